// SPDX-License-Identifier: Apache-2.0
// In a forked process (gtest death test, "fast" style: the state segment is mapped before the fork):
// std::terminate with the daemon's fatal handlers installed writes fault 5 and SIGABRT into the state,
// calls the device's signal-safe zero, and ends the process by SIGABRT. The fatal signals themselves are
// tested on a real daemon process (test_server_lifecycle.cpp).
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <csignal>
#include <exception>
#include <string>

#include "daemon/fatal_signal.hpp"
#include "devices/device.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {
namespace {

// A device whose only observable act is the signal-safe zero: it writes a byte into shared memory.
class ZeroMarkDevice final : public Device {
  public:
    explicit ZeroMarkDevice(volatile char* mark) : mark_(mark) {}
    DeviceStatus open() override { return DeviceStatus::Ok; }
    DeviceStatus home() override { return DeviceStatus::Ok; }
    void close() noexcept override {}
    bool zero_force_from_signal_handler() noexcept override {
        *mark_ = 'z';
        return true;
    }
    DeviceStatus read_position(AxisVector& p) noexcept override {
        p = AxisVector{};
        return DeviceStatus::Ok;
    }
    DeviceStatus write_force(const AxisVector&) noexcept override { return DeviceStatus::Ok; }
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return caps_; }
    [[nodiscard]] std::string_view name() const noexcept override { return "zero-mark"; }
    [[nodiscard]] std::string last_error() const override { return {}; }

  private:
    volatile char* mark_;
    DeviceCapabilities caps_{};
};

TEST(FatalSignalHandlers, TerminateMarksTheStateAndZeroesTheDeviceFirst) {
    GTEST_FLAG_SET(death_test_style, "fast");
    const std::string shm = "/hapticd-test-fatal-" + std::to_string(::getpid());
    StatePublisher state(shm, 3, 1e-3, -1);
    state.publish(StateTick{}, nullptr);
    auto* mark =
        static_cast<volatile char*>(::mmap(nullptr, 1, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0));
    ASSERT_NE(mark, MAP_FAILED);
    *mark = '-';
    ZeroMarkDevice device(mark);
    EXPECT_EXIT(
        {
            install_fatal_signal_handlers(&device, &state);
            std::terminate();
        },
        ::testing::KilledBySignal(SIGABRT),
        "hapticd: fatal: std::terminate; zero force written to the device; the state says fault 5");
    StateLayout s{};
    ASSERT_TRUE(state.read(s));
    EXPECT_EQ(s.fault, static_cast<std::uint32_t>(StateFault::Terminate));
    EXPECT_EQ(*mark, 'z');
    ::munmap(const_cast<char*>(mark), 1);
}

}  // namespace
}  // namespace hapticd
