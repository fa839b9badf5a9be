// SPDX-License-Identifier: Apache-2.0
#include "identification/identification_run.hpp"

#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "devices/device_factory.hpp"
#include "common/stop_flag.hpp"

namespace hapticd {

namespace {

std::uint64_t next_random(std::uint64_t& state) {
    state ^= state >> 12U;
    state ^= state << 25U;
    state ^= state >> 27U;
    return state * 0x2545F4914F6CDD1DULL;
}

// Writes zero force on the way out unless disarmed.
struct ZeroForceOnExit {
    Device& device;
    ~ZeroForceOnExit() {
        const AxisVector zero{};
        (void)device.write_force(zero);
    }
};

std::string fmt(double v, int digits = 6) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

void add_ns(timespec& t, std::int64_t ns) {
    t.tv_nsec += ns;
    while (t.tv_nsec >= 1000000000L) {
        t.tv_nsec -= 1000000000L;
        ++t.tv_sec;
    }
}

}  // namespace

namespace {

struct Block {
    std::size_t start = 0;   // tick
    std::size_t length = 0;  // L
    double amplitude = 0.0;  // A with its random sign
};

// The blocks and the total length (blocks + settle tail + 1).
std::vector<Block> excitation_blocks(const ExcitationSettings& s, std::size_t& total) {
    std::vector<Block> blocks;
    total = 0;
    const double T = s.period;
    if (!(T > 0.0) || !(s.force_limit > 0.0) || !(s.position_limit > 0.0) || !(s.design_mass > 0.0)) return blocks;
    const auto n_exc = static_cast<std::size_t>(std::llround(std::max(0.0, s.duration) / T));
    const auto n_settle = static_cast<std::size_t>(std::llround(std::max(0.0, s.settle) / T));
    const double m_safe = s.design_mass / std::max(1.0, s.mass_margin);
    const double peak = s.excursion_fraction * s.position_limit;
    std::uint64_t rng = s.seed == 0 ? 0x9E3779B97F4A7C15ULL : s.seed;
    constexpr std::array<double, 6> kBlockTimes{0.002, 0.004, 0.008, 0.016, 0.032, 0.064};  // s
    std::array<std::size_t, 6> lengths{};
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        lengths[i] = static_cast<std::size_t>(std::max(1LL, std::llround(kBlockTimes[i] / T)));
    }
    std::size_t used = 0;
    while (true) {
        std::size_t fitting = 0;
        while (fitting < lengths.size() && used + 4 * lengths[fitting] <= n_exc) ++fitting;
        if (fitting == 0) break;
        const std::uint64_t r = next_random(rng);
        const std::size_t L = lengths[(r >> 8U) % fitting];
        const double sign = ((r >> 40U) & 1U) != 0U ? 1.0 : -1.0;
        const double LT = static_cast<double>(L) * T;
        const double A = sign * std::min(s.block_force_fraction * s.force_limit, peak * m_safe / (LT * LT));
        blocks.push_back({used, L, A});
        used += 4 * L;
    }
    total = n_exc + n_settle + 1;
    return blocks;
}

// Block value at offset i of a block of length L and amplitude A: +A (L), -A (2L), +A (L).
double block_value(std::size_t i, std::size_t L, double A) { return i < L || i >= 3 * L ? A : -A; }

}  // namespace

std::vector<double> excitation_signal(const ExcitationSettings& s) {
    std::size_t total = 0;
    const std::vector<Block> blocks = excitation_blocks(s, total);
    std::vector<double> u(total, 0.0);
    for (const Block& b : blocks) {
        for (std::size_t i = 0; i < 4 * b.length; ++i) u[b.start + i] = block_value(i, b.length, b.amplitude);
    }
    return u;
}

