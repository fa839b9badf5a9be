// SPDX-License-Identifier: Apache-2.0
// hapticopt._core: the pybind11 extension over the header library include/hapticopt/ (one
// implementation, two languages). It takes and returns plain numbers, tuples, dicts and numpy
// arrays; the Python package (python/src/hapticopt/) wraps them in dataclasses and documents the
// equations. One translation unit on purpose: the library's templates cost ~20 s of compile each.
//
// Errors: hapticopt::InvalidParameter becomes hapticopt.InvalidParameterError (a ValueError) with
// the library's message and the attributes `parameter` and `value`; an unknown criterion name is a
// ValueError naming the accepted names. The vectorised functions release the GIL while they compute.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <hapticopt/hapticopt.hpp>

namespace py = pybind11;
using namespace hapticopt;

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The criteria a single cost surface exists for (vectorised costs and optimal curves).
/// CE0 .. CE2 are 0 .. 2 and CI0 .. CI2 are 4 .. 6: their energy index plus 0 or 4 (parse_surface).
enum class Surface { CE0, CE1, CE2, OV, CI0, CI1, CI2 };

/// The names of the surfaces, in the enum's order: CE0, CE1, CE2, OV, CI0, CI1, CI2 (criterion.hpp's names).
const std::vector<std::string>& surface_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> out = criterion_names(kEnergyCriteria);
        out.emplace_back(to_string(Criterion::Overshoot));
        for (const std::string& n : criterion_names(kAllImpulseCriteria)) out.push_back(n);
        return out;
    }();
    return names;
}

/// The step and collision criteria, in the order of kAllCriteria then kAllImpulseCriteria.
std::string step_and_collision_names() {
    std::vector<std::string> names = criterion_names(kAllCriteria);
    for (const std::string& n : criterion_names(kAllImpulseCriteria)) names.push_back(n);
    return joined_names(names);
}

/// The criteria passive and robust optima exist for: CE0, CE1, CE2, CI0, CI1, CI2.
std::string energy_and_collision_names() {
    std::vector<std::string> names = criterion_names(kEnergyCriteria);
    for (const std::string& n : criterion_names(kAllImpulseCriteria)) names.push_back(n);
    return joined_names(names);
}

Surface parse_surface(const std::string& function, const std::string& name) {
    if (const auto c = parse_criterion(name)) {
        if (*c == Criterion::Overshoot) return Surface::OV;
        if (const auto k = energy_index(*c); k && !requires_no_overshoot(*c))
            return static_cast<Surface>(*k);  // CE0 .. CE2
    }
    if (const auto ci = parse_impulse_criterion(name))
        return static_cast<Surface>(4 + energy_index(*ci));  // CI0 .. CI2
    throw py::value_error(function + ": criterion = '" + name +
                          "' is invalid; accepted: " + joined_names(surface_names()));
}

NormalizedPlant plant_of(double gamma, double delta, double delay) { return NormalizedPlant{gamma, delta, delay}; }

/// One cost evaluation on a precomputed plant; +inf when unstable (the library's convention).
double surface_cost(Surface s, const SampledPlant<double>& plant, double alpha, double beta,
                    const OvershootOptions& overshoot_options) {
    switch (s) {
        case Surface::CE0:
            return energy_cost(plant, alpha, beta, 0);
        case Surface::CE1:
            return energy_cost(plant, alpha, beta, 1);
        case Surface::CE2:
            return energy_cost(plant, alpha, beta, 2);
        case Surface::OV:
            return overshoot(plant, alpha, beta, overshoot_options).value;
        case Surface::CI0:
            return impulse_costs(plant, alpha, beta).ci0;
        case Surface::CI1:
            return impulse_costs(plant, alpha, beta).ci1;
        case Surface::CI2:
            return impulse_costs(plant, alpha, beta).ci2;
    }
    return kNaN;
}

OvershootOptions overshoot_options_of(const char* function, double tolerance) {
    detail::require_in_range(function, "overshoot_tolerance", tolerance, 0.0, true, 1.0, "0 < tolerance <= 1");
    OvershootOptions o;
    o.tolerance = tolerance;
    return o;
}

void require_same_shape(const char* function, const DoubleArray& a, const DoubleArray& b) {
    if (a.ndim() != b.ndim() || !std::equal(a.shape(), a.shape() + a.ndim(), b.shape())) {
        throw py::value_error(std::string(function) +
                              ": alpha and beta must have the same shape (broadcast them first)");
    }
}

