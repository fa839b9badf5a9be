// SPDX-License-Identifier: Apache-2.0
#include "tuning/engagement_patterns.hpp"

#include <algorithm>
#include <cmath>
#include <array>
#include <cstring>
#include <numeric>
#include <set>
#include <sstream>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace hapticd {

namespace {

// The span operator of a term in the unit-mass coordinates: S = A A^T + A^T A + Bn Bn^T (positive
// semi-definite; its range is the span of the ranges and row spaces of A = M^-1/2 K M^-1/2 and
// Bn = M^-1/2 B M^-1/2, the directions the term acts on and from).
Eigen::Matrix3d span_operator(const Eigen::Matrix3d& mass_inverse_sqrt, const SceneTerm& t) {
    const Eigen::Matrix3d A = mass_inverse_sqrt * as_eigen(t.K) * mass_inverse_sqrt;
    const Eigen::Matrix3d Bn = mass_inverse_sqrt * as_eigen(t.B) * mass_inverse_sqrt;
    return A * A.transpose() + A.transpose() * A + Bn * Bn.transpose();
}

std::size_t find_root(std::vector<std::size_t>& parent, std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

// The weights of a term's stiffness and damping in the scene at ramp position s (s = 1: the final scene).
std::pair<double, double> role_weights(SceneTerm::Role role, double s) {
    switch (role) {
        case SceneTerm::Role::Base:
            return {1.0, 1.0};
        case SceneTerm::Role::In:
            return {s * s, s};
        case SceneTerm::Role::Out:
            return {(1.0 - s) * (1.0 - s), 1.0 - s};
    }
    return {1.0, 1.0};
}

void add_weighted(Matrix3& to, const Matrix3& m, double w) {
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) to[i][j] += w * m[i][j];
    }
}

// One unit of a pattern: an exclusive pair (neither, the first or the second engaged), or a class of m
// identical conditional terms (the same K, B and role, bitwise; m = 1 for most): k = 0 .. m of them engaged,
// m + 1 sums — which k of them does not change the sum, so the 2^m subsets give exactly these m + 1 scenes.
struct PatternUnit {
    std::vector<std::size_t> members;
    bool pair = false;
    [[nodiscard]] std::size_t options() const { return pair ? 3 : members.size() + 1; }
    // The terms engaged for a digit (0 .. options() - 1).
    [[nodiscard]] std::vector<std::size_t> engaged(std::size_t digit) const {
        if (pair) return digit == 0 ? std::vector<std::size_t>{} : std::vector<std::size_t>{members[digit - 1]};
        return std::vector<std::size_t>(members.begin(), members.begin() + static_cast<std::ptrdiff_t>(digit));
    }
};

bool identical_terms(const SceneTerm& a, const SceneTerm& b) { return a.role == b.role && a.K == b.K && a.B == b.B; }

std::vector<PatternUnit> pattern_units(const std::vector<SceneTerm>& terms,
                                       const std::vector<std::size_t>& conditional) {
    std::vector<PatternUnit> units;
    std::vector<bool> used(conditional.size(), false);
    for (std::size_t a = 0; a < conditional.size(); ++a) {
        if (used[a]) continue;
        used[a] = true;
        PatternUnit u{{conditional[a]}, false};
        const int id = terms[conditional[a]].exclusive_pair;
        for (std::size_t b = a + 1; b < conditional.size(); ++b) {
            if (used[b]) continue;
            const SceneTerm& other = terms[conditional[b]];
            if (id >= 0 && other.exclusive_pair == id) {  // the pair: never both engaged
                used[b] = true;
                u.members.push_back(conditional[b]);
                u.pair = true;
                break;
            }
            if (id < 0 && other.exclusive_pair < 0 && identical_terms(terms[conditional[a]], other)) {
                used[b] = true;
                u.members.push_back(conditional[b]);
            }
        }
        units.push_back(u);
    }
    return units;
}

// The number of patterns of the units, exact up to kPatternCountCeiling (far above any limit), which it
// saturates at (2^64 and beyond are not counted).
constexpr std::size_t kPatternCountCeiling = std::size_t{1} << 40;
std::size_t pattern_count(const std::vector<PatternUnit>& units) {
    std::size_t n = 1;
    for (const PatternUnit& u : units) {
        n *= u.options();
        if (n > kPatternCountCeiling) return kPatternCountCeiling;
    }
    return n;
}

std::string term_label(const SceneTerm& t) {
    std::string s = std::to_string(t.object_id);
    if (t.role == SceneTerm::Role::Out) s += " (ramping out)";  // the object it is replaced by has the same id
    return s;
}

