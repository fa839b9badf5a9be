// SPDX-License-Identifier: Apache-2.0
// Robust wall gains: (K, B) minimising the worst case of an energy criterion (C_E0..2 of the step,
// C_I0..2 of the collision) over a box of uncertain physical parameters, with stability over the
// whole box. Beyond Hulin et al. 2011, who name robustness (their objective 4) but do not optimise it.
//
// Box: mass m in [m_min, m_max] (e.g. the Falcon with and without a hand, 0.22 ... 0.30 kg), damping
// b, stiffness k and loop delay t_d in their ranges; the period T is fixed. For fixed physical gains
// the normalised parameters move with the box point: alpha = K T^2/m, beta = B T/m, gamma = k T^2/m,
// delta = b T/m, d = t_d/T. A mass range alone therefore maps (K, B) to the segment
// (alpha, beta) = s (K T^2, B T), s = 1/m in [1/m_max, 1/m_min], of a ray through the origin.
//
// Problem:  minimise over (K, B)  W(K, B) = max over the box of C(alpha, beta; gamma, delta, d),
// subject to stability at every box point. W is +inf unless the gains are stable on the whole
// optimisation grid (below), so a minimiser always lies in the robustly stable set.
//
// Method.
//  1. Optimisation grid: `mass_points` masses x `other_points` dampings and stiffnesses (one when a
//     range is a point) x `delay_points` delays, ends included. For each grid plant the exact
//     stable region (stability_region.hpp) gives the stable beta interval at each alpha; mapped to
//     physical units and intersected over the grid plants it is the admissible B interval at K,
//     for K in (0, min_i alpha_max_i m_i / T^2).
//  2. W on the grid is minimised by the region search of region_minimum.hpp (coarse grid, Brent).
//  3. Verification of the answer on a finer grid (`verify_*` points) and the worst case refined by
//     Brent over the mass at the worst grid point; the report names where in the box it occurs.
//  4. Stability guarantee along every mass segment of the verification grid. When b = k = 0 the
//     normalised plant does not depend on m and the characteristic polynomial is affine in s:
//       p(z; s) = P_0(z) + s Q(z),  Q = K T^2 P_alpha + B T P_beta  (characteristic_polynomial.hpp).
//     A root crosses the unit circle at s only if P_0(z) + s Q(z) = 0 with |z| = 1, i.e. where
//     P_0 / Q is real, with s = -P_0(z) / Q(z): the sign changes of a Chebyshev series in cos(theta),
//     bracketed by a derivative cascade (mass_scaling_stability.hpp, MassScalingTest). If no crossing s
//     lies in the segment and the loop is stable at its end (Schur-Cohn), it is stable on the whole
//     segment: a certified check up to rounding in the coefficients. When b > 0 or k > 0 the plant itself depends on m,
//     p is not affine in s, and the segment is checked densely (Schur-Cohn at `verify_mass_points` masses): not a proof
//     between the points. Damping, stiffness and delay are checked on their verification grids only (the characteristic
//     polynomial is not affine in them): a dense check, not a proof. Limits: stated in the result
//     (`mass_segments_certified`).
// With a velocity estimator (RobustOptions::estimator): the same steps on the loop with it — the costs of
// estimator_costs.hpp, each grid plant's main region (EstimatorStabilityRegion on kFastOptimumRegionGrid, its
// beta interval to 1e-9), the crossing test of MassScalingTest with the estimator, the dense check by its Schur-Cohn
// verdict. A force-noise budget (RobustOptions::force_noise_budget) makes W = +inf wherever sigma_F exceeds it at a
// grid plant: the minimiser meets it on the optimisation grid (the region search treats +inf as infeasible), and
// force_noise_max reports the largest sigma_F on the verification grid.
// Cost: about 10^4 cost evaluations per grid plant for the optimisation (a few 0.1 s at d = 1 with the backward
// difference; measured with estimators in docs/benchmarks.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "config.hpp"
#include "estimator_costs.hpp"
#include "estimator_noise.hpp"
#include "estimator_optimum.hpp"
#include "estimator_region.hpp"
#include "estimator_stability.hpp"
#include "impulse_optimum.hpp"
#include "mass_scaling_stability.hpp"
#include "optimum.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// A closed interval [min, max] of a physical parameter (min == max: a known value).
struct ParameterRange {
    double min = 0;
    double max = 0;
    double mid() const { return (min + max) / 2; }
    /// The i-th of n points spanning the range, ends included (one point when min == max).
    double at(int i, int n) const { return n <= 1 || min == max ? mid() : min + (max - min) * i / (n - 1); }
};

