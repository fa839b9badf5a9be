// SPDX-License-Identifier: Apache-2.0
#include "daemon/daemon.hpp"

namespace hapticd {

Daemon::Daemon(Device& device, Scene& scene, TraceWriter* trace, const DaemonConfig& config)
    : device_(device),
      scene_(scene),
      trace_(trace),
      config_(config),
      loop_(config.loop),
      delay_(config.delay_samples),
      limiter_(config.max_force > 0.0 ? config.max_force : scene.max_force(),
               config.max_force_rate > 0.0
                   ? config.max_force_rate
                   : default_max_force_rate(config.max_force > 0.0 ? config.max_force : scene.max_force(),
                                            static_cast<double>(config.loop.period_ns) * 1e-9),
               static_cast<double>(config.loop.period_ns) * 1e-9, kMaxAxes),
      watchdog_(config.watchdog) {
    if (config_.max_ticks != 0) final_tick_ = config_.max_ticks - 1;
    result_.stop_ticks = limiter_.stop_ticks();
}

RunResult Daemon::run() noexcept {
    result_.counters = loop_.run([this](const TickInput& in) { return tick(in); });
    result_.limiter = limiter_.stats();
    return result_;
}

}  // namespace hapticd