ExcitationRecord run_excitation(Device& device, const ExcitationSettings& s) {
    ExcitationRecord rec;
    rec.data.period = s.period;
    const DeviceCapabilities& caps = device.capabilities();
    if (s.axis >= caps.axes || s.axis >= kMaxAxes) {
        rec.abort_reason = "axis " + std::to_string(s.axis) + " is not an axis of the device";
        return rec;
    }
    ExcitationSettings settings = s;
    settings.force_limit = std::min(s.force_limit, caps.max_force);
    if (!(settings.force_limit > 0.0) || !(settings.position_limit > 0.0)) {
        rec.abort_reason = "the force and position limits must be > 0";
        return rec;
    }
    ZeroForceOnExit zero_on_exit{device};
    const std::int64_t period_ns = std::llround(s.period * 1e9);
    timespec deadline{};
    clock_gettime(CLOCK_MONOTONIC, &deadline);
    std::vector<Block> blocks;  // computed after the first read (the workspace limits the position limit)
    std::size_t total = 0;
    std::size_t block = 0;
    double block_sign = 1.0;
    AxisVector pos{};
    AxisVector cmd{};
    const AxisVector zero{};
    double limit = settings.position_limit;
    // Centering: a weak PD on the deviation from the start (natural frequency centering_hz, damping ratio
    // 0.7 for the design mass), so that a spring's resonance or a drift cannot accumulate over blocks.
    const double wc = 2.0 * 3.14159265358979323846 * s.centering_hz;
    const double Kc = s.design_mass * wc * wc;
    const double Bc = 2.0 * 0.7 * s.design_mass * wc;
    constexpr std::size_t kVelocityLag = 5;  // periods of the backward difference
    for (std::size_t j = 0;; ++j) {
        if (j > 0 && j >= total) break;
        if (s.paced) {
            add_ns(deadline, period_ns);
            while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) != 0 && !stop_requested()) {
            }
        }
        if (stop_requested()) {
            rec.stopped = true;
            rec.abort_reason = "stopped by a signal";
            return rec;
        }
        if (const DeviceStatus st = device.read_position(pos); st != DeviceStatus::Ok) {
            rec.status = st;
            rec.abort_reason = "device error while reading the position: " + device.last_error();
            return rec;
        }
        const double y = pos[s.axis];
        if (!std::isfinite(y)) {
            (void)device.write_force(zero);
            rec.abort_reason = "non-finite position at tick " + std::to_string(j);
            return rec;
        }
        if (j == 0) {
            rec.start_position = y;
            const double room = std::min(y - caps.workspace_min[s.axis], caps.workspace_max[s.axis] - y);
            if (!(room > 0.0)) {
                (void)device.write_force(zero);
                rec.abort_reason = "the start position " + fmt(y) + " is outside the workspace";
                return rec;
            }
            if (std::isfinite(room)) limit = std::min(limit, 0.5 * room);
            settings.position_limit = limit;
            blocks = excitation_blocks(settings, total);
            if (blocks.empty()) {
                (void)device.write_force(zero);
                rec.abort_reason = "empty excitation (check period, limits and mass)";
                return rec;
            }
        }
        const double excursion = std::abs(y - rec.start_position);
        rec.max_excursion = std::max(rec.max_excursion, excursion);
        if (excursion > s.guard_fraction * limit) {
            (void)device.write_force(zero);
            rec.guard_tripped = true;
            rec.abort_reason = "position guard: moved " + fmt(excursion) + " from the start, more than " +
                               fmt(s.guard_fraction * limit) + " (" + fmt(s.guard_fraction) + " of the limit " +
                               fmt(limit) + ")";
            return rec;
        }
        double centering = -Kc * (y - rec.start_position);
        if (j >= kVelocityLag) {
            centering -=
                Bc * (y - rec.data.position[j - kVelocityLag]) / (static_cast<double>(kVelocityLag) * s.period);
        }
        // The blocks use at most block_force_fraction of the limit and the centering the rest, so the sum
        // is never clipped (a clipped block would lose its zero net impulse).
        const double reserve = (1.0 - s.block_force_fraction) * settings.force_limit;
        centering = std::clamp(centering, -reserve, reserve);
        // Block sign: random, unless the device is already away from the start or moving (a spring's
        // ringing, a drift): then the block's first push opposes the position predicted L periods ahead,
        // so blocks take energy out instead of pumping a resonance.
        double feedforward = 0.0;
        while (block < blocks.size() && j >= blocks[block].start + 4 * blocks[block].length) ++block;
        if (block < blocks.size() && j >= blocks[block].start) {
            const Block& b = blocks[block];
            if (j == b.start) {
                block_sign = 1.0;
                if (j >= kVelocityLag) {
                    const double v =
                        (y - rec.data.position[j - kVelocityLag]) / (static_cast<double>(kVelocityLag) * s.period);
                    const double ahead = (y - rec.start_position) + v * static_cast<double>(b.length) * s.period;
                    if (std::abs(ahead) > 0.05 * limit) block_sign = (ahead > 0.0) == (b.amplitude > 0.0) ? -1.0 : 1.0;
                }
            }
            feedforward = block_sign * block_value(j - b.start, b.length, b.amplitude);
        }
        const double f = std::clamp(feedforward + centering, -settings.force_limit, settings.force_limit);
        cmd = zero;
        cmd[s.axis] = f;
        if (const DeviceStatus st = device.write_force(cmd); st != DeviceStatus::Ok) {
            rec.status = st;
            rec.abort_reason = "device error while writing the force: " + device.last_error();
            return rec;
        }
        rec.max_abs_force = std::max(rec.max_abs_force, std::abs(f));
        rec.data.position.push_back(y);
        rec.data.force.push_back(f);
    }
    rec.completed = true;
    return rec;
}

