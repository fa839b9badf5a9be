// SPDX-License-Identifier: Apache-2.0
// Every scene the loop can render when some objects act only at some handle positions (docs/protocol.md,
// section 5, "Engagement patterns"). Runs on the server's scene-check worker (server/scene_check_worker.hpp: commits
// and departures) and once at start-up, never in the loop.
//
// A unilateral plane renders its law only while the handle is behind its surface and the law pushes out, a
// field only inside its radius, a unilateral config wall only beyond its position: these terms are
// *conditional*; bilateral planes and springs act everywhere (*always*). At a tick the loop renders the
// always-engaged terms plus the conditional terms the handle engages — an engagement pattern. Sums are not
// monotone (A + B can be unstable while A + B + C is stable), so every pattern is checked, at the final
// scene and at every ramp scene. Geometry does not prune client objects: a move (offset, point, centre)
// changes no gain and is applied unchecked, so any pattern of the client objects can be reached at any
// time by moving them around the handle. Only fixed geometry prunes: two unilateral config walls on one
// axis, facing each other with disjoint solids (x > p and x < q, p >= q), are never engaged together.
//
// Exact reductions, each stated where it is used (engagement_patterns.cpp):
//  * Groups. In the unit-mass coordinates y = M^1/2 x each term i has gain matrices A_i = M^-1/2 K_i
//    M^-1/2, B_i = M^-1/2 B_i M^-1/2 acting on the span V_i of their ranges and row spaces. Terms whose
//    spans are orthogonal to every span of another group never couple: with V_1 .. V_g the groups' spans
//    (mutually orthogonal) every scene's sums are block diagonal in a basis adapted to V_1 + ... + V_g +
//    their complement, so det P(z) = prod_k det P_k(z) times the free plant's factor, and a scene is
//    stable iff each group's part is. A pattern is one choice per group, so "every pattern stable" is
//    "every pattern of each group stable": sum_k n_k checks instead of prod_k n_k.
//  * Terms at weight 0 in a scene (an object ramped fully out) contribute nothing: left out of that scene.
//  * Identical conditional terms (the same K, B and role, bitwise): which k of m are engaged does not change
//    the sum, so a class of m gives m + 1 patterns, not 2^m (32 identical planes: 33). Patterns whose sums
//    are bitwise identical to one already checked in that scene are the same scene: checked once.
//  * The device's stiffness limit needs no enumeration: every term's symmetric stiffness is positive
//    semi-definite (planes, springs; a field's -sym(J) is required to be), so the largest eigenvalue of a
//    sub-sum never exceeds the full sum's (Loewner order); the server checks the full sum.
// Cost: one GainChecker::coupled verdict per pattern per scene (tens of microseconds for a 3-axis
// non-commuting sum); a check may have at most kMaxEngagementPatterns (weighted) patterns, else it refuses
// (over_limit) rather than spend unbounded time.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tuning/object_checks.hpp"

