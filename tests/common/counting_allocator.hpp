// SPDX-License-Identifier: Apache-2.0
// A counting global operator new and delete (counting_allocator.cpp, linked into an allocation test's own
// executable: the replacement is global). Only the thread between start_counting() and stop_counting() counts, so
// the helper threads of the code under test (writers, workers) allocate as they like.
#pragma once

#include <cstdint>

namespace hapticd::test {

struct AllocationCounts {
    std::uint64_t allocations = 0;  // calls of any operator new on the counting thread
    std::uint64_t releases = 0;     // calls of any operator delete with a non-null pointer on the counting thread
};

// Zeroes the counts and counts this thread's calls from now on.
void start_counting() noexcept;
// Stops counting on this thread; the calls counted since start_counting().
AllocationCounts stop_counting() noexcept;

}  // namespace hapticd::test