IdentifiedTuning tune_identified(hapticopt::Criterion criterion, const IdentificationResult& r, double period,
                                 double extra_delay, const VelocityEstimatorSpec& velocity) {
    auto plant_of = [&](double m, double b, double k, double d) {
        return TuningPlant{m,       std::max(0.0, b), std::max(0.0, k), period, std::max(0.0, d) * period + extra_delay,
                           velocity};
    };
    IdentifiedTuning out;
    out.plant = plant_of(r.mass, r.damping, r.stiffness, r.delay_periods);
    out.tuning = tune_wall(criterion, out.plant);
    const std::array<double, 4> x{r.mass, std::max(0.0, r.damping), std::max(0.0, r.stiffness),
                                  std::max(0.0, r.delay_periods)};
    const std::array<double, 4> se{r.mass_stderr, r.damping_stderr, r.stiffness_stderr, r.delay_stderr};
    const std::array<double, 4> floor{1e-6 * r.mass, 1e-6 * r.mass / period, 1e-6 * r.mass / (period * period), 1e-4};
    std::array<double, 4> gK{};
    std::array<double, 4> gB{};
    for (std::size_t i = 0; i < 4; ++i) {
        std::array<double, 4> xi = x;
        const double h = std::max(0.5 * se[i], floor[i]);
        xi[i] += h;
        const TuningResult t = tune_wall(criterion, plant_of(xi[0], xi[1], xi[2], xi[3]));
        gK[i] = (t.K - out.tuning.K) / h;
        gB[i] = (t.B - out.tuning.B) / h;
    }
    double vK = 0.0;
    double vB = 0.0;
    for (std::size_t i = 0; i < 4; ++i) {
        for (std::size_t j = 0; j < 4; ++j) {
            vK += gK[i] * r.covariance[4 * i + j] * gK[j];
            vB += gB[i] * r.covariance[4 * i + j] * gB[j];
        }
    }
    out.K_stderr = std::sqrt(std::max(0.0, vK));
    out.B_stderr = std::sqrt(std::max(0.0, vB));
    return out;
}

nlohmann::json identification_to_json(const IdentificationResult& r, const std::string& device) {
    nlohmann::json j;
    j["format"] = "hapticd-identification";
    j["version"] = 1;
    j["device"] = device;
    j["period"] = r.period;
    j["mass"] = r.mass;
    j["mass_stderr"] = r.mass_stderr;
    j["damping"] = r.damping;
    j["damping_stderr"] = r.damping_stderr;
    j["stiffness"] = r.stiffness;
    j["stiffness_stderr"] = r.stiffness_stderr;
    j["delay_periods"] = r.delay_periods;
    j["delay_stderr_periods"] = r.delay_stderr;
    j["delay_whole_periods"] = r.delay_whole;
    j["delay_fraction"] = r.delay_fraction;
    j["delay_s"] = r.delay_periods * r.period;
    j["offset_force"] = r.offset_force;
    j["offset_force_stderr"] = r.offset_force_stderr;
    j["residual_rms"] = r.residual_rms;
    j["samples"] = r.samples;
    j["arx_delay"] = r.arx_delay;
    j["covariance_mbkd"] = r.covariance;
    return j;
}

