// SPDX-License-Identifier: Apache-2.0
// Bounded lock-free single-producer single-consumer ring (capacity rounded up to a power of two),
// preallocated at construction. try_push() is called by one producer; try_pop(), or front() and pop(), by
// one consumer.
#pragma once

#include <atomic>
#include <cstddef>
#include <new>
#include <vector>

namespace hapticd {

template <class T>
class SpscRing {
  public:
    explicit SpscRing(std::size_t capacity) : buffer_(round_up(capacity)), mask_(buffer_.size() - 1) {}

    [[nodiscard]] std::size_t capacity() const noexcept { return buffer_.size(); }

    // Producer only: true when try_push would fail now (the consumer may free a place right after).
    [[nodiscard]] bool full() noexcept {
        const std::size_t head = head_.load(std::memory_order_relaxed);
        if (head - tail_cache_ == buffer_.size()) tail_cache_ = tail_.load(std::memory_order_acquire);
        return head - tail_cache_ == buffer_.size();
    }

    bool try_push(const T& value) noexcept {
        const std::size_t head = head_.load(std::memory_order_relaxed);
        if (head - tail_cache_ == buffer_.size()) {
            tail_cache_ = tail_.load(std::memory_order_acquire);
            if (head - tail_cache_ == buffer_.size()) {
                return false;
            }
        }
        buffer_[head & mask_] = value;
        head_.store(head + 1, std::memory_order_release);
        return true;
    }

    bool try_pop(T& out) noexcept {
        const std::size_t tail = tail_.load(std::memory_order_relaxed);
        if (tail == head_cache_) {
            head_cache_ = head_.load(std::memory_order_acquire);
            if (tail == head_cache_) {
                return false;
            }
        }
        out = buffer_[tail & mask_];
        tail_.store(tail + 1, std::memory_order_release);
        return true;
    }

    // Consumer: the oldest element, left in the ring (nullptr when empty). It stays valid and unchanged until
    // pop(): the producer never writes a slot that has not been popped. Lets the consumer decide whether to
    // take an element now without copying it out first.
    [[nodiscard]] const T* front() noexcept {
        const std::size_t tail = tail_.load(std::memory_order_relaxed);
        if (tail == head_cache_) {
            head_cache_ = head_.load(std::memory_order_acquire);
            if (tail == head_cache_) {
                return nullptr;
            }
        }
        return &buffer_[tail & mask_];
    }

    // Consumer: removes the element front() returned (only after a non-null front()).
    void pop() noexcept { tail_.store(tail_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

  private:
    static std::size_t round_up(std::size_t n) {
        std::size_t c = 2;
        while (c < n) c <<= 1U;
        return c;
    }

    std::vector<T> buffer_;
    std::size_t mask_;
    alignas(64) std::atomic<std::size_t> head_{0};
    alignas(64) std::size_t tail_cache_ = 0;  // producer's view of tail_
    alignas(64) std::atomic<std::size_t> tail_{0};
    alignas(64) std::size_t head_cache_ = 0;  // consumer's view of head_
};

}  // namespace hapticd