namespace hapticd {

// Engagement patterns one check may have, summed over its groups (a group's patterns: the product over its
// conditional terms of 2, m + 1 for a class of m identical ones, 3 for a pair of config walls never engaged
// together): 7 different conditional objects on coupled directions, or the 6 walls of a box (27 patterns)
// and 2 more (108). A group acting along one direction only (parallel planes) counts
// 1 / kOneDirectionPatternsPerUnit per pattern: each of its verdicts is one scalar Schur-Cohn test (~5 us),
// not a companion eigenproblem (~15-30 us). Bounds a commit's check on one mass to ~60 ms (d = 1) .. ~115 ms
// (d = 3) at the default 30 ms ramp (docs/protocol.md, section 5: hapticd_benchmarks BM_CommitCheck*).
inline constexpr std::size_t kMaxEngagementPatterns = 128;
inline constexpr std::size_t kOneDirectionPatternsPerUnit = 4;
// The limit itself, in patterns times scenes (a group's scenes: the final one, and 1 / step - 1 ramp scenes
// when the batch ramps one of its objects): kMaxEngagementPatterns at the default ramp (30 scenes); a longer
// ramp allows proportionally fewer patterns (a scene with no conditional object is always checked).
inline constexpr std::size_t kMaxEngagementPatternScenes = kMaxEngagementPatterns * 30;
enum class PatternLimit : std::uint8_t {
    Enforced,  // a commit: refused (over_limit) beyond kMaxEngagementPatternScenes
    None,      // a departure or the config walls: every pattern of an accepted scene is checked, whatever it costs
};

// One object of a scene as the checks see it.
struct SceneTerm {
    enum class Role : std::uint8_t {
        Base,  // at its final weight in every scene of the check
        In,    // ramps in: stiffness s^2, damping s (s = j T / ramp_s)
        Out,   // ramps out: stiffness (1 - s)^2, damping 1 - s
    };
    Matrix3 K{};  // stiffness matrix rendered, GainChecker's convention f = -K x - B v
    Matrix3 B{};
    bool conditional = false;  // engages only at some handle positions (engages_conditionally)
    // Terms with the same exclusive_pair >= 0 (at most two) are never engaged together (fixed geometry).
    int exclusive_pair = -1;
    Role role = Role::Base;
    std::uint32_t object_id = 0;  // for messages
    // A mesh's proxy: K, B are its gains at P = I, rendered as K P, B P for its active constraints' projector P
    // (GainChecker::ProxyGains); in a sum with other terms every configuration is judged (proven or not) with them.
    bool proxy = false;
    bool shaded = false;  // with force shading (never proven in a sum)
};

// The term of a plane (or a spring to a plane) along the unit normal n with gains K, B: K n n^T, B n n^T,
// always engaged, role Base (set the rest).
SceneTerm plane_term(const std::array<double, 3>& n, double K, double B);

struct EngagementCheck {
    bool stable = true;
    bool over_limit = false;  // more than kMaxEngagementPatternScenes (weighted as above): not checked
    std::size_t checks = 0;   // scene verdicts computed
    // Of them, accepted on the sampled verdict, not proven over the whole plant set (GainChecker::sum_is_stable's
    // `proven`): a final scene no proof covers, or a ramp scene whose gains do not commute (the numerical-range proof
    // runs on final scenes only: its cost per scene is 0.1 to 1.5 s on the Falcon's set, docs/benchmarks.md).
    std::size_t sampled = 0;
    std::size_t largest_group_patterns = 0;
    std::size_t groups = 0;
    bool cancelled = false;  // stopped at `cancel` before its verdict: stable is false and means nothing
    std::string why;         // on failure or over_limit: which scene, which pattern, why
};

// The config walls' exclusive pairs: for walls on one axis (axis, position, direction +1 / -1, bilateral),
// a unilateral +1 wall at p (solid x > p) and a unilateral -1 wall at q (solid x < q) with p >= q are never
// engaged together; each wall is paired with at most one other (greedily; a wall left unpaired only costs
// patterns, never soundness). Returns one id per wall (-1: none), pair ids starting at `first_id`.
struct AxisWall {
    std::size_t axis = 0;
    double position = 0.0;
    double direction = 1.0;
    bool bilateral = false;
};
std::vector<int> exclusive_wall_pairs(const std::vector<AxisWall>& walls, int first_id = 0);

// Every scene the loop renders from the terms: the final scene (Base and In at weight 1, Out gone) and,
// when 0 < step < 1 and a group has In or Out terms, every ramp scene s_j = j step (0 < s_j < 1) of that
// group; in each scene every engagement pattern of the conditional terms, each judged by
// GainChecker::coupled (the verdict of sum_is_stable; on failure sum_is_stable's explanation). Groups are
// checked independently (header comment). The all-engaged pattern of each scene is checked first.
// `cancel` (may be null) is read before each verdict: once true the check ends with `cancelled` (a caller on
// another thread waits at most one verdict, GainChecker::sum_is_stable: up to ~1.5 s on the Falcon's set).
EngagementCheck check_engagement_patterns(const GainChecker& checker, const std::vector<SceneTerm>& terms, double step,
                                          PatternLimit limit = PatternLimit::Enforced,
                                          const std::atomic<bool>* cancel = nullptr);

}  // namespace hapticd
