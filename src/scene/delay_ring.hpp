// SPDX-License-Identifier: Apache-2.0
// The delay buffer of the wall: a preallocated ring of N samples. The value pushed at tick j comes out
// at tick j + N; the first N values out are zero (no wall force before the first one arrives).
// N = 0 passes the value through. No allocation after construction.
#pragma once

#include <cstddef>
#include <vector>

namespace hapticd {

template <class T>
class DelayRing {
  public:
    explicit DelayRing(std::size_t samples) : buffer_(samples, T{}) {}

    [[nodiscard]] std::size_t samples() const noexcept { return buffer_.size(); }

    // Returns the value pushed samples() calls ago (T{} during the first samples() calls).
    T push_pop(const T& value) noexcept {
        if (buffer_.empty()) {
            return value;
        }
        T out = buffer_[head_];
        buffer_[head_] = value;
        head_ = head_ + 1 == buffer_.size() ? 0 : head_ + 1;
        return out;
    }

    void clear() noexcept {
        for (auto& v : buffer_) {
            v = T{};
        }
        head_ = 0;
    }

  private:
    std::vector<T> buffer_;
    std::size_t head_ = 0;
};

}  // namespace hapticd
