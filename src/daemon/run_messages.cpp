// SPDX-License-Identifier: Apache-2.0
// The lines around the run (run_messages.hpp).
#include "daemon/run_messages.hpp"

#include <cmath>
#include <iostream>
#include <sstream>

#include "daemon/exit_codes.hpp"
#include "loop/realtime_setup.hpp"

namespace hapticd {

void print_startup(std::ostream& out, const Options& o, const DeviceProfile& profile, double period, double delay,
                   std::int64_t period_ns, const std::vector<ResolvedWall>& walls, const RunReport& report,
                   const std::optional<IdentificationStage>& ident,
                   const std::optional<TuningResult>& configured_tuning,
                   const std::optional<IdentifiedTuning>& ident_tuning) {
    out << "hapticd: device '" << profile.name << "' (" << profile.path << ")"
        << (o.simulate || profile.driver == "sim" ? ", simulated" : "") << ": mass ";
    if (profile.mass_model.isotropic) {
        out << profile.mass << (profile.rotary ? " kg m^2" : " kg");
    } else {
        out << profile.mass_model.describe();
    }
    out << ", damping " << profile.damping << ", stiffness " << profile.stiffness << "; rate " << o.rate
        << " Hz (T = " << period * 1e3 << " ms), delay " << delay * 1e3 << " ms = " << delay / period
        << " periods (device " << profile.inherent_delay * 1e3 << " ms + buffer " << o.delay_buffer << ")\n";
    out << "hapticd: velocity estimate " << to_string(profile.velocity_estimator)
        << ": every damper acts on it, and the tuning and every check analyse the loop with it\n";
    if (std::abs(static_cast<double>(period_ns) - 1e9 / o.rate) > 1e-6) {
        out << "hapticd: note: the scheduler period is " << period_ns << " ns (1e9/rate rounded to whole ns); "
            << "the wall and the tuning use T = 1/rate exactly\n";
    }
    if (walls.empty()) out << "hapticd: no walls in the scene: nothing to tune, zero force\n";
    if (ident) {
        out << identification_text(*ident, profile, period) << "\n";
        if (configured_tuning && ident_tuning) {
            out << "hapticd: tuned from the identified plant: K = " << ident_tuning->tuning.K << " +- "
                << ident_tuning->K_stderr << ", B = " << ident_tuning->tuning.B << " +- " << ident_tuning->B_stderr
                << " (from the profile: K = " << configured_tuning->K << ", B = " << configured_tuning->B << ")\n";
        }
    }
    for (const auto& r : report.walls) {
        out << "hapticd: wall " << r.spec << ": " << tuning_line(r.tuning, profile.rotary) << "\n";
        const std::string encoder = encoder_line(r.tuning, profile.rotary);
        if (!encoder.empty()) out << "hapticd: wall " << r.spec << ": " << encoder << "\n";
    }
    if (o.gains_set) {
        for (const auto& w : walls) {
            if (w.spec.criterion)
                out << "hapticd: note: explicit gains override the wall's criterion="
                    << hapticopt::to_string(*w.spec.criterion) << "\n";
        }
    }
}

void apply_realtime_step(RunReport& report, const Options& o, std::ostream& out) {
    report.realtime_requested = true;
    report.realtime = apply_realtime(RealtimeRequest{o.rt_priority, o.mlock, o.cpu});
    if (!o.quiet) {
        out << "hapticd: real-time: SCHED_FIFO "
            << (report.realtime.fifo ? "priority " + std::to_string(o.rt_priority) : std::string("off")) << ", memory "
            << (report.realtime.memory_locked ? "locked" : "not locked") << ", CPU "
            << (report.realtime.pinned ? std::to_string(o.cpu) : std::string("not pinned"))
            << (o.spin_us > 0.0
                    ? ", spinning the last " + std::to_string(std::llround(o.spin_us)) + " us before each tick"
                    : std::string())
            << "\n";
    }
    if (!report.realtime.failures.empty()) {
        std::cerr << "hapticd: warning: real-time setup did not take effect: " << report.realtime.failures
                  << "; running with normal scheduling (see docs/hapticd.md, 'Running without root')\n";
    }
}

void print_running(std::ostream& out, const Options& o, std::uint64_t max_ticks, const SimScenario& scenario,
                   const DeviceProfile& profile) {
    out << "hapticd: running" << (o.lockstep ? " in lockstep" : "")
        << (max_ticks ? " for " + std::to_string(max_ticks) + " ticks" : std::string(" until SIGINT/SIGTERM"))
        << ", scenario " << to_string(scenario.kind);
    if (profile.driver == "sim" || o.simulate) {
        out << " (simulated hand: b_H " << scenario.hand.damping << " N s/m, k_H " << scenario.hand.stiffness << " N/m"
            << (scenario.hand.mass > 0.0 ? ", m_H +" + std::to_string(scenario.hand.mass) + " kg" : std::string())
            << (scenario.schedule.empty() ? std::string() : "; schedule " + describe(scenario.schedule)) << ")";
    }
    out << std::endl;
}

std::string ready_status_text(const DeviceProfile& profile, const std::vector<ResolvedWall>& walls, const Options& o) {
    std::ostringstream ready_status;
    ready_status << "device '" << profile.name << "' open and homed, " << walls.size() << " wall(s) tuned"
                 << (walls.empty() ? std::string() : " (" + tuning_line(walls.front().tuning, profile.rotary) + ")")
                 << ", loop running at " << o.rate << " Hz";
    return ready_status.str();
}

void warn_device_counters(const Device& device, const DeviceProfile& profile, const Options& o) {
    if (const DeviceCounters c = device.counters();
        c.packets_malformed + c.packets_short + c.garbage_bytes > 0 && !o.quiet) {
        std::cerr << "hapticd: warning: device '" << profile.name << "': " << c.packets_malformed << " malformed and "
                  << c.packets_short << " short packets dropped, " << c.garbage_bytes
                  << " bytes skipped while resynchronising (" << c.packets_ok << " good packets)\n";
    }
}

int fault_exit_code(const RunReport& report, const Options& o, const DeviceProfile& profile) {
    int code = kExitOk;
    switch (report.run.fault) {
        case StateFault::None:
            break;
        case StateFault::Device:
            code = kExitDeviceError;
            std::cerr << "hapticd: error: device '" << profile.name << "' failed at tick " << report.run.fault_tick
                      << ": " << report.device_error << "; zero force, loop stopped\n";
            break;
        case StateFault::NonFinite:
            code = kExitRunFault;
            std::cerr << "hapticd: error: fault at tick " << report.run.fault_tick << ": "
                      << to_string(report.run.scene_fault) << "; zero force, loop stopped\n";
            break;
        case StateFault::Watchdog:
            code = kExitRunFault;
            std::cerr << "hapticd: error: watchdog fault at tick " << report.run.fault_tick << ": more than "
                      << o.watchdog_overruns << " consecutive overruns or a stall of more than "
                      << o.watchdog_stall_periods << " periods; zero force, loop stopped\n";
            break;
        case StateFault::FatalSignal:
        case StateFault::Terminate:
            break;  // written only into the shared memory, by daemon/fatal_signal.cpp, as the process ends
    }
    return code;
}

}  // namespace hapticd