std::string id_list(const std::vector<SceneTerm>& terms, const std::vector<std::size_t>& which) {
    std::string s = "[";
    for (std::size_t i = 0; i < which.size(); ++i) s += (i > 0 ? ", " : "") + term_label(terms[which[i]]);
    return s + "]";
}

// A scene's sums, and the proxies' share of them (two patterns with the same sums but other proxies in them are
// other families of configurations).
using SumKey = std::array<double, 36>;

SumKey sum_key(const Matrix3& K, const Matrix3& B, const Matrix3& K_proxies, const Matrix3& B_proxies) {
    SumKey k{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            k[3 * i + j] = K[i][j];
            k[9 + 3 * i + j] = B[i][j];
            k[18 + 3 * i + j] = K_proxies[i][j];
            k[27 + 3 * i + j] = B_proxies[i][j];
        }
    }
    return k;
}

// A term at its weights as GainChecker::sum_is_stable takes a proxy.
GainChecker::ProxyGains proxy_gains(const SceneTerm& t, std::pair<double, double> weight) {
    GainChecker::ProxyGains p;
    add_weighted(p.K, t.K, weight.first);
    add_weighted(p.B, t.B, weight.second);
    p.shaded = t.shaded;
    return p;
}

// Every pattern of one group in the scene at ramp position s (s = 1: final). False on the first unstable
// pattern, with `why`.
bool group_scene_is_stable(const GainChecker& checker, const std::vector<SceneTerm>& terms,
                           const std::vector<std::size_t>& group, double s, EngagementCheck& result, std::string& why,
                           const std::atomic<bool>* cancel) {
    Matrix3 K_always{}, B_always{};
    std::vector<std::size_t> conditional, always;
    std::vector<std::pair<double, double>> weight(terms.size(), {0.0, 0.0});
    for (const std::size_t i : group) {
        weight[i] = role_weights(terms[i].role, s);
        if (weight[i].first == 0.0 && weight[i].second == 0.0) continue;  // gone in this scene: contributes nothing
        if (terms[i].conditional) {
            conditional.push_back(i);
        } else {
            always.push_back(i);
            add_weighted(K_always, terms[i].K, weight[i].first);
            add_weighted(B_always, terms[i].B, weight[i].second);
        }
    }
    const std::vector<PatternUnit> units = pattern_units(terms, conditional);
    const std::size_t count = pattern_count(units);
    // Patterns as mixed-radix numbers, digit u in 0 .. options(u) - 1 (a class: that many of its terms
    // engaged; a pair: neither, the first, the second), counted down from the largest: the all-engaged
    // pattern first.
    std::set<SumKey> checked;
    std::vector<std::size_t> digits(units.size());
    std::vector<GainChecker::ProxyGains> proxies;
    for (std::size_t code = count; code-- > 0;) {
        std::size_t rest = code;
        Matrix3 K = K_always, B = B_always;
        proxies.clear();
        std::size_t acting = always.size();
        for (const std::size_t i : always) {
            if (terms[i].proxy) proxies.push_back(proxy_gains(terms[i], weight[i]));
        }
        for (std::size_t u = 0; u < units.size(); ++u) {
            digits[u] = rest % units[u].options();
            rest /= units[u].options();
            for (const std::size_t i : units[u].engaged(digits[u])) {
                add_weighted(K, terms[i].K, weight[i].first);
                add_weighted(B, terms[i].B, weight[i].second);
                ++acting;
                if (terms[i].proxy) proxies.push_back(proxy_gains(terms[i], weight[i]));
            }
        }
        // A proxy alone: its object check judged every configuration (ObjectResolver, mesh_masses); beside other
        // terms every configuration of the sum is the family's.
        if (acting < 2) proxies.clear();
        Matrix3 K_proxies{}, B_proxies{};
        for (const GainChecker::ProxyGains& p : proxies) {
            add_to(K_proxies, p.K);
            add_to(B_proxies, p.B);
        }
        if (!checked.insert(sum_key(K, B, K_proxies, B_proxies)).second) continue;  // a pattern checked already
        if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) {
            result.cancelled = true;
            why = "the check was cancelled";
            return false;
        }
        ++result.checks;
        std::string reason;
        bool proven = false;
        if (checker.sum_is_stable(K, B, reason, s >= 1.0, &proven, proxies)) {
            result.sampled += proven ? 0 : 1;
            continue;
        }
        std::vector<std::size_t> engaged, free;
        for (std::size_t u = 0; u < units.size(); ++u) {
            const std::vector<std::size_t> in = units[u].engaged(digits[u]);
            for (const std::size_t i : units[u].members)
                (std::find(in.begin(), in.end(), i) != in.end() ? engaged : free).push_back(i);
        }
        if (free.empty()) {
            why = reason + " (every object in contact at once)";
        } else {
            why = "with the conditionally engaged objects " + id_list(terms, engaged) + " in contact and " +
                  id_list(terms, free) +
                  " not (a unilateral plane, a field or a unilateral config wall acts only while the handle is in it; "
                  "any such "
                  "pattern is reachable, since moves are not checked): " +
                  reason;
        }
        return false;
    }
    return true;
}

}  // namespace

