// SPDX-License-Identifier: Apache-2.0
// Two handles, one spring between them (docs/clients.md, "Two devices: a spring between the handles"): two
// hapticd instances (--left, --right: hapticd --instance NAME, one device each) each render one end, a spring
// whose anchor is the other handle's position, read from the other's state segment and moved at --update-rate
// (the loop interpolates each move over the measured update interval: docs/protocol.md, section 4).
//
// Stability. Without delay the two ends' forces are equal and opposite, F_L = -K_c (x_L - x_R) - B_c (v_L - v_R) =
// -F_R, so the relative coordinate d = x_L - x_R obeys mu d'' = -K_c d - B_c d', mu = m_L m_R / (m_L + m_R) (m/2 for
// two equal masses): a wall (K_c, B_c) on the mass mu. The anchor reaches the loop late by at most
//   t_c = t_d + T_u + 2 T + L
// (t_d the loop's delay from the welcome, the larger of the two; T_u = 1 / --update-rate, the interpolation over
// one update interval; 2 T: the age of the other's state sample and the wait for the next tick; L =
// --latency-budget, the socket and the scheduling), and the model delays the whole force by t_c (the own-position
// terms, delayed by t_d only in the loop, are given the anchor's delay). K_c, B_c are hapticopt's robust optimum of
// --criterion for mu over the two devices' plant sets (their mass_scale) at t_c, or --stiffness/--damping, refused
// unless hapticopt::robust_stability certifies them over that set (exit 5). While it runs, an update later than
// T_u + L after the previous one breaks the model: the springs are removed and it exits with 6.
// At the end it prints the mean and the spread of both positions and of d over the last quarter of the run.
//   two_handed_spring [--left left] [--right right] [--update-rate 500] [--duration 5] [--latency-budget 0.001]
//                     [--criterion CE2 | --stiffness K_c --damping B_c]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include <hapticopt/hapticopt.hpp>

#include "example_options.hpp"

namespace hc = hapticd::client;

namespace {

// The moving masses a device's plant set holds (docs/robust-stability.md): its mass times mass_scale[0] .. [1].
// std::nullopt for a mass matrix that is not m I (this example models one mass per device).
std::optional<std::pair<double, double>> mass_set(const hc::DeviceInfo& d) {
    const double m = d.mass_matrix[0][0];
    for (std::size_t i = 0; i < d.axes; ++i) {
        for (std::size_t j = 0; j < d.axes; ++j) {
            if (d.mass_matrix[i][j] != (i == j ? m : 0.0)) return std::nullopt;
        }
    }
    return std::make_pair(m * d.mass_scale[0], m * d.mass_scale[1]);
}

double reduced_mass(double a, double b) { return a * b / (a + b); }

struct Spread {
    double mean = 0.0, stddev = 0.0;
};
Spread spread(const std::vector<double>& v) {
    Spread s;
    if (v.empty()) return s;
    for (double x : v) s.mean += x;
    s.mean /= static_cast<double>(v.size());
    for (double x : v) s.stddev += (x - s.mean) * (x - s.mean);
    s.stddev = std::sqrt(s.stddev / static_cast<double>(v.size()));
    return s;
}

}  // namespace

