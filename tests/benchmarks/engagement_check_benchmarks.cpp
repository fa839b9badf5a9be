// SPDX-License-Identifier: Apache-2.0
// What a commit's stability check costs the server thread (docs/protocol.md, section 5, "Engagement
// patterns"): check_engagement_patterns on the scene of a batch that adds one object (ramp 30 ms at 1 kHz:
// the final scene and 29 ramp scenes), against the baseline in the same run — the check that counts every
// object in contact (GainChecker::sum_is_stable on the full sum and ramp_is_stable), which left the subset
// scenes unchecked. Plants: one mass 0.3 kg and the sim3_aniso mass matrix, delay d = 1 and 3.
//  * Typical: a box of 6 unilateral config walls (+-0.05 m, each the CE2 optimum for its axis's mass), a
//    unilateral plane (1000 N/m, 10 N s/m), a bilateral plane (500, 5) and a field (-J = 300 I, 5 N s/m),
//    these three at 1/9 of those gains for d = 3, the field being added: 108 patterns (27 of the box, times 2
//    times 2).
//  * At the limit: 7 unilateral planes on coupled directions (128 patterns, kMaxEngagementPatterns), one of
//    them being added: every pattern stable, so every one is checked.
// The baseline counts every object in contact at once but, like the patterns, not two facing config walls
// (the old rule summed those too, and refused the typical scene: each axis at twice the CE2 optimum).
//  * One direction: 9 different unilateral planes along one normal (512 patterns, the limit at 1/4 per
//    pattern), one being added: scalar verdicts.
// Counters: verdicts (scene checks) per commit; the time is per commit.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "tuning/engagement_patterns.hpp"