/// Runs `body` with the GIL released; an exception thrown inside is carried out and rethrown with
/// the GIL held (pybind11 translates exceptions only then).
template <typename Body>
void without_gil(Body&& body) {
    std::exception_ptr failure;
    {
        py::gil_scoped_release release;
        try {
            body();
        } catch (...) {
            failure = std::current_exception();
        }
    }
    if (failure) std::rethrow_exception(failure);
}

/// Vectorised cost: one cell per (alpha[i], beta[i]); NaN where an input is not finite; +inf where
/// the loop is unstable. The plant is set up once. GIL released; `threads` worker threads take
/// interleaved cells (cell i by thread i mod threads: C_OV's cost varies across the region), each
/// cell computed exactly as with one thread.
py::array_t<double> cost_array(const std::string& criterion, double gamma, double delta, double delay,
                               const DoubleArray& alpha, const DoubleArray& beta, double overshoot_tolerance,
                               int threads) {
    const char* fn = "hapticopt.cost";
    const Surface s = parse_surface(fn, criterion);
    require_same_shape(fn, alpha, beta);
    detail::require_in_range(fn, "threads", threads, 1, false, 1024, "1 <= threads <= 1024");
    const OvershootOptions o = overshoot_options_of(fn, overshoot_tolerance);
    const SampledPlant<double> plant(plant_of(gamma, delta, delay));
    py::array_t<double> out(std::vector<py::ssize_t>(alpha.shape(), alpha.shape() + alpha.ndim()));
    const double* a = alpha.data();
    const double* b = beta.data();
    double* c = out.mutable_data();
    const py::ssize_t n = alpha.size();
    auto cells = [&](py::ssize_t first, py::ssize_t stride) {
        for (py::ssize_t i = first; i < n; i += stride) {
            c[i] = std::isfinite(a[i]) && std::isfinite(b[i]) ? surface_cost(s, plant, a[i], b[i], o) : kNaN;
        }
    };
    without_gil([&] {
        const auto workers = static_cast<py::ssize_t>(std::min<py::ssize_t>(threads, std::max<py::ssize_t>(n, 1)));
        if (workers <= 1) {
            cells(0, 1);
            return;
        }
        std::vector<std::exception_ptr> failures(static_cast<std::size_t>(workers));
        std::vector<std::thread> pool;
        pool.reserve(static_cast<std::size_t>(workers));
        for (py::ssize_t w = 0; w < workers; ++w) {
            pool.emplace_back([&, w] {
                try {
                    cells(w, workers);
                } catch (...) {
                    failures[static_cast<std::size_t>(w)] = std::current_exception();
                }
            });
        }
        for (std::thread& t : pool) t.join();
        for (const std::exception_ptr& f : failures) {
            if (f) std::rethrow_exception(f);
        }
    });
    return out;
}

/// Every criterion at one point (what `hapticopt cost --json` prints).
py::dict point_costs(double gamma, double delta, double delay, double alpha, double beta, double overshoot_tolerance) {
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    const NormalizedGains gains{alpha, beta};
    validate(gains, "hapticopt.costs");
    const OvershootOptions o = overshoot_options_of("hapticopt.costs", overshoot_tolerance);
    const SampledPlant<double> plant(np);
    const StabilityReport report = stability(np, gains);
    const EnergyCosts e = energy_costs(plant, alpha, beta);
    const OvershootResult ov = overshoot(plant, alpha, beta, o);
    const ImpulseCosts ic = impulse_costs(plant, alpha, beta);
    const PenetrationResult pen = penetration(plant, alpha, beta, 1000000LL);  // the CLI's cap (cost_command.cpp)
    py::dict d;
    d["stable"] = report.stable;
    d["spectral_radius"] = report.spectral_radius;
    d["ce0"] = e.ce0;
    d["ce1"] = e.ce1;
    d["ce2"] = e.ce2;
    d["ov"] = ov.value;
    d["no_overshoot"] = ov.within_tolerance;
    d["ci0"] = ic.ci0;
    d["ci1"] = ic.ci1;
    d["ci2"] = ic.ci2;
    d["penetration"] = pen.depth;
    d["force_noise_gain"] = force_noise_gain(np, gains);
    // The passivity condition covers integer delays only (passivity.hpp); None otherwise.
    d["passivity_margin"] =
        passivity_is_covered(np) ? py::object(py::float_(passivity_margin(np, gains))) : py::object(py::none());
    return d;
}

