// SPDX-License-Identifier: Apache-2.0
#include "daemon/report.hpp"

#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

namespace hapticd {

std::string tuning_line(const TuningResult& t, bool rotary) {
    char buf[1024];
    const char* ku = rotary ? "N m/rad" : "N/m";
    const char* bu = rotary ? "N m s/rad" : "N s/m";
    std::string cost = "n/a";
    if (t.cost) {
        char c[64];
        std::snprintf(c, sizeof c, "%.6g", *t.cost);
        cost = c;
    }
    const std::string criterion(hapticopt::to_string(t.criterion));
    std::snprintf(buf, sizeof buf,
                  "%s: K = %.6g %s, B = %.6g %s, alpha = %.6g, beta = %.6g, predicted %s = %s, "
                  "alpha/alpha_max = %.4f (alpha_max = %.6g)",
                  t.explicit_gains ? "explicit gains" : ("tuned for " + criterion).c_str(), t.K, ku, t.B, bu, t.alpha,
                  t.beta, criterion.c_str(), cost.c_str(), t.stability_margin(), t.alpha_max);
    std::string line = buf;
    if (t.plant_set) {
        const PlantSetCertificate& c = *t.plant_set;
        std::string derated;
        if (c.derating < 1.0) {
            std::snprintf(buf, sizeof buf, " derated to %.6g x the %s optimum to be", c.derating, criterion.c_str());
            derated = buf;
        }
        std::snprintf(buf, sizeof buf, ";%s stable for every mass %.4g .. %.4g kg (%s)", derated.c_str(), c.mass_min,
                      c.mass_max, c.exact ? "exact" : "sampled");
        line += buf;
        if (c.arm_stiffness_per_mass > 0.0 || c.arm_damping_per_mass > 0.0) {
            std::snprintf(buf, sizeof buf, " with every arm k_H / m <= %.4g s^-2, b_H / m <= %.4g s^-1 (%s)",
                          c.arm_stiffness_per_mass, c.arm_damping_per_mass, c.arm_certified ? "certified" : "sampled");
            line += buf;
        }
        if (c.delay_max > c.delay_min) {
            std::snprintf(buf, sizeof buf, " at every total delay %.4g .. %.4g ms (%s)", c.delay_min * 1e3,
                          c.delay_max * 1e3, c.delay_exact ? "certified" : "estimated");
            line += buf;
        }
    }
    if (t.robust) {
        const RobustSummary& r = *t.robust;
        std::snprintf(buf, sizeof buf,
                      "; robust over mass %.6g..%.6g, damping %.6g..%.6g, stiffness %.6g..%.6g, delay %.6g..%.6g ms: "
                      "worst %s = %.6g at mass %.6g, damping %.6g, stiffness %.6g, delay %.6g ms (the nominal "
                      "optimum's worst case: %.6g); stability over the mass range %s; alpha, beta, alpha_max of the "
                      "box centre",
                      r.box.mass_min, r.box.mass_max, r.box.damping_min, r.box.damping_max, r.box.stiffness_min,
                      r.box.stiffness_max, r.box.delay_min * 1e3, r.box.delay_max * 1e3, criterion.c_str(),
                      r.worst_case, r.worst_mass, r.worst_damping, r.worst_stiffness, r.worst_delay * 1e3,
                      r.nominal_worst_case, r.mass_certified ? "proven" : "checked on a grid");
        line += buf;
        if (r.box.force_noise_budget && r.force_noise_max) {
            std::snprintf(buf, sizeof buf, "; force noise at most %.4g N over the box (budget %.4g N)",
                          *r.force_noise_max, *r.box.force_noise_budget);
            line += buf;
        }
    }
    return line;
}

std::string encoder_line(const TuningResult& t, bool rotary) {
    if (!t.force_noise_std) return {};
    char buf[1024];
    const char* fu = rotary ? "N m" : "N";
    std::snprintf(buf, sizeof buf,
                  "encoder step %.6g %s: force noise sigma_F = %.4g %s while the handle moves over many steps "
                  "(white-noise model, the loop's velocity estimate)",
                  t.position_resolution, rotary ? "rad" : "m", *t.force_noise_std, fu);
    std::string line = buf;
    if (t.chatter) {
        const EncoderChatter& c = *t.chatter;
        std::snprintf(buf, sizeof buf,
                      "; at rest in contact each count steps the force by %.3g %s on its first tick (B q / T times "
                      "the estimator's newest weight), and a rest holds every push only with Coulomb friction >= K q "
                      "/ 2 = %.3g %s; the profile's coulomb_friction %.3g %s: %s",
                      c.count_kick, fu, c.friction_for_rest, fu, c.coulomb_friction, fu,
                      c.rest_for_every_push ? "a rest holds every push" : "no rest for some pushes");
        line += buf;
        if (c.backward_difference) {
            std::snprintf(buf, sizeof buf, "; Abbott-Okamura bound K <= %.4g (B = 0, no delay): %s",
                          c.abbott_okamura_bound, c.abbott_okamura_passive ? "met" : "not met");
            line += buf;
        }
        if (c.cycle_predicted) {
            std::snprintf(
                buf, sizeof buf,
                "; %s (describing function with that friction, push half-way between two counts: %.3g %s "
                "at %.3g Hz)",
                c.rest_for_every_push ? "a cycle may coexist with the rest" : "the handle keeps moving between counts",
                c.cycle_amplitude * (rotary ? 1.0 : 1e6), rotary ? "rad" : "um", c.cycle_frequency);
            line += buf;
        }
    }
    return line;
}

std::string statistics_text(const RunReport& r) {
    std::string s;
    char buf[512];
    const auto& c = r.run.counters;
    std::snprintf(buf, sizeof buf,
                  "ticks %llu, overruns %llu (skipped periods %llu, longest run %u), trace drops %llu\n",
                  static_cast<unsigned long long>(c.ticks), static_cast<unsigned long long>(c.overruns),
                  static_cast<unsigned long long>(c.skipped_periods), c.max_consecutive_overruns,
                  static_cast<unsigned long long>(r.trace_dropped));
    s += buf;
    if (r.loop != nullptr) {
        s += "wake latency: " + r.loop->wake_latency().summary_line() + "\n";
        s += "compute time: " + r.loop->compute_time().summary_line() + "\n";
        s += "wake latency histogram (us):";
        for (const auto& bin : r.loop->wake_latency().coarse_histogram()) {
            if (bin.count == 0) continue;
            std::snprintf(buf, sizeof buf, " <%g: %llu", bin.upper_us, static_cast<unsigned long long>(bin.count));
            s += buf;
        }
        s += "\n";
    }
    if (r.options != nullptr) {
        const Options& o = *r.options;
        const ForceLimiterStats& l = r.run.limiter;
        std::snprintf(buf, sizeof buf,
                      "force limiter: %.6g N/s (step %.6g N per tick), rate-limited ticks %llu, saturated ticks %llu, "
                      "largest step %.6g N, stop window %llu ticks\n",
                      o.max_force_rate, o.max_force_rate * r.period,
                      static_cast<unsigned long long>(l.rate_limited_ticks),
                      static_cast<unsigned long long>(l.saturated_ticks), l.largest_step,
                      static_cast<unsigned long long>(r.run.stop_ticks));
        s += buf;
    }
    if (r.passivity_control) {
        const PassivityControlStats& p = r.passivity;
        std::snprintf(
            buf, sizeof buf,
            "passivity control: damper on %llu ticks (capped %llu, guarded %llu, saturated %llu, non-finite %llu), "
            "max added damping %.6g N s/m, dissipated %.6g J, observed energy min %.6g J, port energy min %.6g J "
            "(bound: -(shortfall %.6g J + prediction error %.6g J))\n",
            static_cast<unsigned long long>(p.damper_ticks), static_cast<unsigned long long>(p.capped_ticks),
            static_cast<unsigned long long>(p.guarded_ticks), static_cast<unsigned long long>(p.saturated_ticks),
            static_cast<unsigned long long>(p.nonfinite_events), p.max_added_damping, p.dissipated,
            p.min_observed_energy, p.min_port_energy, p.shortfall, p.prediction_error);
        s += buf;
    }
    return s;
}

namespace {

// The keys of one wall's tuning (shared by the headline and the per-wall list).
nlohmann::json tuning_json(const TuningResult& t) {
    nlohmann::json j;
    j["criterion"] = std::string(hapticopt::to_string(t.criterion));
    j["explicit_gains"] = t.explicit_gains;
    j["K"] = t.K;
    j["B"] = t.B;
    j["alpha"] = t.alpha;
    j["beta"] = t.beta;
    j["predicted_cost"] = t.cost ? nlohmann::json(*t.cost) : nlohmann::json(nullptr);
    j["alpha_max"] = t.alpha_max;
    j["stability_margin"] = t.stability_margin();
    if (t.plant_set) {
        j["plant_set"] = {{"mass", {t.plant_set->mass_min, t.plant_set->mass_max}},
                          {"arm_stiffness_per_mass", t.plant_set->arm_stiffness_per_mass},
                          {"arm_damping_per_mass", t.plant_set->arm_damping_per_mass},
                          {"delay_s", {t.plant_set->delay_min, t.plant_set->delay_max}},
                          {"delay_exact", t.plant_set->delay_exact},
                          {"derating", t.plant_set->derating},
                          {"exact", t.plant_set->exact}};
    } else {
        j["plant_set"] = nullptr;
    }
    j["position_resolution"] = t.position_resolution;
    j["force_noise_std"] = t.force_noise_std ? nlohmann::json(*t.force_noise_std) : nlohmann::json(nullptr);
    if (t.chatter) {
        const EncoderChatter& c = *t.chatter;
        j["encoder_chatter"] = {
            {"count_kick", c.count_kick},
            {"friction_for_rest", c.friction_for_rest},
            {"coulomb_friction", c.coulomb_friction},
            {"rest_for_every_push", c.rest_for_every_push},
            {"abbott_okamura_passive",
             c.backward_difference ? nlohmann::json(c.abbott_okamura_passive) : nlohmann::json(nullptr)},
            {"abbott_okamura_bound",
             c.backward_difference ? nlohmann::json(c.abbott_okamura_bound) : nlohmann::json(nullptr)},
            {"cycle_amplitude", c.cycle_predicted ? nlohmann::json(c.cycle_amplitude) : nlohmann::json(nullptr)},
            {"cycle_frequency", c.cycle_predicted ? nlohmann::json(c.cycle_frequency) : nlohmann::json(nullptr)}};
    } else {
        j["encoder_chatter"] = nullptr;
    }
    if (t.robust) {
        const RobustSummary& r = *t.robust;
        auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
        j["robust"] = {
            {"mass", {r.box.mass_min, r.box.mass_max}},
            {"damping", {r.box.damping_min, r.box.damping_max}},
            {"stiffness", {r.box.stiffness_min, r.box.stiffness_max}},
            {"delay", {r.box.delay_min, r.box.delay_max}},
            {"worst_case", r.worst_case},
            {"worst_at",
             {{"mass", r.worst_mass},
              {"damping", r.worst_damping},
              {"stiffness", r.worst_stiffness},
              {"delay", r.worst_delay}}},
            {"nominal_worst_case", finite_or_null(r.nominal_worst_case)},
            {"mass_stability_certified", r.mass_certified},
            {"force_noise_budget",
             r.box.force_noise_budget ? nlohmann::json(*r.box.force_noise_budget) : nlohmann::json(nullptr)},
            {"force_noise_max", r.force_noise_max ? nlohmann::json(*r.force_noise_max) : nlohmann::json(nullptr)}};
    }
    return j;
}

}  // namespace

nlohmann::json summary_json(const RunReport& r) {
    nlohmann::json j;
    const Options& o = *r.options;
    const DeviceProfile& p = *r.profile;
    // The first wall's tuning is the headline (the one --criterion chose for walls without their own);
    // with no walls the tuning keys are null.
    if (r.walls.empty()) {
        j["criterion"] = std::string(hapticopt::to_string(o.criterion));
        j["explicit_gains"] = false;
        for (const char* key : {"K", "B", "alpha", "beta", "predicted_cost", "alpha_max", "stability_margin",
                                "force_noise_std", "encoder_chatter"}) {
            j[key] = nullptr;
        }
        j["position_resolution"] = nullptr;
    } else {
        j.update(tuning_json(r.walls.front().tuning));
    }
    // mass: one number for compatibility — the profile's one mass, or for an anisotropic profile the mass
    // along axis 0, 1 / (M^-1)_00. The full plant: mass_matrix, M on the device's axes row by row (m I for
    // one mass), and axis_masses, per axis a the mass a wall on that axis acts with and was tuned for
    // (unless --identify replaced the profile's one mass), 1 / (M^-1)_aa (= M_aa for a diagonal M;
    // config/profile_keys.hpp, wall_tuning.cpp). All the profile's values, not identified ones.
    j["mass"] = p.mass;
    const DeviceMass& M = p.mass_model;
    nlohmann::json matrix = nlohmann::json::array(), axis_masses = nlohmann::json::array();
    for (std::size_t a = 0; a < M.axes; ++a) {
        nlohmann::json row = nlohmann::json::array();
        for (std::size_t b = 0; b < M.axes; ++b) row.push_back(M.matrix[a][b]);
        matrix.push_back(row);
        axis_masses.push_back(M.of_axis(a));
    }
    j["mass_matrix"] = matrix;
    j["axis_masses"] = axis_masses;
    j["max_stiffness"] = p.max_stiffness ? nlohmann::json(*p.max_stiffness) : nlohmann::json(nullptr);
    j["damping"] = p.damping;
    j["stiffness"] = p.stiffness;
    j["period"] = r.period;
    j["rate"] = o.rate;
    j["delay"] = r.delay;
    j["inherent_delay"] = p.inherent_delay;
    j["velocity_estimator"] = to_string(p.velocity_estimator);
    j["delay_buffer"] = o.delay_buffer;
    j["device"] = p.name;
    j["device_profile"] = p.path;
    j["scenario"] = o.scenario;
    j["lockstep"] = o.lockstep;
    j["spin_us"] = o.spin_us;
    nlohmann::json walls = nlohmann::json::array();
    for (const auto& w : r.walls) {
        nlohmann::json wj = tuning_json(w.tuning);
        wj["spec"] = w.spec;
        walls.push_back(wj);
    }
    j["walls"] = walls;
    const auto& c = r.run.counters;
    j["ran"] = r.ran;
    j["ticks"] = c.ticks;
    j["overruns"] = c.overruns;
    j["skipped_periods"] = c.skipped_periods;
    j["max_consecutive_overruns"] = c.max_consecutive_overruns;
    j["saturated_ticks"] = r.saturated_ticks;
    j["force_limiter"] = {{"max_force_rate", o.max_force_rate},
                          {"max_step", o.max_force_rate * r.period},
                          {"rate_limited_ticks", r.run.limiter.rate_limited_ticks},
                          {"saturated_ticks", r.run.limiter.saturated_ticks},
                          {"largest_step", r.run.limiter.largest_step},
                          {"stop_ticks", r.run.stop_ticks}};
    if (r.passivity_control) {
        const PassivityControlStats& p = r.passivity;
        j["passivity_control"] = {{"damper_ticks", p.damper_ticks},
                                  {"capped_ticks", p.capped_ticks},
                                  {"guarded_ticks", p.guarded_ticks},
                                  {"saturated_ticks", p.saturated_ticks},
                                  {"nonfinite_events", p.nonfinite_events},
                                  {"max_added_damping", p.max_added_damping},
                                  {"dissipated", p.dissipated},
                                  {"shortfall", p.shortfall},
                                  {"prediction_error", p.prediction_error},
                                  {"min_observed_energy", p.min_observed_energy},
                                  {"min_port_energy", p.min_port_energy}};
    } else {
        j["passivity_control"] = nullptr;
    }
    if (r.loop != nullptr) {
        j["wake_latency"] = r.loop->wake_latency().to_json();
        j["compute_time"] = r.loop->compute_time().to_json();
    }
    j["trace_drops"] = r.trace_dropped;
    j["trace_records"] = r.trace_written;
    j["trace_write_error"] = r.trace_error;
    j["fault"] = std::string(to_string(r.run.fault));
    j["fault_tick"] = r.run.fault != StateFault::None ? nlohmann::json(r.run.fault_tick) : nlohmann::json(nullptr);
    if (r.run.fault == StateFault::NonFinite) j["fault_detail"] = std::string(to_string(r.run.scene_fault));
    if (r.run.fault == StateFault::Device) j["fault_detail"] = r.device_error;
    j["stopped_by_signal"] = r.run.stopped_by_signal;
    j["session_max_objects"] = o.session_max_objects;
    j["session_max_in_flight"] = o.session_max_in_flight;
    j["realtime"] = {{"requested", r.realtime_requested},
                     {"sched_fifo", r.realtime.fifo},
                     {"mlockall", r.realtime.memory_locked},
                     {"cpu_pinned", r.realtime.pinned},
                     {"failures", r.realtime.failures}};
    j["exit_code"] = r.exit_code;
    return j;
}

}  // namespace hapticd