IdentificationResult identification_from_json(const nlohmann::json& j, std::string& device) {
    if (!j.is_object() || j.value("format", std::string()) != "hapticd-identification") {
        throw std::runtime_error("not a hapticd identification file (\"format\": \"hapticd-identification\" missing)");
    }
    auto num = [&](const char* key) {
        if (!j.contains(key) || !j[key].is_number())
            throw std::runtime_error(std::string("missing or non-numeric key '") + key + "'");
        const double v = j[key].get<double>();
        if (!std::isfinite(v)) throw std::runtime_error(std::string("key '") + key + "' is not finite");
        return v;
    };
    IdentificationResult r;
    device = j.value("device", std::string());
    r.period = num("period");
    r.mass = num("mass");
    r.mass_stderr = num("mass_stderr");
    r.damping = num("damping");
    r.damping_stderr = num("damping_stderr");
    r.stiffness = num("stiffness");
    r.stiffness_stderr = num("stiffness_stderr");
    r.delay_periods = num("delay_periods");
    r.delay_stderr = num("delay_stderr_periods");
    r.offset_force = j.contains("offset_force") ? num("offset_force") : 0.0;
    r.residual_rms = j.contains("residual_rms") ? num("residual_rms") : 0.0;
    r.samples = j.value("samples", std::size_t{0});
    r.arx_delay = j.value("arx_delay", -1);
    if (!(r.period > 0.0) || !(r.mass > 0.0) || r.delay_periods < 0.0 || r.mass_stderr < 0.0 ||
        r.damping_stderr < 0.0 || r.stiffness_stderr < 0.0 || r.delay_stderr < 0.0) {
        throw std::runtime_error("period and mass must be > 0, delay and standard errors >= 0");
    }
    if (j.contains("covariance_mbkd")) {
        const auto& c = j["covariance_mbkd"];
        if (!c.is_array() || c.size() != 16) throw std::runtime_error("covariance_mbkd must be an array of 16 numbers");
        for (std::size_t i = 0; i < 16; ++i) r.covariance[i] = c[i].get<double>();
    } else {
        const std::array<double, 4> se{r.mass_stderr, r.damping_stderr, r.stiffness_stderr, r.delay_stderr};
        for (std::size_t i = 0; i < 4; ++i) r.covariance[5 * i] = se[i] * se[i];
    }
    r.delay_whole = static_cast<long long>(std::floor(r.delay_periods));
    r.delay_fraction = r.delay_periods - static_cast<double>(r.delay_whole);
    r.ok = true;
    return r;
}

std::vector<std::string> compare_identifications(const IdentificationResult& a, const IdentificationResult& b,
                                                 double n_sigma) {
    std::vector<std::string> changes;
    const double T = b.period > 0.0 ? b.period : 1e-3;
    const double m = std::max(a.mass, b.mass);
    struct Item {
        const char* name;
        const char* unit;
        double va, sa, vb, sb, floor;
    };
    const Item items[] = {
        {"mass", "kg", a.mass, a.mass_stderr, b.mass, b.mass_stderr, 0.01 * m},
        {"damping", "N s/m", a.damping, a.damping_stderr, b.damping, b.damping_stderr,
         std::max(0.05 * std::max(std::abs(a.damping), std::abs(b.damping)), 0.01 * m / T)},
        {"stiffness", "N/m", a.stiffness, a.stiffness_stderr, b.stiffness, b.stiffness_stderr, 1e-3 * m / (T * T)},
        {"delay", "periods", a.delay_periods, a.delay_stderr, b.delay_periods, b.delay_stderr, 0.1},
    };
    for (const Item& it : items) {
        const double diff = std::abs(it.vb - it.va);
        const double sigma = std::hypot(it.sa, it.sb);
        if (diff > std::max(n_sigma * sigma, it.floor)) {
            changes.push_back(std::string(it.name) + " changed: " + fmt(it.va) + " +- " + fmt(it.sa, 2) + " -> " +
                              fmt(it.vb) + " +- " + fmt(it.sb, 2) + " " + it.unit + " (" +
                              fmt(sigma > 0.0 ? diff / sigma : 0.0, 3) + " standard errors)");
        }
    }
    return changes;
}