py::tuple stability_of(double gamma, double delta, double delay, double alpha, double beta) {
    const StabilityReport r = stability(plant_of(gamma, delta, delay), NormalizedGains{alpha, beta});
    return py::make_tuple(r.stable, r.margin, r.spectral_radius, r.refined);
}

py::tuple overshoot_of(double gamma, double delta, double delay, double alpha, double beta, double tolerance,
                       long long max_periods) {
    validate(NormalizedGains{alpha, beta}, "hapticopt.overshoot");
    detail::require_in_range("hapticopt.overshoot", "max_periods", static_cast<double>(max_periods), 1.0, false, 1e18,
                             "1 <= max_periods");
    OvershootOptions o = overshoot_options_of("hapticopt.overshoot", tolerance);
    o.max_periods = max_periods;
    const OvershootResult r = overshoot(SampledPlant<double>(plant_of(gamma, delta, delay)), alpha, beta, o);
    return py::make_tuple(r.value, r.time, r.within_tolerance, r.converged, r.periods);
}

py::tuple penetration_of(double gamma, double delta, double delay, double alpha, double beta, long long max_periods) {
    validate(NormalizedGains{alpha, beta}, "hapticopt.penetration");
    const PenetrationResult r =
        penetration(SampledPlant<double>(plant_of(gamma, delta, delay)), alpha, beta, max_periods);
    return py::make_tuple(r.depth, r.time, r.converged, r.periods);
}

/// x(t), x'(t), E(t) at the given times (any order); GIL released.
py::tuple step_response_of(double gamma, double delta, double delay, double alpha, double beta,
                           const DoubleArray& times) {
    const char* fn = "hapticopt.step_response";
    validate(NormalizedGains{alpha, beta}, fn);
    const SampledPlant<double> plant(plant_of(gamma, delta, delay));
    std::vector<double> t(times.data(), times.data() + times.size());
    // The cost is O(N^2 t) (one loop-map step per period): a cap keeps a typo from hanging the call.
    for (const double v : t)
        detail::require_in_range(fn, "time", v, 0.0, false, 1e8, "finite, 0 <= time <= 10^8 periods");
    std::vector<StepResponsePoint> points;
    without_gil([&] { points = step_response(plant, alpha, beta, t); });
    const std::vector<py::ssize_t> shape(times.shape(), times.shape() + times.ndim());
    py::array_t<double> x(shape), v(shape), e(shape);
    for (std::size_t i = 0; i < points.size(); ++i) {
        x.mutable_data()[i] = points[i].position;
        v.mutable_data()[i] = points[i].velocity;
        e.mutable_data()[i] = points[i].energy;
    }
    return py::make_tuple(x, v, e, 1.0 / (alpha + gamma));
}

py::array_t<double> sampled_step_response_of(double gamma, double delta, double delay, double alpha, double beta,
                                             long long samples) {
    detail::require_in_range("hapticopt.sampled_step_response", "samples", static_cast<double>(samples), 0.0, false,
                             1e8, "0 <= samples <= 10^8");
    const std::vector<double> x = sampled_step_response(plant_of(gamma, delta, delay), NormalizedGains{alpha, beta},
                                                        static_cast<std::size_t>(samples));
    py::array_t<double> out(static_cast<py::ssize_t>(x.size()));
    std::copy(x.begin(), x.end(), out.mutable_data());
    return out;
}

py::dict boundary_of(double gamma, double delta, double delay, int points) {
    const StabilityRegion region(plant_of(gamma, delta, delay));
    const std::vector<BoundaryPoint> polygon = region.polygon(points);
    const auto n = static_cast<py::ssize_t>(polygon.size());
    py::array_t<double> theta(n), alpha(n), beta(n);
    for (py::ssize_t i = 0; i < n; ++i) {
        theta.mutable_data()[i] = polygon[static_cast<std::size_t>(i)].theta;
        alpha.mutable_data()[i] = polygon[static_cast<std::size_t>(i)].alpha;
        beta.mutable_data()[i] = polygon[static_cast<std::size_t>(i)].beta;
    }
    py::dict d;
    d["theta"] = theta;
    d["alpha"] = alpha;
    d["beta"] = beta;
    d["alpha_max"] = region.alpha_max();
    d["beta_at_alpha_max"] = region.beta_at_alpha_max();
    d["alpha_min"] = region.alpha_min();
    d["closing_frequency"] = region.closing_frequency();
    return d;
}

