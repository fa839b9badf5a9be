// SPDX-License-Identifier: Apache-2.0
// Engagement patterns (tuning/engagement_patterns.hpp, docs/protocol.md section 5): every sum of the
// always-engaged objects and a subset of the conditional ones is checked, at the final scene and at every
// ramp scene. The grouping into M-orthogonal groups is compared with a brute-force enumeration of every
// pattern of the whole scene, written here without groups, exclusive pairs or de-duplication.
#include <random>

#include <gtest/gtest.h>

#include "tuning/engagement_patterns.hpp"

namespace hapticd {
namespace engagement_test {

constexpr double kPeriod = 1e-3;

GainCheckPlant pattern_plant(double delay, bool anisotropic) {
    GainCheckPlant p;
    p.mass = 0.3;
    p.period = kPeriod;
    p.time_delay = delay;
    const MassMatrix aniso{{{0.45, 0.10, 0.12}, {0.10, 0.30, 0.0}, {0.12, 0.0, 0.25}}};  // tests/server/sim3_aniso.toml
    p.mass_matrix = anisotropic ? DeviceMass::from_matrix(aniso, 3) : DeviceMass::isotropic_mass(0.3, 3);
    return p;
}

SceneTerm plane(const std::array<double, 3>& n, double K, double B, bool conditional, std::uint32_t id,
                SceneTerm::Role role = SceneTerm::Role::Base) {
    SceneTerm t = plane_term(n, K, B);
    t.conditional = conditional;
    t.object_id = id;
    t.role = role;
    return t;
}

// The reproduction (sim3_aniso mass, d = 1): bilateral planes A, B along n = (0, -0.6, -0.8) with K 12739.29,
// B 25.4786 (A + B: spectral radius 1.00397) and C along n with K 1000, B 30 (A + B + C: 0.9762). With C
// bilateral every scene the loop renders is A + B + C: accepted. With C unilateral the loop renders A + B
// while the handle is out of C: refused, naming the pattern.
TEST(EngagementPatterns, ASubsetUnstableWhileTheFullSumIsStableIsRefused) {
    const GainChecker checker(pattern_plant(kPeriod, true));
    const std::array<double, 3> n{0.0, -0.6, -0.8};
    std::vector<SceneTerm> terms{plane(n, 12739.29, 25.4786, false, 11), plane(n, 12739.29, 25.4786, false, 12),
                                 plane(n, 1000.0, 30.0, false, 13)};
    std::string why;
    for (const SceneTerm& t : terms) ASSERT_TRUE(checker.sum_is_stable(t.K, t.B, why)) << why;
    EngagementCheck bilateral = check_engagement_patterns(checker, terms, 1.0);
    EXPECT_TRUE(bilateral.stable) << bilateral.why;
    EXPECT_EQ(bilateral.checks, 1U);
    terms[2].conditional = true;
    const EngagementCheck unilateral = check_engagement_patterns(checker, terms, 1.0);
    EXPECT_FALSE(unilateral.stable);
    EXPECT_FALSE(unilateral.over_limit);
    EXPECT_EQ(unilateral.checks, 2U);  // the all-engaged pattern (stable), then C out of contact (unstable)
    EXPECT_NE(unilateral.why.find("in contact and [13] not"), std::string::npos) << unilateral.why;
    // C ramping in over A + B (a batch adding C): the final scene's pattern is refused before any ramp scene.
    terms[2].role = SceneTerm::Role::In;
    const EngagementCheck ramp = check_engagement_patterns(checker, terms, 1.0 / 30.0);
    EXPECT_FALSE(ramp.stable);
    EXPECT_EQ(ramp.why.find("during the ramp"), std::string::npos) << ramp.why;
    EXPECT_NE(ramp.why.find("[13] not"), std::string::npos) << ramp.why;
}

// The brute force: every subset of the conditional terms over the whole scene, every ramp scene.
bool every_pattern_stable(const GainChecker& checker, const std::vector<SceneTerm>& terms, double step) {
    std::vector<std::size_t> conditional;
    for (std::size_t i = 0; i < terms.size(); ++i) {
        if (terms[i].conditional) conditional.push_back(i);
    }
    std::vector<double> scenes{1.0};
    for (int j = 1; step < 1.0 && j * step < 1.0; ++j) scenes.push_back(j * step);
    for (const double s : scenes) {
        for (std::size_t mask = 0; mask < (std::size_t{1} << conditional.size()); ++mask) {
            Matrix3 K{}, B{};
            for (std::size_t i = 0; i < terms.size(); ++i) {
                bool engaged = !terms[i].conditional;
                for (std::size_t c = 0; c < conditional.size(); ++c)
                    engaged = engaged || (conditional[c] == i && ((mask >> c) & 1U));
                if (!engaged) continue;
                const double wk = terms[i].role == SceneTerm::Role::Base ? 1.0
                                  : terms[i].role == SceneTerm::Role::In ? s * s
                                                                         : (1 - s) * (1 - s);
                const double wb = terms[i].role == SceneTerm::Role::Base ? 1.0
                                  : terms[i].role == SceneTerm::Role::In ? s
                                                                         : 1 - s;
                for (std::size_t r = 0; r < 3; ++r) {
                    for (std::size_t c = 0; c < 3; ++c) {
                        K[r][c] += wk * terms[i].K[r][c];
                        B[r][c] += wb * terms[i].B[r][c];
                    }
                }
            }
            std::string why;
            if (!checker.sum_is_stable(K, B, why)) return false;
        }
    }
    return true;
}

// Random scenes of planes along the axes and in the x-y plane (so that groups form: {x, y, xy-planes} and {z}
// with one mass; with the mass matrix most of them couple), some ramping in or out (ramp scenes at s = 1/4,
// 1/2, 3/4, each with its patterns), gains near the boundary so that both verdicts occur: the grouped
// check's verdict equals the brute force's in every scene.
TEST(EngagementPatterns, GroupsGiveTheVerdictOfEveryPatternOfTheWholeScene) {
    std::mt19937 rng(20261202U);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    int stable = 0, unstable = 0, split = 0;
    for (int anisotropic = 0; anisotropic <= 1; ++anisotropic) {
        const GainChecker checker(pattern_plant(kPeriod, anisotropic != 0));
        for (int scene = 0; scene < 40; ++scene) {
            std::vector<SceneTerm> terms;
            const int count = 3 + static_cast<int>(u(rng) * 4);
            for (int i = 0; i < count; ++i) {
                std::array<double, 3> n{};
                const double pick = u(rng);
                if (pick < 0.5) {
                    n[static_cast<std::size_t>(u(rng) * 3)] = 1.0;
                } else {
                    const double a = 6.283185307179586 * u(rng);
                    n = {std::cos(a), std::sin(a), 0.0};
                }
                const double m = checker.mass_along(n);
                const double alpha = 0.01 + 0.1 * u(rng), beta = 0.05 + 0.4 * u(rng);
                const SceneTerm::Role role = u(rng) < 0.2   ? SceneTerm::Role::In
                                             : u(rng) < 0.1 ? SceneTerm::Role::Out
                                                            : SceneTerm::Role::Base;
                terms.push_back(plane(n, alpha * m / (kPeriod * kPeriod), beta * m / kPeriod, u(rng) < 0.6,
                                      static_cast<std::uint32_t>(i + 1), role));
            }
            const EngagementCheck grouped = check_engagement_patterns(checker, terms, 0.25);
            ASSERT_FALSE(grouped.over_limit);
            EXPECT_EQ(grouped.stable, every_pattern_stable(checker, terms, 0.25))
                << "scene " << scene << ": " << grouped.why;
            (grouped.stable ? stable : unstable) += 1;
            split += grouped.groups > 1 ? 1 : 0;
        }
    }
    std::printf("[ patterns ] 80 scenes: %d stable, %d unstable, %d with more than one group\n", stable, unstable,
                split);
    EXPECT_GT(stable, 10);
    EXPECT_GT(unstable, 10);
    EXPECT_GT(split, 10);
}

// A box of six unilateral config walls: facing walls pair up (never engaged together): with one mass three
// groups of 3 patterns each; with the mass matrix one group of 3^3 = 27. Walls whose solids overlap, walls
// facing the same way and bilateral walls do not pair.
TEST(EngagementPatterns, FacingConfigWallsAreNeverEngagedTogether) {
    std::vector<AxisWall> box;
    for (std::size_t a = 0; a < 3; ++a) {
        box.push_back(AxisWall{a, 0.05, 1.0, false});
        box.push_back(AxisWall{a, -0.05, -1.0, false});
    }
    const std::vector<int> pairs = exclusive_wall_pairs(box);
    for (std::size_t a = 0; a < 3; ++a) {
        EXPECT_GE(pairs[2 * a], 0);
        EXPECT_EQ(pairs[2 * a], pairs[2 * a + 1]);
    }
    EXPECT_NE(pairs[0], pairs[2]);
    EXPECT_EQ(exclusive_wall_pairs({AxisWall{0, -0.01, 1.0, false}, AxisWall{0, 0.01, -1.0, false}}),
              (std::vector<int>{-1, -1}));  // overlap
    EXPECT_EQ(exclusive_wall_pairs({AxisWall{0, 0.05, 1.0, false}, AxisWall{0, 0.06, 1.0, false}}),
              (std::vector<int>{-1, -1}));
    EXPECT_EQ(exclusive_wall_pairs({AxisWall{0, 0.05, 1.0, true}, AxisWall{0, -0.05, -1.0, false}}),
              (std::vector<int>{-1, -1}));
    for (int anisotropic = 0; anisotropic <= 1; ++anisotropic) {
        const GainChecker checker(pattern_plant(kPeriod, anisotropic != 0));
        std::vector<SceneTerm> terms;
        for (std::size_t i = 0; i < box.size(); ++i) {
            std::array<double, 3> e{};
            e[box[i].axis] = 1.0;
            const double m = checker.mass().of_axis(box[i].axis);
            terms.push_back(
                plane(e, 0.05 * m / (kPeriod * kPeriod), 0.3 * m / kPeriod, true, static_cast<std::uint32_t>(i + 1)));
            terms.back().exclusive_pair = pairs[i];
        }
        const EngagementCheck c = check_engagement_patterns(checker, terms, 1.0);
        EXPECT_TRUE(c.stable) << c.why;
        EXPECT_EQ(c.groups, anisotropic ? 1U : 3U);
        EXPECT_EQ(c.largest_group_patterns, anisotropic ? 27U : 3U);
        // Patterns whose sums are identical are checked once: a wall and its facing twin have the same gain
        // matrices (K e e^T), so per axis "neither" and "one of the two" give 2 sums: 2 per group with one
        // mass, 2^3 of the 27 patterns with the mass matrix.
        EXPECT_EQ(c.checks, anisotropic ? 8U : 6U);
    }
}

// Eight conditional planes on coupled directions (the x-y plane), one ramping in (30 scenes at the default
// ramp): 256 patterns x 30 = 7680 pattern-scenes, beyond kMaxEngagementPatternScenes (3840): refused without a
// verdict, the message naming the limit. Seven are checked (128 x 30). Along one direction a pattern counts
// 1/4: 9 different parallel planes (512 patterns) are checked, 10 are refused.
TEST(EngagementPatterns, BeyondTheLimitTheCheckRefusesNamingIt) {
    static_assert(kMaxEngagementPatternScenes == 3840 && kOneDirectionPatternsPerUnit == 4);
    const GainChecker checker(pattern_plant(0.0, false));
    const double ramp = 1.0 / 30.0;
    std::vector<SceneTerm> terms;
    for (std::uint32_t i = 0; i < 8; ++i) {
        const double a = 0.3 * i;
        terms.push_back(plane({std::cos(a), std::sin(a), 0.0}, 0.01 * 0.3 / (kPeriod * kPeriod), 0.1 * 0.3 / kPeriod,
                              true, i + 1, i == 0 ? SceneTerm::Role::In : SceneTerm::Role::Base));
    }
    const EngagementCheck over = check_engagement_patterns(checker, terms, ramp);
    EXPECT_FALSE(over.stable);
    EXPECT_TRUE(over.over_limit);
    EXPECT_EQ(over.checks, 0U);
    EXPECT_NE(over.why.find("give 7680 pattern-scenes"), std::string::npos) << over.why;
    EXPECT_NE(over.why.find("accepted: at most 3840 (128 patterns at the default 30 ms ramp"), std::string::npos)
        << over.why;
    // A departure (no limit) checks them all.
    EXPECT_FALSE(check_engagement_patterns(checker, terms, ramp, PatternLimit::None).over_limit);
    terms.pop_back();
    const EngagementCheck at = check_engagement_patterns(checker, terms, ramp);
    EXPECT_TRUE(at.stable) << at.why;
    EXPECT_EQ(at.largest_group_patterns, 128U);
    EXPECT_EQ(at.checks, 3840U);  // every sum of a scene distinct (the empty one too: zero, trivially stable)

    std::vector<SceneTerm> parallel;
    for (std::uint32_t i = 0; i < 10; ++i) {
        parallel.push_back(plane({0.0, 0.6, 0.8}, (0.001 + 0.0002 * i) * 0.3 / (kPeriod * kPeriod),
                                 0.015 * 0.3 / kPeriod, true, i + 1,
                                 i == 0 ? SceneTerm::Role::In : SceneTerm::Role::Base));
    }
    const EngagementCheck over_parallel = check_engagement_patterns(checker, parallel, ramp);
    EXPECT_TRUE(over_parallel.over_limit);
    EXPECT_NE(over_parallel.why.find("give 7680 pattern-scenes"), std::string::npos) << over_parallel.why;
    parallel.pop_back();
    const EngagementCheck at_parallel = check_engagement_patterns(checker, parallel, ramp);
    EXPECT_TRUE(at_parallel.stable) << at_parallel.why;
    EXPECT_EQ(at_parallel.largest_group_patterns, 512U);
}

// Identical conditional objects (32 clients each adding the same unilateral plane): which k of the 32 are
// engaged does not change the sum, so 33 patterns, each checked once — and the brute force over the
// subsets of 6 of them agrees.
TEST(EngagementPatterns, IdenticalObjectsCountOncePerNumberEngaged) {
    const GainChecker checker(pattern_plant(kPeriod, false));
    std::vector<SceneTerm> terms;
    for (std::uint32_t i = 0; i < 32; ++i) terms.push_back(plane({0.0, 0.0, -1.0}, 50.0, 0.5, true, i + 1));
    const EngagementCheck all = check_engagement_patterns(checker, terms, 1.0);
    EXPECT_TRUE(all.stable) << all.why;
    EXPECT_EQ(all.largest_group_patterns, 33U);
    EXPECT_EQ(all.checks, 33U);
    // Stiff enough that several together are unstable (alpha = 0.1, beta = 0.3 each at d = 1): refused.
    std::vector<SceneTerm> stiff(
        6, plane({0.0, 0.0, -1.0}, 0.1 * 0.3 / (kPeriod * kPeriod), 0.3 * 0.3 / kPeriod, true, 1));
    std::string why;
    ASSERT_TRUE(checker.sum_is_stable(stiff[0].K, stiff[0].B, why)) << why;
    EXPECT_EQ(check_engagement_patterns(checker, stiff, 1.0).stable, every_pattern_stable(checker, stiff, 1.0));
    EXPECT_FALSE(check_engagement_patterns(checker, stiff, 1.0).stable);
}

}  // namespace engagement_test
}  // namespace hapticd