std::optional<IdentificationStage> run_identification_stage(const Options& o, const DeviceProfile& p, double period,
                                                            std::ostream& out, std::ostream& err) {
    if (!o.identify && o.identification_file.empty()) return std::nullopt;
    IdentificationStage stage;
    stage.file = o.identification_file;
    std::optional<IdentificationResult> previous;
    if (!stage.file.empty() && std::filesystem::exists(stage.file)) {
        std::ifstream in(stage.file);
        std::string device;
        try {
            const nlohmann::json j = nlohmann::json::parse(in);
            previous = identification_from_json(j, device);
        } catch (const std::exception& e) {
            throw StartupError(ErrorKind::BadConfig, "identification-file '" + stage.file + "': " + e.what());
        }
        if (device != p.name) {
            err << "hapticd: warning: identification-file '" << stage.file << "' is for device '" << device
                << "', not '" << p.name << "': not used\n";
            previous.reset();
        } else if (std::abs(previous->period - period) > 1e-12 * period) {
            // The delay is kept in seconds; its share in periods changes with the rate.
            err << "hapticd: warning: identification-file '" << stage.file
                << "' was measured at T = " << previous->period << " s, now T = " << period
                << " s: delay converted through seconds\n";
            const double scale = previous->period / period;
            previous->delay_periods *= scale;
            previous->delay_stderr *= scale;
            for (std::size_t i = 0; i < 4; ++i) {
                previous->covariance[4 * i + 3] *= scale;
                previous->covariance[4 * 3 + i] *= scale;
            }
            previous->delay_whole = static_cast<long long>(std::floor(previous->delay_periods));
            previous->delay_fraction = previous->delay_periods - static_cast<double>(previous->delay_whole);
            previous->period = period;
        }
    }
    if (!o.identify) {
        if (!previous) {
            if (!std::filesystem::exists(stage.file)) {
                err << "hapticd: warning: identification-file '" << stage.file
                    << "' does not exist and --identify was not given: tuning from the profile\n";
            }
            return std::nullopt;
        }
        stage.reused = true;
        stage.result = *previous;
        return stage;
    }

    // The excitation. A simulated device is excited untouched (no scenario force: at rest, nobody holding
    // it); a real device as it is.
    SimScenario neutral;
    neutral.kind = Scenario::Hold;
    neutral.hold_force = 0.0;
    neutral.hold_distance = 0.0;
    std::unique_ptr<Device> device = make_device(p, o, neutral, period);
    install_stop_signal_handlers();  // SIGINT/SIGTERM during the excitation: zero force, clean exit
    ExcitationSettings& s = stage.excitation;
    s.axis = 0;
    s.period = period;
    s.duration = o.identify_duration;
    s.force_limit = o.identify_force > 0.0 ? std::min(o.identify_force, p.max_force) : 0.25 * p.max_force;
    s.position_limit = o.identify_distance > 0.0 ? o.identify_distance : (p.rotary ? 0.05 : 0.005);
    s.design_mass = p.mass;
    s.paced = !o.lockstep;
    if (!o.quiet) {
        out << "hapticd: identifying: " << s.duration << " s of force pulses within " << s.force_limit
            << (p.rotary ? " N m and " : " N and ") << s.position_limit << (p.rotary ? " rad" : " m") << " on axis 0"
            << std::endl;
    }
    if (device->open() != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device,
                           "identification: device '" + p.name + "': open failed: " + device->last_error());
    }
    if (device->home() != DeviceStatus::Ok) {
        const std::string e = device->last_error();
        device->close();
        throw StartupError(ErrorKind::Device, "identification: device '" + p.name + "': homing failed: " + e);
    }
    stage.record = run_excitation(*device, s);
    device->close();  // zero force
    if (!stage.record.completed) {
        const ErrorKind kind = stage.record.stopped         ? ErrorKind::Ok
                               : stage.record.guard_tripped ? ErrorKind::RunFault
                                                            : ErrorKind::Device;
        throw StartupError(kind, "identification aborted: " + stage.record.abort_reason + "; zero force");
    }
    stage.result = identify_plant(stage.record.data);
    stage.record.data = IdentificationData{};
    if (!stage.result.ok) {
        throw StartupError(ErrorKind::Device, "identification failed: " + stage.result.message);
    }
    stage.excited = true;
    if (stage.result.mass_stderr > 0.05 * stage.result.mass) {
        err << "hapticd: warning: identified mass is uncertain (standard error "
            << fmt(stage.result.mass_stderr / stage.result.mass * 100, 3)
            << " %): a larger --identify-force or --identify-distance helps\n";
    }
    if (previous) stage.changes = compare_identifications(*previous, stage.result);
    for (const auto& c : stage.changes) {
        err << "hapticd: warning: the device changed since '" << stage.file << "': " << c << "\n";
    }
    if (!stage.file.empty()) {
        std::ofstream f(stage.file);
        f << identification_to_json(stage.result, p.name).dump(2) << "\n";
        f.close();
        if (!f) throw StartupError(ErrorKind::Usage, "identification-file = '" + stage.file + "': cannot write");
        stage.saved = true;
    }
    return stage;
}