py::tuple beta_range_of(double gamma, double delta, double delay, double alpha) {
    const auto [lo, hi] = StabilityRegion(plant_of(gamma, delta, delay)).beta_range(alpha);
    return py::make_tuple(lo, hi);
}

OptimumOptions optimum_options_of(double overshoot_tolerance, int alpha_grid, int beta_grid, double alpha_tolerance) {
    OptimumOptions o;
    o.overshoot_tolerance = overshoot_tolerance;
    o.alpha_grid = alpha_grid;
    o.beta_grid = beta_grid;
    o.alpha_tolerance = alpha_tolerance;
    return o;
}

/// beta_opt(alpha) and the cost there at each alpha; NaN where alpha is not finite or outside the
/// open stiffness range (alpha_min, alpha_max]. GIL released.
py::tuple optimal_curve_of(const std::string& criterion, double gamma, double delta, double delay,
                           const DoubleArray& alpha, double overshoot_tolerance, int alpha_grid, int beta_grid) {
    const char* fn = "hapticopt.optimal_curve";
    const Surface s = parse_surface(fn, criterion);
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    const auto n = alpha.size();
    py::array_t<double> beta_out(n), cost_out(n);
    const double* a = alpha.data();
    double* b = beta_out.mutable_data();
    double* c = cost_out.mutable_data();
    const bool impulse = s == Surface::CI0 || s == Surface::CI1 || s == Surface::CI2;
    const int index = s == Surface::CE0 || s == Surface::CI0   ? 0
                      : s == Surface::CE1 || s == Surface::CI1 ? 1
                      : s == Surface::OV                       ? 3
                                                               : 2;
    if (impulse) {
        const ImpulseOptimizer opt(np, RegionSearchOptions{alpha_grid, beta_grid});
        detail::require_in_range(fn, "beta_grid", beta_grid, 4, false, 1e6, "4 <= beta_grid <= 10^6");
        without_gil([&] {
            for (py::ssize_t i = 0; i < n; ++i) {
                const bool inside =
                    std::isfinite(a[i]) && a[i] > opt.region().alpha_min() && a[i] <= opt.region().alpha_max();
                b[i] = inside ? opt.optimal_beta(index, a[i]) : kNaN;
                c[i] = inside ? opt.cost(index, a[i], b[i]) : kNaN;
            }
        });
    } else {
        const WallOptimizer opt(np, optimum_options_of(overshoot_tolerance, alpha_grid, beta_grid, 1e-10));
        without_gil([&] {
            for (py::ssize_t i = 0; i < n; ++i) {
                const bool inside =
                    std::isfinite(a[i]) && a[i] > opt.region().alpha_min() && a[i] <= opt.region().alpha_max();
                b[i] = inside ? opt.optimal_beta(index, a[i]) : kNaN;
                c[i] = !inside ? kNaN : index < 3 ? opt.energy_cost(index, a[i], b[i]) : opt.overshoot_cost(a[i], b[i]);
            }
        });
    }
    return py::make_tuple(beta_out, cost_out);
}

/// The optimum of a step criterion (amax, OV, CE0..2, CE0..2+OV) or a collision criterion (CI0..2).
py::dict optimal_point_of(const std::string& criterion, double gamma, double delta, double delay,
                          double overshoot_tolerance, int alpha_grid, int beta_grid, double alpha_tolerance) {
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    py::dict d;
    if (const auto c = parse_criterion(criterion)) {
        const OptimumOptions o = optimum_options_of(overshoot_tolerance, alpha_grid, beta_grid, alpha_tolerance);
        Optimum r;
        without_gil([&] { r = optimal_point(*c, np, o); });
        d["alpha"] = r.alpha;
        d["beta"] = r.beta;
        d["cost"] = r.cost ? py::object(py::float_(*r.cost)) : py::object(py::none());
        d["alpha_max"] = r.alpha_max;
        d["beta_at_alpha_max"] = r.beta_at_alpha_max;
        return d;
    }
    if (const auto c = parse_impulse_criterion(criterion)) {
        const RegionSearchOptions o{alpha_grid, beta_grid};
        ImpulseOptimum r;
        without_gil([&] { r = optimal_point(*c, np, o); });
        d["alpha"] = r.alpha;
        d["beta"] = r.beta;
        d["cost"] = py::float_(r.cost);
        d["alpha_max"] = r.alpha_max;
        d["penetration"] = r.penetration;
        d["penetration_converged"] = r.penetration_converged;
        d["on_region_edge"] = r.on_region_edge;
        return d;
    }
    throw py::value_error("hapticopt.optimal_point: criterion = '" + criterion +
                          "' is invalid; accepted: " + step_and_collision_names());
}