namespace {

using namespace hapticd;

constexpr double kBenchPeriod = 1e-3;
constexpr double kBenchRampStep = 1.0 / 30.0;

GainCheckPlant bench_plant(int d, bool anisotropic) {
    GainCheckPlant p;
    p.mass = 0.3;
    p.period = kBenchPeriod;
    p.time_delay = d * kBenchPeriod;
    const MassMatrix aniso{{{0.45, 0.10, 0.12}, {0.10, 0.30, 0.0}, {0.12, 0.0, 0.25}}};  // tests/server/sim3_aniso.toml
    p.mass_matrix = anisotropic ? DeviceMass::from_matrix(aniso, 3) : DeviceMass::isotropic_mass(0.3, 3);
    return p;
}

SceneTerm bench_plane(const std::array<double, 3>& n, double K, double B, bool conditional,
                      SceneTerm::Role role = SceneTerm::Role::Base) {
    SceneTerm t = plane_term(n, K, B);
    t.conditional = conditional;
    t.role = role;
    return t;
}

std::array<double, 3> unit(double x, double y, double z) {
    const double n = std::sqrt(x * x + y * y + z * z);
    return {x / n, y / n, z / n};
}

std::vector<SceneTerm> typical_scene(GainChecker& checker, int d) {
    const double scale = 1.0 / (d * d);  // the client objects' gains at d = 1; softer with more delay
    std::vector<AxisWall> box;
    for (std::size_t a = 0; a < 3; ++a) {
        box.push_back(AxisWall{a, 0.05, 1.0, false});
        box.push_back(AxisWall{a, -0.05, -1.0, false});
    }
    const std::vector<int> pairs = exclusive_wall_pairs(box);
    std::vector<SceneTerm> terms;
    for (std::size_t i = 0; i < box.size(); ++i) {
        std::array<double, 3> e{};
        e[box[i].axis] = 1.0;
        const CriterionGains g =
            checker.criterion_gains(hapticopt::Criterion::CE2, checker.mass().of_axis(box[i].axis));
        terms.push_back(bench_plane(e, g.K, g.B, true));
        terms.back().exclusive_pair = pairs[i];
    }
    const std::array<double, 3> n1 = unit(0.3, 0.5, 0.8), n2 = unit(-0.7, 0.2, 0.4);
    terms.push_back(bench_plane(n1, 1000.0 * scale, 10.0 * scale, true));  // unilateral
    terms.push_back(bench_plane(n2, 500.0 * scale, 5.0 * scale, false));   // bilateral
    SceneTerm field;                                                       // -J = 300 I, damping 5: being added
    for (std::size_t i = 0; i < 3; ++i) {
        field.K[i][i] = 300.0 * scale;
        field.B[i][i] = 5.0 * scale;
    }
    field.conditional = true;
    field.role = SceneTerm::Role::In;
    terms.push_back(field);
    return terms;
}

// 9 different unilateral planes along one normal (512 patterns: the limit, at 1/4 per pattern), one being
// added: scalar verdicts.
std::vector<SceneTerm> one_direction_scene(const GainChecker& checker) {
    std::vector<SceneTerm> terms;
    const std::array<double, 3> n = unit(0.0, 0.6, 0.8);
    const double m = checker.mass_along(n);
    for (int i = 0; i < 9; ++i) {
        terms.push_back(bench_plane(n, (0.001 + 0.0002 * i) * m / (kBenchPeriod * kBenchPeriod),
                                    0.015 * m / kBenchPeriod, true,
                                    i == 0 ? SceneTerm::Role::In : SceneTerm::Role::Base));
    }
    return terms;
}

std::vector<SceneTerm> limit_scene(const GainChecker& checker) {
    std::vector<SceneTerm> terms;
    for (int i = 0; i < 7; ++i) {
        const double a = 0.7 * i;
        const std::array<double, 3> n = unit(std::cos(a), std::sin(a), 0.3 * (i % 3));
        const double m = checker.mass_along(n);
        terms.push_back(bench_plane(n, 0.005 * m / (kBenchPeriod * kBenchPeriod), 0.08 * m / kBenchPeriod, true,
                                    i == 0 ? SceneTerm::Role::In : SceneTerm::Role::Base));
    }
    return terms;
}

// The check before engagement patterns: the full sum, then the ramp scenes (base + s^2 K_in, s B_in).
bool all_in_contact(const GainChecker& checker, const std::vector<SceneTerm>& terms) {
    Matrix3 K{}, B{}, K_in{}, B_in{};
    std::vector<int> pairs_seen;
    for (const SceneTerm& t : terms) {
        if (t.exclusive_pair >= 0) {
            if (std::find(pairs_seen.begin(), pairs_seen.end(), t.exclusive_pair) != pairs_seen.end()) continue;
            pairs_seen.push_back(t.exclusive_pair);
        }
        add_to(K, t.K);
        add_to(B, t.B);
        if (t.role == SceneTerm::Role::In) {
            add_to(K_in, t.K);
            add_to(B_in, t.B);
        }
    }
    std::string why;
    if (!checker.sum_is_stable(K, B, why)) return false;
    Matrix3 K_base = K, B_base = B;
    for (std::size_t r = 0; r < 3; ++r) {
        for (std::size_t c = 0; c < 3; ++c) {
            K_base[r][c] -= K_in[r][c];
            B_base[r][c] -= B_in[r][c];
        }
    }
    return checker.ramp_is_stable(K_base, B_base, K_in, B_in, Matrix3{}, Matrix3{}, kBenchRampStep, why);
}

template <bool Patterns, int Scene>
void BM_CommitCheck(benchmark::State& state) {
    GainChecker checker(bench_plant(static_cast<int>(state.range(0)), state.range(1) != 0));
    const std::vector<SceneTerm> terms = Scene == 1   ? limit_scene(checker)
                                         : Scene == 2 ? one_direction_scene(checker)
                                                      : typical_scene(checker, static_cast<int>(state.range(0)));
    std::size_t checks = 0, patterns = 0;
    for (auto _ : state) {
        if (Patterns) {
            const EngagementCheck c = check_engagement_patterns(checker, terms, kBenchRampStep);
            if (!c.stable) {
                state.SkipWithError(("the benchmark's scene is refused: " + c.why).c_str());
                break;
            }
            checks = c.checks;
            patterns = c.largest_group_patterns;
        } else {
            if (!all_in_contact(checker, terms)) {
                state.SkipWithError("the benchmark's scene is refused");
                break;
            }
            checks = 30;
            patterns = 1;
        }
    }
    state.counters["verdicts"] = static_cast<double>(checks);
    state.counters["patterns"] = static_cast<double>(patterns);
}

void plants(benchmark::internal::Benchmark* b) {
    for (int d : {1, 3}) {
        for (int aniso : {0, 1}) b->Args({d, aniso});
    }
    b->ArgNames({"d", "aniso"})->Unit(benchmark::kMillisecond);
}

BENCHMARK_TEMPLATE(BM_CommitCheck, false, 0)->Name("BM_CommitCheckTypicalAllInContact")->Apply(plants);
BENCHMARK_TEMPLATE(BM_CommitCheck, true, 0)->Name("BM_CommitCheckTypicalEveryPattern")->Apply(plants);
BENCHMARK_TEMPLATE(BM_CommitCheck, false, 1)->Name("BM_CommitCheckAtLimitAllInContact")->Apply(plants);
BENCHMARK_TEMPLATE(BM_CommitCheck, true, 1)->Name("BM_CommitCheckAtLimitEveryPattern")->Apply(plants);
BENCHMARK_TEMPLATE(BM_CommitCheck, false, 2)->Name("BM_CommitCheckOneDirectionAllInContact")->Apply(plants);
BENCHMARK_TEMPLATE(BM_CommitCheck, true, 2)->Name("BM_CommitCheckOneDirectionEveryPattern")->Apply(plants);

}  // namespace