std::string identification_text(const IdentificationStage& st, const DeviceProfile& p, double period) {
    const IdentificationResult& r = st.result;
    const char* mu = p.rotary ? " kg m^2" : " kg";
    std::string s = "hapticd: identified (" +
                    std::string(st.excited ? "excitation, " + std::to_string(r.samples) + " samples, residual rms " +
                                                 fmt(r.residual_rms, 3)
                                           : "from '" + st.file + "'") +
                    "), configured -> identified +- standard error:\n";
    s += "hapticd:   mass " + fmt(p.mass) + " -> " + fmt(r.mass) + " +- " + fmt(r.mass_stderr, 2) + mu + "\n";
    s += "hapticd:   damping " + fmt(p.damping) + " -> " + fmt(r.damping) + " +- " + fmt(r.damping_stderr, 2) + "\n";
    s += "hapticd:   stiffness " + fmt(p.stiffness) + " -> " + fmt(r.stiffness) + " +- " + fmt(r.stiffness_stderr, 2) +
         "\n";
    s += "hapticd:   delay " + fmt(p.inherent_delay / period) + " -> " + fmt(r.delay_periods, 5) + " +- " +
         fmt(r.delay_stderr, 2) + " periods (" + std::to_string(r.delay_whole) + " whole + " +
         fmt(r.delay_fraction, 3) + ")";
    if (st.saved) s += "\nhapticd:   saved to '" + st.file + "'";
    return s;
}

nlohmann::json identification_summary_json(const IdentificationStage& st, const DeviceProfile& p, double period,
                                           const TuningResult* configured, const IdentifiedTuning* identified) {
    nlohmann::json j = identification_to_json(st.result, p.name);
    j.erase("format");
    j.erase("version");
    j["source"] = st.excited ? "excitation" : "file";
    j["file"] = st.file.empty() ? nlohmann::json(nullptr) : nlohmann::json(st.file);
    j["saved"] = st.saved;
    j["changes"] = st.changes;
    j["configured"] = {{"mass", p.mass},
                       {"damping", p.damping},
                       {"stiffness", p.stiffness},
                       {"delay_periods", p.inherent_delay / period}};
    if (st.excited) {
        j["excitation"] = {{"force_limit", st.excitation.force_limit}, {"position_limit", st.excitation.position_limit},
                           {"duration", st.excitation.duration},       {"seed", st.excitation.seed},
                           {"max_abs_force", st.record.max_abs_force}, {"max_excursion", st.record.max_excursion}};
    }
    if (configured != nullptr) {
        j["configured_tuning"] = {
            {"K", configured->K}, {"B", configured->B}, {"alpha", configured->alpha}, {"beta", configured->beta}};
    }
    if (identified != nullptr) {
        j["K"] = identified->tuning.K;
        j["K_stderr"] = identified->K_stderr;
        j["B"] = identified->tuning.B;
        j["B_stderr"] = identified->B_stderr;
    }
    return j;
}

}  // namespace hapticd