/// The uncertain plant: a box of masses, dampings, stiffnesses and delays at a fixed period.
struct UncertainPlant {
    ParameterRange mass;              ///< m [kg], min > 0
    ParameterRange damping{0, 0};     ///< b [N s/m], >= 0
    ParameterRange stiffness{0, 0};   ///< k [N/m], >= 0
    double period = 0.001;            ///< T [s], > 0
    ParameterRange time_delay{0, 0};  ///< t_d [s], >= 0, <= 1000 T
    /// The box centre (used as the nominal plant).
    PhysicalPlant nominal() const {
        return PhysicalPlant{mass.mid(), damping.mid(), stiffness.mid(), period, time_delay.mid()};
    }
};

inline void validate(const UncertainPlant& box, const char* function = "hapticopt::validate") {
    auto range = [&](const char* name, const ParameterRange& r, double lower, bool strict) {
        detail::require_in_range(function, name, r.min, lower, strict, HUGE_VAL,
                                 strict ? "finite and > 0, min <= max" : "finite and >= 0, min <= max");
        const std::string upper = std::string(name) + ".max";
        detail::require_in_range(function, upper.c_str(), r.max, r.min, false, HUGE_VAL,
                                 "finite and >= the range's minimum");
    };
    range("mass", box.mass, 0.0, true);
    range("damping", box.damping, 0.0, false);
    range("stiffness", box.stiffness, 0.0, false);
    detail::require_positive(function, "period", box.period);
    range("time_delay", box.time_delay, 0.0, false);
    detail::require_in_range(function, "time_delay", box.time_delay.max / box.period, 0.0, false, 1e3, "t_d <= 1000 T");
}

/// Which energy criterion is robustified: C_E<index> (step) or C_I<index> (collision).
struct RobustCriterion {
    bool impulse = false;
    int index = 2;
    /// CE0..CE2 only (throws InvalidParameter for amax, OV and the +OV criteria).
    static RobustCriterion step(Criterion c) {
        const auto k = energy_index(c);
        if (!k || requires_no_overshoot(c)) {
            throw InvalidParameter("hapticopt::RobustCriterion::step", "criterion", static_cast<double>(c),
                                   "CE0, CE1, CE2 (energy criteria; robust amax/OV are not defined)");
        }
        return {false, *k};
    }
    static RobustCriterion collision(ImpulseCriterion c) { return {true, energy_index(c)}; }
};

struct RobustOptions {
    int mass_points = 5;          ///< optimisation grid, >= 2
    int other_points = 3;         ///< over b and k when they are ranges, >= 2
    int delay_points = 3;         ///< over t_d when it is a range, >= 2
    int verify_mass_points = 33;  ///< verification grid, >= 2
    int verify_other_points = 5;
    int verify_delay_points = 9;
    RegionSearchOptions search{16, 12};
    /// The loop's velocity estimator (velocity_estimator.hpp): the costs, regions and stability checks are those
    /// of the loop with it. Collision criteria need the backward difference.
    VelocityEstimator estimator{};
    /// A force-noise budget sigma_F <= force_noise_budget [N] at every grid plant (0: none), sigma_F =
    /// (m q / T^2) g_F with q = position_resolution [m] (> 0 with a budget): gains that exceed it at a plant
    /// of the optimisation grid have W = +inf, and the verification reports the largest sigma_F on its grid.
    double force_noise_budget = 0;
    double position_resolution = 0;
};

/// Where the worst case occurs and its value (+inf: unstable there).
struct BoxWorstCase {
    double cost = HUGE_VAL;
    PhysicalPlant where{};
};

struct RobustStability {
    bool stable = false;                   ///< stable at every verification point / mass segment
    bool mass_segments_certified = false;  ///< every mass segment passed the exact crossing test (b = k = 0)
    int plants_checked = 0;                ///< (b, k, t_d) combinations checked along their mass segment
};

struct RobustOptimum {
    RobustCriterion criterion;
    UncertainPlant box;
    WallGains gains{0, 0};  ///< robust K [N/m], B [N s/m]
    BoxWorstCase worst;     ///< its worst case over the box (verification grid + refinement)
    RobustStability stability;
    double K_max = 0;               ///< robust stiffness limit on the optimisation grid
    PhysicalPlant nominal{};        ///< box centre
    WallGains nominal_gains{0, 0};  ///< optimum of the criterion at the nominal plant
    BoxWorstCase nominal_worst;     ///< its worst case over the box (+inf if unstable somewhere)
    RobustStability nominal_stability;
    /// Largest sigma_F [N] of the robust gains over the verification grid (0 without a position_resolution).
    double force_noise_max = 0;
};