SceneTerm plane_term(const std::array<double, 3>& n, double K, double B) {
    SceneTerm t;
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            t.K[i][j] = K * n[i] * n[j];
            t.B[i][j] = B * n[i] * n[j];
        }
    }
    return t;
}

std::vector<int> exclusive_wall_pairs(const std::vector<AxisWall>& walls, int first_id) {
    std::vector<int> pair(walls.size(), -1);
    int next = first_id;
    for (std::size_t a = 0; a < walls.size(); ++a) {
        if (walls[a].bilateral || walls[a].direction < 0.0 || pair[a] >= 0) continue;
        for (std::size_t b = 0; b < walls.size(); ++b) {
            // a: solid x > p (direction +1); b: solid x < q (direction -1); both engaged needs p < x < q.
            if (b == a || pair[b] >= 0 || walls[b].bilateral || walls[b].direction > 0.0 ||
                walls[b].axis != walls[a].axis)
                continue;
            if (walls[a].position >= walls[b].position) {
                pair[a] = pair[b] = next++;
                break;
            }
        }
    }
    return pair;
}

// The groups (header comment): terms i, j couple when their span operators are not orthogonal,
// ||S_i S_j||_F > kMatrixGainRoundingLevel ||S_i||_F ||S_j||_F (for two planes this ratio is |n_i.n_j| in
// the unit-mass coordinates); the groups are the connected components of that relation. Terms across groups
// then have orthogonal spans up to that level: the coupling neglected is below 64 eps of the gains, the level at
// which the loop's own summed gains are rounded, and the same bound by which matrix_gain_stability.hpp leaves out
// directions touched below rounding (it moves a root by at most ~sqrt(1.5e-14) = 1.2e-7 for a double root, inside
// the 1e-6 radius margin of the sampled coupled path; the exact paths judge each group over the whole mass set).
EngagementCheck check_engagement_patterns(const GainChecker& checker, const std::vector<SceneTerm>& terms, double step,
                                          PatternLimit limit, const std::atomic<bool>* cancel) {
    EngagementCheck result;
    const Eigen::Matrix3d Mis = as_eigen(checker.mass().inverse_sqrt);
    std::vector<Eigen::Matrix3d> span(terms.size());
    std::vector<double> size(terms.size());
    std::vector<std::size_t> parent(terms.size());
    std::iota(parent.begin(), parent.end(), std::size_t{0});
    for (std::size_t i = 0; i < terms.size(); ++i) {
        span[i] = span_operator(Mis, terms[i]);
        size[i] = span[i].norm();
    }
    for (std::size_t i = 0; i < terms.size(); ++i) {
        if (size[i] == 0.0) continue;
        for (std::size_t j = i + 1; j < terms.size(); ++j) {
            if (size[j] == 0.0 || find_root(parent, i) == find_root(parent, j)) continue;
            if ((span[i] * span[j]).norm() > hapticopt::kMatrixGainRoundingLevel * size[i] * size[j]) {
                parent[find_root(parent, j)] = find_root(parent, i);
            }
        }
    }
    std::vector<std::vector<std::size_t>> groups;
    std::vector<std::size_t> group_of(terms.size(), terms.size());
    for (std::size_t i = 0; i < terms.size(); ++i) {
        if (size[i] == 0.0) continue;  // acts nowhere (a weight 0, or no gains)
        const std::size_t r = find_root(parent, i);
        if (group_of[r] == terms.size()) {
            group_of[r] = groups.size();
            groups.emplace_back();
        }
        groups[group_of[r]].push_back(i);
    }
    result.groups = groups.size();

    // The limit first, before any verdict: each group's patterns (every conditional term present) times its
    // scenes (the final one, and the ramp's when the group has a ramping term), those of a group acting along
    // one direction (scalar verdicts) weighted 1 / kOneDirectionPatternsPerUnit, summed over the groups.
    const bool ramp = step > 0.0 && step < 1.0;
    const double ramp_scenes = ramp ? std::ceil(1.0 / step) - 1.0 : 0.0;
    double units = 0.0, largest_scenes = 1.0;
    std::vector<std::size_t> all_conditional;
    for (const auto& group : groups) {
        std::vector<std::size_t> conditional;
        for (const std::size_t i : group) {
            if (terms[i].conditional) conditional.push_back(i);
        }
        all_conditional.insert(all_conditional.end(), conditional.begin(), conditional.end());
        const std::size_t count = pattern_count(pattern_units(terms, conditional));
        result.largest_group_patterns = std::max(result.largest_group_patterns, count);
        // The group's dimension: the rank of the sum of its span operators (relative 64 eps, as the groups).
        Eigen::Matrix3d spans = Eigen::Matrix3d::Zero();
        for (const std::size_t i : group) spans += span[i] / size[i];
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(spans, Eigen::EigenvaluesOnly);
        const bool one_direction = es.eigenvalues()(1) <= hapticopt::kMatrixGainRoundingLevel * es.eigenvalues()(2);
        const bool ramps = std::any_of(group.begin(), group.end(),
                                       [&](std::size_t i) { return terms[i].role != SceneTerm::Role::Base; });
        const double scenes = 1.0 + (ramps ? ramp_scenes : 0.0);
        largest_scenes = std::max(largest_scenes, scenes);
        units += static_cast<double>(count) * scenes /
                 (one_direction ? static_cast<double>(kOneDirectionPatternsPerUnit) : 1.0);
    }
    if (limit == PatternLimit::Enforced && units > static_cast<double>(kMaxEngagementPatternScenes) &&
        units > largest_scenes) {  // a scene without conditional objects is always checked, whatever its ramp
        std::ostringstream o;
        o << all_conditional.size() << " conditionally engaged objects " << id_list(terms, all_conditional)
          << " (unilateral planes, fields, unilateral config walls) give " << units
          << " pattern-scenes to check (each group's engagement patterns times its scenes, the final one and "
          << ramp_scenes << " ramp scenes; a group acting along one direction counts 1/" << kOneDirectionPatternsPerUnit
          << "); accepted: at most " << kMaxEngagementPatternScenes << " (" << kMaxEngagementPatterns
          << " patterns at the default 30 ms ramp: a group's patterns are the product of 2 per conditional object, m + "
             "1 per m "
             "identical ones, 3 per pair of facing config walls; e.g. 7 different conditional objects on coupled "
             "directions, or 9 "
             "along one direction; fewer with a longer ramp-time); make some bilateral, remove some, or place them on "
             "M-orthogonal directions";
        result.stable = false;
        result.over_limit = true;
        result.why = o.str();
        return result;
    }

    // The final scene of every group, then the ramp scenes of the groups the batch touches. A commuting sum's
    // direction pair met again (another pattern or scene, the same plane along another direction) is judged once
    // (GainChecker::CommitMemo: the verdict is a function of the pair).
    const GainChecker::CommitMemo memo(checker);
    for (const auto& group : groups) {
        std::string why;
        if (!group_scene_is_stable(checker, terms, group, 1.0, result, why, cancel)) {
            result.stable = false;
            result.why = why;
            return result;
        }
    }
    if (!(step > 0.0) || step >= 1.0) return result;  // no ramp: the scene jumps from before to after
    for (const auto& group : groups) {
        const bool ramps = std::any_of(group.begin(), group.end(),
                                       [&](std::size_t i) { return terms[i].role != SceneTerm::Role::Base; });
        if (!ramps) continue;  // every ramp scene of this group is its final scene
        for (int j = 1;; ++j) {
            const double s = static_cast<double>(j) * step;  // the loop's arithmetic (SceneObjects::step_ramps)
            if (s >= 1.0) break;
            std::string why;
            if (!group_scene_is_stable(checker, terms, group, s, result, why, cancel)) {
                if (result.cancelled) {
                    result.stable = false;
                    result.why = why;
                    return result;
                }
                std::ostringstream o;
                o.precision(4);
                o << "during the ramp, " << j << " ticks after the batch (new or changed objects at weight s = " << s
                  << ", the ones they replace or remove at 1 - s): " << why;
                result.stable = false;
                result.why = o.str();
                return result;
            }
        }
    }
    return result;
}

}  // namespace hapticd