py::dict physical_plant_dict(const PhysicalPlant& p) {
    py::dict d;
    d["mass"] = p.mass;
    d["damping"] = p.damping;
    d["stiffness"] = p.stiffness;
    d["period"] = p.period;
    d["time_delay"] = p.time_delay;
    return d;
}

VelocityEstimator estimator_of(const std::string& kind, double cutoff, int window);

py::dict robust_optimum_of(const std::string& criterion, std::pair<double, double> mass,
                           std::pair<double, double> damping, std::pair<double, double> stiffness, double period,
                           std::pair<double, double> time_delay, const std::string& kind, double cutoff, int window,
                           double force_noise_budget, double position_resolution) {
    RobustOptions options;
    options.estimator = estimator_of(kind, cutoff, window);
    options.force_noise_budget = force_noise_budget;
    options.position_resolution = position_resolution;
    UncertainPlant box;
    box.mass = {mass.first, mass.second};
    box.damping = {damping.first, damping.second};
    box.stiffness = {stiffness.first, stiffness.second};
    box.period = period;
    box.time_delay = {time_delay.first, time_delay.second};
    RobustOptimum r;
    if (const auto c = parse_criterion(criterion)) {
        without_gil([&] { r = robust_optimum(*c, box, options); });
    } else if (const auto ci = parse_impulse_criterion(criterion)) {
        without_gil([&] { r = robust_optimum(*ci, box, options); });
    } else {
        throw py::value_error("hapticopt.robust_optimum: criterion = '" + criterion +
                              "' is invalid; accepted: " + energy_and_collision_names());
    }
    py::dict d;
    d["stiffness"] = r.gains.stiffness;
    d["damping"] = r.gains.damping;
    d["worst_cost"] = r.worst.cost;
    d["worst_at"] = physical_plant_dict(r.worst.where);
    d["stable_over_box"] = r.stability.stable;
    d["mass_segments_certified"] = r.stability.mass_segments_certified;
    d["K_max"] = r.K_max;
    d["nominal"] = physical_plant_dict(r.nominal);
    d["nominal_stiffness"] = r.nominal_gains.stiffness;
    d["nominal_damping"] = r.nominal_gains.damping;
    d["nominal_worst_cost"] = r.nominal_worst.cost;
    d["nominal_stable_over_box"] = r.nominal_stability.stable;
    d["force_noise_max"] = r.force_noise_max;
    return d;
}

/// The estimator from the Python package's fields (kind "backward", "lowpass" or "window"); the library's
/// factories validate nu and N (InvalidParameter naming `cutoff` or `window`).
VelocityEstimator estimator_of(const std::string& kind, double cutoff, int window) {
    if (kind == "backward") return VelocityEstimator::backward_difference();
    if (kind == "lowpass") return VelocityEstimator::low_pass(cutoff);
    if (kind == "window") return VelocityEstimator::moving_window(window);
    throw py::value_error("hapticopt.VelocityEstimator: kind = '" + kind +
                          "' is invalid; accepted: backward, lowpass, window");
}

/// Stability of physical gains for every mass of [m_min, m_max] (free-mass plant, mass_scaling_stability.hpp):
/// stable, the failing mass (None when stable) and every mass at which a root lies on the unit circle.
py::dict mass_range_stability_of(double K, double B, std::pair<double, double> mass, double period, double time_delay,
                                 const std::string& kind, double cutoff, int window) {
    const char* fn = "hapticopt.mass_range_stability";
    detail::require_positive(fn, "mass.min", mass.first);
    detail::require_in_range(fn, "mass.max", mass.second, mass.first, false, HUGE_VAL, "finite and >= mass.min");
    detail::require_positive(fn, "period", period);
    detail::require_in_range(fn, "stiffness", K, 0.0, false, HUGE_VAL, "finite and >= 0");
    detail::require_finite(fn, "damping", B);
    const MassScalingTest test(NormalizedPlant{0.0, 0.0, time_delay / period}, estimator_of(kind, cutoff, window));
    const double alpha = K * period * period / mass.second, beta = B * period / mass.second;
    GainRayStability r;
    std::vector<double> crossings;
    without_gil([&] {
        r = test.over(alpha, beta, 1.0, mass.second / mass.first);
        crossings = gain_ray_crossings(test.polynomial(), alpha, beta);
    });
    std::vector<double> masses;
    for (auto it = crossings.rbegin(); it != crossings.rend(); ++it) masses.push_back(mass.second / *it);
    py::dict d;
    d["stable"] = r.stable;
    d["failing_mass"] = r.stable ? py::object(py::none()) : py::object(py::float_(mass.second / r.failing_scale));
    d["crossing_masses"] = masses;
    return d;
}

