// SPDX-License-Identifier: Apache-2.0
// The client's StateReader against a segment written by this test (include/hapticd/state_layout.hpp): a writer
// preempted inside a publication (the sequence odd) is waited for, and a writer that never leaves it (stalled, or
// killed mid-write) makes read() return false once the stale age has passed, not at once and not never.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "hapticd/client.hpp"

namespace hapticd::client_state_reader_test {

namespace cl = hapticd::client;

// A segment as the daemon's StatePublisher lays it out, writable by the test; unlinked on destruction.
class HandWrittenSegment {
  public:
    HandWrittenSegment(const std::string& name, double period_s) : name_(name) {
        const int fd = ::shm_open(name.c_str(), O_CREAT | O_EXCL | O_RDWR, 0600);
        EXPECT_GE(fd, 0) << name;
        EXPECT_EQ(::ftruncate(fd, sizeof(StateLayout)), 0);
        void* p = ::mmap(nullptr, sizeof(StateLayout), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        ::close(fd);
        EXPECT_NE(p, MAP_FAILED);
        layout_ = static_cast<StateLayout*>(p);
        layout_->layout_version = kStateLayoutVersion;
        layout_->size = sizeof(StateLayout);
        layout_->axes = 3;
        layout_->period_s = period_s;
        layout_->mesh_proxy_capacity = static_cast<std::uint32_t>(kStateMeshProxyCapacity);
        layout_->sequence.store(2, std::memory_order_relaxed);
        layout_->tick = 1;
        std::atomic_thread_fence(std::memory_order_release);
        layout_->magic = kStateMagic;
    }
    ~HandWrittenSegment() {
        ::munmap(layout_, sizeof(StateLayout));
        ::shm_unlink(name_.c_str());
    }
    HandWrittenSegment(const HandWrittenSegment&) = delete;
    HandWrittenSegment& operator=(const HandWrittenSegment&) = delete;
    StateLayout& layout() { return *layout_; }

  private:
    std::string name_;
    StateLayout* layout_ = nullptr;
};

std::string segment_name(const char* tag) {
    return "/hapticd-test-reader-" + std::string(tag) + "-" + std::to_string(::getpid());
}

// The writer enters a publication and is held there 20 ms before it writes tick 2: read() returns tick 2. The
// header's period of 0.1 s makes the stale age 1 s, fifty times the hold, so a loaded machine delaying the writer
// thread does not reach it.
TEST(StateReader, WaitsForAWriterHeldInsideAPublication) {
    HandWrittenSegment segment(segment_name("held"), 0.1);
    StateLayout& l = segment.layout();
    const cl::StateReader reader = cl::StateReader::open(segment_name("held"));
    ASSERT_DOUBLE_EQ(reader.stale_after_s(), 1.0);
    l.sequence.store(3, std::memory_order_relaxed);  // odd: inside a publication
    std::atomic_thread_fence(std::memory_order_release);
    std::thread writer([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        l.tick = 2;
        l.sequence.store(4, std::memory_order_release);
    });
    cl::StateSample s;
    const bool read = reader.read(s, 1);
    writer.join();
    ASSERT_TRUE(read);
    EXPECT_EQ(s.tick, 2U);
}

// The sequence held odd for good: read() gives up, and not before the stale age (50 ms for a 1 ms period).
TEST(StateReader, GivesUpOnAWriterThatNeverLeavesItsPublicationAfterTheStaleAge) {
    HandWrittenSegment segment(segment_name("dead"), 1e-3);
    const cl::StateReader reader = cl::StateReader::open(segment_name("dead"));
    ASSERT_DOUBLE_EQ(reader.stale_after_s(), 0.05);
    cl::StateSample s;
    ASSERT_TRUE(reader.read(s));
    EXPECT_EQ(s.tick, 1U);
    segment.layout().sequence.store(5, std::memory_order_release);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_FALSE(reader.read(s));
    EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.05);
}

}  // namespace hapticd::client_state_reader_test