namespace detail {

HAPTICOPT_FUNC double criterion_cost(const RobustCriterion& c, const SampledPlant<double>& plant, double alpha,
                                     double beta, const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    if (c.impulse) return impulse_costs(plant, alpha, beta)[c.index];
    const EnergyCosts e = estimator.kind == VelocityEstimatorKind::backward
                              ? energy_costs(plant, alpha, beta)
                              : estimator_energy_costs(plant, estimator, alpha, beta);
    return c.index == 0 ? e.ce0 : c.index == 1 ? e.ce1 : e.ce2;
}
#else
    ;
#endif

/// Cost at physical gains for a physical plant (normalising both).
HAPTICOPT_FUNC double physical_cost(const RobustCriterion& c, const PhysicalPlant& p, const SampledPlant<double>& sp,
                                    double K, double B, const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    return criterion_cost(c, sp, K * p.period * p.period / p.mass, B * p.period / p.mass, estimator);
}
#else
    ;
#endif

/// The grid of (b, k, t_d) combinations, each with `nm` masses.
HAPTICOPT_FUNC std::vector<PhysicalPlant> box_grid(const UncertainPlant& box, int nm, int no, int nd)
#if HAPTICOPT_DEFINITIONS
{
    std::vector<PhysicalPlant> out;
    for (int ib = 0; ib < no; ++ib) {
        if (ib > 0 && box.damping.min == box.damping.max) break;
        for (int ik = 0; ik < no; ++ik) {
            if (ik > 0 && box.stiffness.min == box.stiffness.max) break;
            for (int id = 0; id < nd; ++id) {
                if (id > 0 && box.time_delay.min == box.time_delay.max) break;
                for (int im = 0; im < nm; ++im) {
                    if (im > 0 && box.mass.min == box.mass.max) break;
                    out.push_back(PhysicalPlant{box.mass.at(im, nm), box.damping.at(ib, no), box.stiffness.at(ik, no),
                                                box.period, box.time_delay.at(id, nd)});
                }
            }
        }
    }
    return out;
}
#else
    ;
#endif

/// Exact unit-circle crossing test along the mass segment for b = k = 0 (header comment, step 4; the crossings of
/// mass_scaling_stability.hpp). Returns true when the loop is stable for every m in [m_min, m_max].
HAPTICOPT_FUNC bool mass_segment_certified_stable(const UncertainPlant& box, double time_delay, double K, double B,
                                                  const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    const double T = box.period;
    if (!(K > 0)) return false;
    const MassScalingTest test(NormalizedPlant{0.0, 0.0, time_delay / T}, estimator);
    // s = m_max / m in [1, m_max / m_min]; alpha = s alpha_ref, beta = s beta_ref.
    return test.over(K * T * T / box.mass.max, B * T / box.mass.max, 1.0, box.mass.max / box.mass.min).stable;
}
#else
    ;
#endif

}  // namespace detail

/// Stability of (K, B) over the box (header comment, step 4) on the verification grid.
HAPTICOPT_FUNC RobustStability robust_stability(const UncertainPlant& box, const WallGains& gains,
                                                const RobustOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    validate(box, "hapticopt::robust_stability");
    RobustStability out;
    out.stable = true;
    out.mass_segments_certified = true;
    const int nm = options.verify_mass_points;
    const std::vector<PhysicalPlant> grid =
        detail::box_grid(box, 1, options.verify_other_points, options.verify_delay_points);
    for (const PhysicalPlant& corner : grid) {
        ++out.plants_checked;
        if (corner.damping == 0 && corner.stiffness == 0) {
            if (!detail::mass_segment_certified_stable(box, corner.time_delay, gains.stiffness, gains.damping,
                                                       options.estimator)) {
                out.stable = false;
                out.mass_segments_certified = false;
                return out;
            }
        } else {
            out.mass_segments_certified = false;
        }
        for (int im = 0; im < nm; ++im) {  // dense check (always; the only check when b or k > 0)
            PhysicalPlant p = corner;
            p.mass = box.mass.at(im, nm);
            const NormalizedGains g = normalize(gains, p.mass, p.period);
            const bool stable = options.estimator.kind == VelocityEstimatorKind::backward
                                    ? loop_is_stable(SampledPlant<double>(normalize(p)), g.alpha, g.beta)
                                    : EstimatorStabilityTest(normalize(p), options.estimator).stable(g.alpha, g.beta);
            if (!stable) {
                out.stable = false;
                out.mass_segments_certified = false;
                return out;
            }
        }
    }
    return out;
}
#else
    ;
#endif