/// The best passive gains with the loop's estimator (estimator_passivity.hpp; the backward difference is
/// passivity.hpp's optimum).
std::optional<py::dict> passive_optimum_of(const std::string& criterion, double gamma, double delta, double delay,
                                           const std::string& kind, double cutoff, int window) {
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    const VelocityEstimator e = estimator_of(kind, cutoff, window);
    std::optional<PassiveOptimum> r;
    const auto c = parse_criterion(criterion);
    const auto ci = parse_impulse_criterion(criterion);
    if (c && energy_index(*c) && !requires_no_overshoot(*c)) {
        without_gil([&] { r = passive_optimum(*energy_index(*c), np, e); });
    } else if (ci) {
        without_gil([&] { r = passive_impulse_optimum(energy_index(*ci), np, e); });
    } else {
        throw py::value_error("hapticopt.passive_optimum: criterion = '" + criterion +
                              "' is invalid; accepted: " + energy_and_collision_names());
    }
    if (!r) return std::nullopt;
    py::dict d;
    d["alpha"] = r->alpha;
    d["beta"] = r->beta;
    d["cost"] = r->cost;
    d["margin"] = r->margin;
    return d;
}

/// Stability, C_E0..2, C_OV, C_I0..2, the penetration, the passivity margin and g_F at one point with the
/// estimator (what `hapticopt cost --velocity --json` prints: estimator_impulse.hpp, estimator_passivity.hpp;
/// the penetration with the CLI's cap of 10^6 periods, +inf when unstable; the margin None for a fractional delay).
py::dict estimator_point_costs(double gamma, double delta, double delay, double alpha, double beta,
                               const std::string& kind, double cutoff, int window, double overshoot_tolerance) {
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    const NormalizedGains gains{alpha, beta};
    const VelocityEstimator e = estimator_of(kind, cutoff, window);
    const OvershootOptions o = overshoot_options_of("hapticopt.costs", overshoot_tolerance);
    StabilityReport report;
    EnergyCosts c;
    OvershootResult ov;
    ImpulseCosts ic{};
    double depth = HUGE_VAL, margin = 0, g = 0;
    const bool covered = passivity_is_covered(np);
    without_gil([&] {
        report = stability(np, gains, e);
        c = energy_costs(np, gains, e);
        ov = overshoot(np, gains, e, o);
        ic = impulse_costs(np, gains, e);
        if (report.stable) depth = estimator_penetration(SampledPlant<double>(np), e, alpha, beta, 1000000LL).depth;
        if (covered) margin = passivity_margin(np, gains, e);
        g = force_noise_gain(np, gains, e);
    });
    py::dict d;
    d["stable"] = report.stable;
    d["margin"] = report.margin;
    d["refined"] = report.refined;
    d["spectral_radius"] = report.spectral_radius;
    d["ce0"] = c.ce0;
    d["ce1"] = c.ce1;
    d["ce2"] = c.ce2;
    d["ov"] = ov.value;
    d["no_overshoot"] = report.stable && ov.within_tolerance;
    d["ci0"] = ic.ci0;
    d["ci1"] = ic.ci1;
    d["ci2"] = ic.ci2;
    d["penetration"] = depth;
    d["passivity_margin"] = covered ? py::object(py::float_(margin)) : py::object(py::none());
    d["force_noise_gain"] = g;
    return d;
}

py::tuple estimator_stability_of(double gamma, double delta, double delay, double alpha, double beta,
                                 const std::string& kind, double cutoff, int window) {
    const StabilityReport r =
        stability(plant_of(gamma, delta, delay), NormalizedGains{alpha, beta}, estimator_of(kind, cutoff, window));
    return py::make_tuple(r.stable, r.margin, r.spectral_radius, r.refined);
}

double force_noise_gain_of(double gamma, double delta, double delay, double alpha, double beta, const std::string& kind,
                           double cutoff, int window) {
    return force_noise_gain(plant_of(gamma, delta, delay), NormalizedGains{alpha, beta},
                            estimator_of(kind, cutoff, window));
}

