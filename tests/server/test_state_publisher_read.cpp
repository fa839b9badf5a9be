// SPDX-License-Identifier: Apache-2.0
// The server thread's read of the state (StatePublisher::read, server/state_publisher.hpp) against the real
// publisher's segment, its sequence held odd by this test as a loop preempted inside a publication holds it: the
// read waits for the publication to end, and gives up once the stale age has passed (not at once, not never).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "server/state_publisher.hpp"

namespace hapticd::state_publisher_read_test {

// The publisher's segment mapped writable a second time, as the loop's side of the seqlock.
struct WriterView {
    explicit WriterView(const std::string& name) {
        const int fd = ::shm_open(name.c_str(), O_RDWR, 0);
        EXPECT_GE(fd, 0) << name;
        void* p = ::mmap(nullptr, sizeof(StateLayout), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        ::close(fd);
        EXPECT_NE(p, MAP_FAILED);
        layout = static_cast<StateLayout*>(p);
    }
    ~WriterView() { ::munmap(layout, sizeof(StateLayout)); }
    WriterView(const WriterView&) = delete;
    WriterView& operator=(const WriterView&) = delete;
    StateLayout* layout = nullptr;
};

// A 0.1 s period: the stale age is 1 s, fifty times the 20 ms the publication is held.
TEST(StatePublisherRead, WaitsForAPublicationHeldByAPreemptedLoop) {
    const std::string name = "/hapticd-test-pubread-held-" + std::to_string(::getpid());
    StatePublisher publisher(name, 3, 0.1, -1);
    StateTick t;
    t.tick = 1;
    publisher.publish(t, nullptr);
    WriterView w(name);
    const std::uint64_t s = w.layout->sequence.load(std::memory_order_relaxed);
    w.layout->sequence.store(s + 1, std::memory_order_relaxed);  // odd: inside a publication
    std::thread loop([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        w.layout->tick = 2;
        w.layout->sequence.store(s + 2, std::memory_order_release);
    });
    StateLayout out{};
    const bool read = publisher.read(out);
    loop.join();
    ASSERT_TRUE(read);
    EXPECT_EQ(out.tick, 2U);
}

// A 1 ms period (stale age 50 ms) and a publication that never ends: false, after at least 50 ms.
TEST(StatePublisherRead, GivesUpOnALoopStalledInsideAPublicationAfterTheStaleAge) {
    const std::string name = "/hapticd-test-pubread-stalled-" + std::to_string(::getpid());
    StatePublisher publisher(name, 3, 1e-3, -1);
    StateTick t;
    t.tick = 7;
    publisher.publish(t, nullptr);
    StateLayout out{};
    ASSERT_TRUE(publisher.read(out));
    EXPECT_EQ(out.tick, 7U);
    WriterView w(name);
    w.layout->sequence.fetch_add(1, std::memory_order_release);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_FALSE(publisher.read(out));
    EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.05);
}

}  // namespace hapticd::state_publisher_read_test