/// Worst case of the criterion at (K, B) over the box: the verification grid, then Brent over the
/// mass around the worst grid point (other parameters fixed there).
HAPTICOPT_FUNC BoxWorstCase robust_worst_case(const RobustCriterion& criterion, const UncertainPlant& box,
                                              const WallGains& gains, const RobustOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    validate(box, "hapticopt::robust_worst_case");
    const int nm = options.verify_mass_points;
    const std::vector<PhysicalPlant> grid =
        detail::box_grid(box, nm, options.verify_other_points, options.verify_delay_points);
    BoxWorstCase worst;
    worst.cost = -HUGE_VAL;
    std::size_t at = 0;
    for (std::size_t i = 0; i < grid.size(); ++i) {
        const SampledPlant<double> sp(normalize(grid[i]));
        const double c =
            detail::physical_cost(criterion, grid[i], sp, gains.stiffness, gains.damping, options.estimator);
        if (!(c <= worst.cost)) {
            worst.cost = c;
            worst.where = grid[i];
            at = i;
        }
        if (!std::isfinite(c)) return worst;  // unstable (or NaN): that is the worst case
    }
    if (box.mass.min < box.mass.max) {
        const PhysicalPlant base = grid[at];
        const double step = (box.mass.max - box.mass.min) / (nm - 1);
        auto negative = [&](double m) {
            PhysicalPlant p = base;
            p.mass = m;
            return -detail::physical_cost(criterion, p, SampledPlant<double>(normalize(p)), gains.stiffness,
                                          gains.damping, options.estimator);
        };
        const auto r = detail::minimize_scalar(negative, std::max(box.mass.min, base.mass - step),
                                               std::min(box.mass.max, base.mass + step), 1e-9 * base.mass);
        if (-r.value > worst.cost) {
            worst.cost = -r.value;
            worst.where.mass = r.x;
        }
    }
    return worst;
}
#else
    ;
#endif