/// The optimum of every criterion with the estimator (estimator_optimum.hpp's optimal_point; OV by
/// noise_budget.hpp's estimator_overshoot_point), g_F there and the stable islands of the gain plane (as
/// `hapticopt optimum --velocity --json`).
py::dict estimator_optimal_point_of(const std::string& criterion, double gamma, double delta, double delay,
                                    const std::string& kind, double cutoff, int window, double overshoot_tolerance) {
    const char* fn = "hapticopt.optimal_point";
    const auto c = parse_criterion(criterion);
    if (!c) {
        throw py::value_error(std::string(fn) + ": criterion = '" + criterion +
                              "' is invalid with a velocity estimator; accepted: amax, OV, CE0, CE1, CE2, CE0+OV, "
                              "CE1+OV, CE2+OV");
    }
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    const VelocityEstimator e = estimator_of(kind, cutoff, window);
    EstimatorOptimumOptions o;
    o.overshoot_tolerance = overshoot_tolerance;
    EstimatorOptimum r;
    double g = 0;
    std::vector<StableIsland> islands;
    without_gil([&] {
        r = estimator_optimum(*c, np, e, o);  // OV too (noise_budget.hpp)
        g = force_noise_gain(np, NormalizedGains{r.alpha, r.beta}, e);
        islands = EstimatorStabilityRegion(np, e).islands();
    });
    py::dict d;
    d["alpha"] = r.alpha;
    d["beta"] = r.beta;
    d["cost"] = r.cost ? py::object(py::float_(*r.cost)) : py::object(py::none());
    d["alpha_max"] = r.alpha_max;
    d["beta_at_alpha_max"] = r.beta_at_alpha_max;
    d["force_noise_gain"] = g;
    py::list l;
    for (const StableIsland& i : islands) l.append(py::make_tuple(i.alpha_min, i.alpha_max, i.beta_min, i.beta_max));
    d["stable_islands"] = l;
    return d;
}

/// The optimum of a step criterion under g_F <= noise_budget (noise_budget.hpp), as `hapticopt optimum --noise-budget`.
py::dict noise_budget_optimum_of(const std::string& criterion, double gamma, double delta, double delay,
                                 const std::string& kind, double cutoff, int window, double noise_budget) {
    const auto c = parse_criterion(criterion);
    if (!c) {
        throw py::value_error("hapticopt.optimal_point_under_noise_budget: criterion = '" + criterion +
                              "' is invalid; accepted: amax, OV, CE0, CE1, CE2, CE0+OV, CE1+OV, CE2+OV");
    }
    const NormalizedPlant np = plant_of(gamma, delta, delay);
    const VelocityEstimator e = estimator_of(kind, cutoff, window);
    NoiseBudgetOptimum r;
    without_gil([&] { r = optimal_point_under_noise_budget(*c, np, e, noise_budget); });
    py::dict d;
    d["noise_budget"] = r.noise_budget;
    d["alpha"] = r.alpha;
    d["beta"] = r.beta;
    d["cost"] = r.cost;
    d["force_noise_gain"] = r.force_noise_gain;
    d["budget_active"] = r.budget_active;
    d["alpha_max"] = r.alpha_max;
    d["unconstrained_cost"] = r.unconstrained_cost;
    d["unconstrained_force_noise_gain"] = r.unconstrained_force_noise_gain;
    return d;
}

py::dict limit_cycle_dict(const PredictedLimitCycle& c) {
    py::dict d;
    d["amplitude"] = c.amplitude;
    d["frequency"] = c.frequency;
    d["theta"] = c.theta;
    d["mean_position"] = c.mean_position;
    d["describing_gain"] = c.describing_gain;
    d["equivalent_damping"] = c.equivalent_damping;
    d["stable"] = c.stable;
    return d;
}