int main(int argc, char** argv) {
    const examples::Options o(argc, argv,
                              {{"left", "left"},
                               {"right", "right"},
                               {"update-rate", "500"},
                               {"duration", "5"},
                               {"latency-budget", "0.001"},
                               {"criterion", "CE2"},
                               {"stiffness", "0"},
                               {"damping", "0"}});
    const double rate = o.number("update-rate");
    const double duration = o.number("duration");
    const double latency = o.number("latency-budget");
    const double K_given = o.number("stiffness");
    const double B_given = o.number("damping");
    if (!(rate >= 10.0 && rate <= 1000.0) || !(duration > 0.0) || !(latency >= 0.0 && latency <= 0.1) ||
        K_given < 0.0 || B_given < 0.0) {
        std::fprintf(stderr,
                     "two_handed_spring: accepted: --update-rate 10 .. 1000 Hz, --duration > 0 s, --latency-budget "
                     "0 .. 0.1 s, --stiffness and --damping >= 0 (0: hapticopt's robust optimum)\n");
        return 2;
    }
    const std::optional<hapticopt::Criterion> parsed = hapticopt::parse_criterion(o.text("criterion"));
    if (!parsed || !(*parsed == hapticopt::Criterion::CE0 || *parsed == hapticopt::Criterion::CE1 ||
                     *parsed == hapticopt::Criterion::CE2)) {
        std::fprintf(stderr, "two_handed_spring: --criterion '%s'; accepted: CE0, CE1, CE2 (robust energy optima)\n",
                     o.text("criterion").c_str());
        return 2;
    }
    const hapticopt::Criterion criterion = *parsed;
    examples::install_stop_handlers();
    bool connected = false;
    try {
        // The devices first, in sessions without a lease (the analysis below may take longer than one).
        hc::ConnectOptions co;
        co.client_name = "two_handed_spring";
        co.instance = o.text("left");
        hc::Client probe_l = hc::Client::connect(co);
        co.instance = o.text("right");
        hc::Client probe_r = hc::Client::connect(co);
        connected = true;
        const hc::DeviceInfo dl = probe_l.welcome().device;
        const hc::DeviceInfo dr = probe_r.welcome().device;
        probe_l.bye();
        probe_r.bye();
        const auto ml = mass_set(dl);
        const auto mr = mass_set(dr);
        if (!ml || !mr || dl.period_s != dr.period_s) {
            std::fprintf(stderr,
                         "two_handed_spring: the model needs one mass per device (m I) and one period; accepted: "
                         "two such devices at the same rate (left %s: %g s, right %s: %g s)\n",
                         dl.name.c_str(), dl.period_s, dr.name.c_str(), dr.period_s);
            return 2;
        }
        const double T = dl.period_s;
        const double t_c = std::max(dl.delay_s, dr.delay_s) + 1.0 / rate + 2.0 * T + latency;
        hapticopt::UncertainPlant box;
        box.mass = {reduced_mass(ml->first, mr->first), reduced_mass(ml->second, mr->second)};
        box.period = T;
        box.time_delay = {t_c, t_c};
        double K_c = K_given, B_c = B_given;
        const char* source = "--stiffness/--damping";
        if (K_given > 0.0) {
            if (!hapticopt::robust_stability(box, {K_c, B_c}).stable) {
                const auto limit = hapticopt::robust_optimum(criterion, box);
                std::fprintf(stderr,
                             "two_handed_spring: K_c = %g N/m, B_c = %g N s/m are not stable for the relative "
                             "coordinate (mu %.4g .. %.4g kg, delay %.3g ms); accepted: a pair hapticopt certifies, "
                             "e.g. the robust %s optimum K_c = %.4g N/m, B_c = %.4g N s/m (K_max %.4g N/m)\n",
                             K_c, B_c, box.mass.min, box.mass.max, t_c * 1e3, o.text("criterion").c_str(),
                             limit.gains.stiffness, limit.gains.damping, limit.K_max);
                return 5;
            }
        } else {
            const auto opt = hapticopt::robust_optimum(criterion, box);
            if (!opt.stability.stable) {
                std::fprintf(stderr, "two_handed_spring: no robustly stable optimum at delay %.3g ms\n", t_c * 1e3);
                return 5;
            }
            K_c = opt.gains.stiffness;
            B_c = opt.gains.damping;
            source = "hapticopt robust optimum";
        }
        std::printf(
            "two_handed_spring: mu %.4g .. %.4g kg, T %g ms, delay t_c %.4g ms (d = %.3g), K_c = %.6g N/m, B_c = %.6g "
            "N s/m (%s %s)\n",
            box.mass.min, box.mass.max, T * 1e3, t_c * 1e3, t_c / T, K_c, B_c, source, o.text("criterion").c_str());
        std::fflush(stdout);

        co.lease_s = 0.5;  // every update renews it; a frozen example loses both springs within 0.5 s
        co.instance = o.text("left");
        hc::Client left = hc::Client::connect(co);
        co.instance = o.text("right");
        hc::Client right = hc::Client::connect(co);
        const hc::StateReader sl = hc::StateReader::open(left.welcome().state_shm);
        const hc::StateReader sr = hc::StateReader::open(right.welcome().state_shm);
        hc::StateSample a, b;
        if (!sl.read(a) || !sr.read(b) || a.stale || b.stale) {
            std::fprintf(stderr, "two_handed_spring: a state segment is stale or unreadable\n");
            return 8;
        }
        const hc::Gains gains = hc::Gains::explicit_gains(K_c, B_c);
        hc::Spring to_right{hc::Constraint::Point, b.position, {1.0, 0.0, 0.0}, gains};  // rendered on the left
        hc::Spring to_left{hc::Constraint::Point, a.position, {1.0, 0.0, 0.0}, gains};   // rendered on the right
        const std::uint32_t id_l = left.commit(hc::Batch().add(to_right)).object_ids.front();
        const std::uint32_t id_r = right.commit(hc::Batch().add(to_left)).object_ids.front();

        const auto period = std::chrono::duration<double>(1.0 / rate);
        const double late_after = 1.0 / rate + latency;
        std::vector<double> xl, xr;
        std::uint64_t updates = 0;
        const auto start = std::chrono::steady_clock::now();
        auto previous = start;
        int code = 0;
        for (auto next = start; !examples::g_stop;
             next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period)) {
            std::this_thread::sleep_until(next);
            const auto now = std::chrono::steady_clock::now();
            const double t = std::chrono::duration<double>(now - start).count();
            if (t >= duration) break;
            const double interval = std::chrono::duration<double>(now - previous).count();
            if (updates > 0 && interval > late_after) {
                std::fprintf(stderr,
                             "two_handed_spring: update %llu came %.3f ms after the previous one; the stability "
                             "argument allows %.3f ms (1 / --update-rate + --latency-budget): springs removed\n",
                             static_cast<unsigned long long>(updates), interval * 1e3, late_after * 1e3);
                code = 6;
                break;
            }
            previous = now;
            if (!sl.read(a) || !sr.read(b) || a.stale || b.stale) {
                std::fprintf(stderr, "two_handed_spring: a state segment went stale: springs removed\n");
                code = 8;
                break;
            }
            to_right.point = b.position;
            to_left.point = a.position;
            left.commit(hc::Batch().modify(id_l, to_right));
            right.commit(hc::Batch().modify(id_r, to_left));
            ++updates;
            xl.push_back(a.position[0]);
            xr.push_back(b.position[0]);
        }
        const std::size_t tail = xl.size() / 4;
        const std::vector<double> xl_tail(xl.end() - static_cast<std::ptrdiff_t>(tail), xl.end());
        const std::vector<double> xr_tail(xr.end() - static_cast<std::ptrdiff_t>(tail), xr.end());
        std::vector<double> d_tail(tail);
        for (std::size_t i = 0; i < tail; ++i) d_tail[i] = xl_tail[i] - xr_tail[i];
        const Spread sxl = spread(xl_tail), sxr = spread(xr_tail), sd = spread(d_tail);
        std::printf(
            "two_handed_spring: %llu updates; last quarter (%zu updates): x_left %.6g m (sd %.3g), x_right %.6g m "
            "(sd %.3g), x_left - x_right %.6g m (sd %.3g)\n",
            static_cast<unsigned long long>(updates), tail, sxl.mean, sxl.stddev, sxr.mean, sxr.stddev, sd.mean,
            sd.stddev);
        left.bye();  // both springs ramp out
        right.bye();
        return code;
    } catch (const hc::Error& e) {
        std::fprintf(stderr, "two_handed_spring: %s\n", e.what());
        return examples::exit_code(e, connected);
    } catch (const std::invalid_argument& e) {  // a bad instance name, a plant hapticopt refuses (named)
        std::fprintf(stderr, "two_handed_spring: %s\n", e.what());
        return 2;
    }
}