namespace detail {

HAPTICOPT_FUNC RobustOptimum robust_optimum_impl(const RobustCriterion& criterion, const UncertainPlant& box,
                                                 const RobustOptions& options)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::robust_optimum";
    validate(box, fn);
    require_in_range(fn, "mass_points", options.mass_points, 2, false, 1e4, "2 <= mass_points <= 10^4");
    require_in_range(fn, "other_points", options.other_points, 2, false, 1e3, "2 <= other_points <= 10^3");
    require_in_range(fn, "delay_points", options.delay_points, 2, false, 1e3, "2 <= delay_points <= 10^3");
    require_in_range(fn, "verify_mass_points", options.verify_mass_points, 2, false, 1e5, ">= 2");
    require_in_range(fn, "verify_other_points", options.verify_other_points, 2, false, 1e3, ">= 2");
    require_in_range(fn, "verify_delay_points", options.verify_delay_points, 2, false, 1e3, ">= 2");
    validate(options.estimator, fn);
    const bool backward = options.estimator.kind == VelocityEstimatorKind::backward;
    if (criterion.impulse && !backward) {
        throw InvalidParameter(fn, "estimator", static_cast<double>(options.estimator.kind),
                               "the backward difference for the collision criteria (CI0..2)");
    }
    require_in_range(fn, "force_noise_budget", options.force_noise_budget, 0.0, false, HUGE_VAL,
                     "finite and >= 0 N (0: none)");
    if (options.force_noise_budget > 0) {
        require_in_range(fn, "position_resolution", options.position_resolution, 0.0, true, HUGE_VAL,
                         "finite and > 0 m with a force_noise_budget");
    }
    const double T = box.period;
    const std::vector<PhysicalPlant> grid =
        box_grid(box, options.mass_points, options.other_points, options.delay_points);
    std::vector<SampledPlant<double>> sampled;
    std::vector<StabilityRegion> regions;                     // the backward difference's exact regions
    std::vector<EstimatorStabilityRegion> estimator_regions;  // or the estimator's main regions
    sampled.reserve(grid.size());
    double K_max = HUGE_VAL;
    for (const PhysicalPlant& p : grid) {
        sampled.emplace_back(normalize(p));
        double alpha_max = 0;
        if (backward) {
            regions.emplace_back(normalize(p));
            alpha_max = regions.back().alpha_max();
        } else {
            estimator_regions.emplace_back(normalize(p), options.estimator, kFastOptimumRegionGrid);
            alpha_max = estimator_regions.back().alpha_max();
        }
        K_max = std::min(K_max, alpha_max * p.mass / (T * T));
    }
    auto interval = [&](double K) {
        double lo = -HUGE_VAL, hi = HUGE_VAL;
        for (std::size_t i = 0; i < grid.size(); ++i) {
            const double m = grid[i].mass;
            std::pair<double, double> b;
            if (backward) {
                b = regions[i].beta_range(std::min(K * T * T / m, regions[i].alpha_max()));
            } else {
                const EstimatorStabilityRegion& r = estimator_regions[i];
                b = r.beta_interval(std::min(K * T * T / m, r.alpha_max()), 1e-9);
            }
            lo = std::max(lo, b.first * m / T);
            hi = std::min(hi, b.second * m / T);
        }
        return std::pair<double, double>{lo, hi};
    };
    auto force_noise = [&](const PhysicalPlant& p, const SampledPlant<double>& sp, double K, double B) {
        const double g = estimator_force_noise_gain(sp, options.estimator, K * T * T / p.mass, B * T / p.mass);
        return p.mass * options.position_resolution / (T * T) * g;
    };
    auto worst = [&](double K, double B) {
        double w = -HUGE_VAL;
        for (std::size_t i = 0; i < grid.size(); ++i) {
            const double c = physical_cost(criterion, grid[i], sampled[i], K, B, options.estimator);
            if (!std::isfinite(c)) return HUGE_VAL;
            if (options.force_noise_budget > 0 &&
                !(force_noise(grid[i], sampled[i], K, B) <= options.force_noise_budget)) {
                return HUGE_VAL;
            }
            w = std::max(w, c);
        }
        return w;
    };
    const RegionMinimum m = minimize_on_region(worst, 0.0, K_max, interval, options.search);
    if (!std::isfinite(m.value) && options.force_noise_budget > 0) {
        throw InvalidParameter(fn, "force_noise_budget", options.force_noise_budget,
                               "a budget met by some (K, B) stable over the box (none found on the grid): a larger "
                               "force_noise_budget, a finer position_resolution or a smoother velocity estimator");
    }
    if (!std::isfinite(m.value)) {
        throw InvalidParameter(fn, "mass", box.mass.max,
                               "a box with a common stable (K, B) region (none found on the grid)");
    }
    RobustOptimum out;
    out.criterion = criterion;
    out.box = box;
    out.gains = WallGains{m.alpha, m.beta};
    out.K_max = K_max;
    out.worst = robust_worst_case(criterion, box, out.gains, options);
    out.stability = robust_stability(box, out.gains, options);
    if (options.position_resolution > 0) {
        for (const PhysicalPlant& p :
             box_grid(box, options.verify_mass_points, options.verify_other_points, options.verify_delay_points)) {
            const double sigma =
                force_noise(p, SampledPlant<double>(normalize(p)), out.gains.stiffness, out.gains.damping);
            out.force_noise_max = std::max(out.force_noise_max, sigma);
        }
    }
    out.nominal = box.nominal();
    const NormalizedPlant np = normalize(out.nominal);
    NormalizedGains ng{0, 0};
    if (criterion.impulse) {
        const ImpulseOptimum o = ImpulseOptimizer(np).optimum(criterion.index == 0   ? ImpulseCriterion::CI0
                                                              : criterion.index == 1 ? ImpulseCriterion::CI1
                                                                                     : ImpulseCriterion::CI2);
        ng = {o.alpha, o.beta};
    } else {
        const EstimatorOptimum o = optimal_point(criterion.index == 0   ? Criterion::CE0
                                                 : criterion.index == 1 ? Criterion::CE1
                                                                        : Criterion::CE2,
                                                 np, options.estimator);
        ng = {o.alpha, o.beta};
    }
    out.nominal_gains = to_physical(ng, out.nominal.mass, T);
    out.nominal_worst = robust_worst_case(criterion, box, out.nominal_gains, options);
    out.nominal_stability = robust_stability(box, out.nominal_gains, options);
    return out;
}
#else
    ;
#endif

}  // namespace detail

/// Robust optimum of a step energy criterion (CE0, CE1, CE2) over the box.
HAPTICOPT_FUNC RobustOptimum robust_optimum(Criterion criterion, const UncertainPlant& box,
                                            const RobustOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    return detail::robust_optimum_impl(RobustCriterion::step(criterion), box, options);
}
#else
    ;
#endif

/// Robust optimum of a collision criterion (CI0, CI1, CI2) over the box.
HAPTICOPT_FUNC RobustOptimum robust_optimum(ImpulseCriterion criterion, const UncertainPlant& box,
                                            const RobustOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    return detail::robust_optimum_impl(RobustCriterion::collision(criterion), box, options);
}
#else
    ;
#endif

}  // namespace hapticopt