/// The describing-function prediction of limit_cycles.hpp (physical units), as `hapticopt limit-cycle`.
py::dict limit_cycle_of(double mass, double period, double damping, double stiffness, double time_delay, double K,
                        double B, double coulomb_friction, double position_step, double external_force) {
    LimitCycleLoop loop;
    loop.plant = PhysicalPlant{mass, damping, stiffness, period, time_delay};
    loop.gains = WallGains{K, B};
    loop.coulomb_friction = coulomb_friction;
    loop.position_step = position_step;
    loop.external_force = external_force;
    LimitCyclePrediction p;
    without_gil([&] { p = predict_limit_cycle(loop); });
    py::dict d;
    d["predicted"] = p.predicted;
    d["cycle"] = p.predicted ? py::object(limit_cycle_dict(p.cycle)) : py::object(py::none());
    py::list all;
    for (const auto& c : p.cycles) all.append(limit_cycle_dict(c));
    d["cycles"] = all;
    d["rest_exists"] = p.rest_exists;
    d["grows_at_large_amplitude"] = p.grows_at_large_amplitude;
    return d;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
    m.doc() = "hapticopt._core: bindings over the C++ header library (use the hapticopt package, not this module)";
    m.attr("__version__") = HAPTICOPT_VERSION_STRING;
    m.attr("STEP_CRITERIA") = py::tuple(py::cast(criterion_names(kAllCriteria)));
    m.attr("COLLISION_CRITERIA") = py::tuple(py::cast(criterion_names(kAllImpulseCriteria)));
    m.attr("SURFACE_CRITERIA") = py::tuple(py::cast(surface_names()));

    static py::exception<InvalidParameter> invalid_parameter(m, "InvalidParameterError", PyExc_ValueError);
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const InvalidParameter& e) {
            py::object instance = py::reinterpret_borrow<py::object>(invalid_parameter)(e.what());
            instance.attr("parameter") = e.parameter();
            instance.attr("value") = e.value();
            PyErr_SetObject(invalid_parameter.ptr(), instance.ptr());
        }
    });

    m.def("normalize_plant", [](double mass, double damping, double stiffness, double period, double time_delay) {
        const NormalizedPlant n = normalize(PhysicalPlant{mass, damping, stiffness, period, time_delay});
        return py::make_tuple(n.gamma, n.delta, n.delay);
    });
    m.def("to_physical_plant", [](double gamma, double delta, double delay, double mass, double period) {
        const PhysicalPlant p = to_physical(NormalizedPlant{gamma, delta, delay}, mass, period);
        return py::make_tuple(p.mass, p.damping, p.stiffness, p.period, p.time_delay);
    });
    m.def("normalize_gains", [](double stiffness, double damping, double mass, double period) {
        const NormalizedGains g = normalize(WallGains{stiffness, damping}, mass, period);
        return py::make_tuple(g.alpha, g.beta);
    });
    m.def("to_physical_gains", [](double alpha, double beta, double mass, double period) {
        const WallGains g = to_physical(NormalizedGains{alpha, beta}, mass, period);
        return py::make_tuple(g.stiffness, g.damping);
    });
    m.def("validate_plant", [](double gamma, double delta, double delay) {
        validate(plant_of(gamma, delta, delay), "hapticopt.Plant");  // the user's call in the message, not ours
        SampledPlant<double> check(plant_of(gamma, delta, delay));   // and the model's own limits (delay cap)
        (void)check;
    });
    m.def("stability", &stability_of);
    m.def("point_costs", &point_costs);
    m.def("cost_array", &cost_array);
    m.def("overshoot", &overshoot_of);
    m.def("penetration", &penetration_of);
    m.def("step_response", &step_response_of);
    m.def("sampled_step_response", &sampled_step_response_of);
    m.def("boundary", &boundary_of);
    m.def("beta_range", &beta_range_of);
    m.def("optimal_curve", &optimal_curve_of);
    m.def("optimal_point", &optimal_point_of);
    m.def("robust_optimum", &robust_optimum_of);
    m.def("mass_range_stability", &mass_range_stability_of);
    m.def("passivity_margin", [](double gamma, double delta, double delay, double alpha, double beta,
                                 const std::string& kind, double cutoff, int window) {
        return passivity_margin(plant_of(gamma, delta, delay), NormalizedGains{alpha, beta},
                                estimator_of(kind, cutoff, window));
    });
    m.def("passive_optimum", &passive_optimum_of);
    m.def("estimator_stability", &estimator_stability_of);
    m.def("estimator_point_costs", &estimator_point_costs);
    m.def("force_noise_gain", &force_noise_gain_of);
    m.def("estimator_optimal_point", &estimator_optimal_point_of);
    m.def("noise_budget_optimum", &noise_budget_optimum_of);
    m.def("limit_cycle", &limit_cycle_of);
    m.def("abbott_okamura_passivity", [](double K, double b, double f_c, double q, double T) {
        const AbbottOkamuraPassivity a = abbott_okamura_passivity(K, b, f_c, q, T);
        return py::make_tuple(a.viscous_bound, a.coulomb_bound, a.stiffness_bound, a.passive);
    });
    m.def("quantised_rest_exists", &quantised_rest_exists);
}
