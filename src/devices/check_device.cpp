// SPDX-License-Identifier: Apache-2.0
#include "devices/check_device.hpp"

#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "common/stop_flag.hpp"

namespace hapticd {

namespace {

class Ticker {
  public:
    Ticker(double period, bool lockstep)
        : period_(std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(period * 1e9)))),
          lockstep_(lockstep),
          next_(std::chrono::steady_clock::now()) {}
    void wait() {
        if (lockstep_) return;
        next_ += period_;
        std::this_thread::sleep_until(next_);
    }

  private:
    std::chrono::nanoseconds period_;
    bool lockstep_;
    std::chrono::steady_clock::time_point next_;
};

struct Stop {
    DeviceStatus status = DeviceStatus::Ok;
    std::string message;
};

}  // namespace

ForceSignResult measure_force_sign(Device& device, const ForceSignSettings& s) {
    ForceSignResult result;
    const std::size_t axes = device.capabilities().axes;
    const auto ticks = [&s](double seconds) { return std::max<long>(1, std::lround(seconds / s.period)); };
    Ticker ticker(s.period, s.lockstep);
    AxisVector position{};
    AxisVector zero{};
    Stop stop;
    // One tick: read, check the limit, write `force` on `axis` (0 on the others).
    auto tick = [&](std::size_t axis, double force, double start) -> bool {
        ticker.wait();
        if (const DeviceStatus st = device.read_position(position); st != DeviceStatus::Ok) {
            stop = {st, "reading the position failed: " + device.last_error()};
            return false;
        }
        if (!std::isfinite(position[axis])) {
            stop = {DeviceStatus::HardwareFault, "the device reported a non-finite position"};
            return false;
        }
        if (std::isfinite(start) && std::abs(position[axis] - start) > s.position_limit) {
            stop = {DeviceStatus::Ok, "axis " + std::to_string(axis) + " moved more than " +
                                          std::to_string(s.position_limit) +
                                          " from its start: stopped with zero force (is the handle free to move?)"};
            return false;
        }
        AxisVector f{};
        f[axis] = force;
        if (const DeviceStatus st = device.write_force(f); st != DeviceStatus::Ok) {
            stop = {st, "writing the force failed: " + device.last_error()};
            return false;
        }
        if (stop_requested()) {
            stop = {DeviceStatus::Ok, "interrupted by a stop request"};
            return false;
        }
        return true;
    };
    auto finish = [&](bool ok) {
        device.write_force(zero);
        result.ok = ok;
        result.status = stop.status;
        result.message = stop.message;
        return result;
    };
    for (std::size_t axis = 0; axis < axes; ++axis) {
        // Rest: mean and spread of the position with zero force.
        const long rest = ticks(s.rest_time);
        double sum = 0.0, sum2 = 0.0;
        for (long i = 0; i < rest; ++i) {
            if (!tick(axis, 0.0, NAN)) return finish(false);
            sum += position[axis];
            sum2 += position[axis] * position[axis];
        }
        const double mean = sum / static_cast<double>(rest);
        const double spread = std::sqrt(std::max(0.0, sum2 / static_cast<double>(rest) - mean * mean));
        AxisSign a;
        a.threshold = std::max(s.min_motion, 20.0 * spread);
        const long t = ticks(s.push_time);
        // The first tick's force acts from the next period on (zero-order hold): the displacement of the
        // first phase is read one tick after its last force.
        for (long i = 0; i < t; ++i) {
            if (!tick(axis, s.push_force, mean)) return finish(false);
        }
        if (!tick(axis, -s.push_force, mean)) return finish(false);
        a.displacement = position[axis] - mean;
        for (long i = 1; i < 2 * t; ++i) {
            if (!tick(axis, -s.push_force, mean)) return finish(false);
        }
        for (long i = 0; i < t; ++i) {
            if (!tick(axis, s.push_force, mean)) return finish(false);
        }
        for (long i = 0; i < rest; ++i) {
            if (!tick(axis, 0.0, mean)) return finish(false);
        }
        a.sign = std::abs(a.displacement) <= a.threshold ? 0 : (a.displacement > 0 ? 1 : -1);
        result.axes.push_back(a);
    }
    return finish(true);
}

}  // namespace hapticd
