// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_theory.hpp"

#include <algorithm>
#include <cmath>

#include <hapticopt/energy_costs.hpp>
#include <hapticopt/optimum.hpp>
#include <hapticopt/overshoot.hpp>
#include <hapticopt/parameters.hpp>
#include <hapticopt/stability.hpp>
#include <hapticopt/stability_region.hpp>

#include "svg/svg_figure.hpp"

namespace hapticd::experiment {

struct Theory::Impl {
    TheoryPlant physical;
    hapticopt::NormalizedPlant plant;
    hapticopt::WallOptimizer optimizer;
    double k_scale, b_scale;

    explicit Impl(const TheoryPlant& p)
        : physical(p),
          plant(hapticopt::normalize(hapticopt::PhysicalPlant{p.mass, p.damping, p.stiffness, p.period, p.time_delay})),
          optimizer(plant),
          k_scale(p.mass / (p.period * p.period)),
          b_scale(p.mass / p.period) {}
    [[nodiscard]] hapticopt::NormalizedGains gains(double K, double B) const { return {K / k_scale, B / b_scale}; }
};

Theory::Theory(const TheoryPlant& plant) : impl_(std::make_unique<Impl>(plant)) {}
Theory::~Theory() = default;

const TheoryPlant& Theory::plant() const noexcept { return impl_->physical; }
double Theory::k_scale() const noexcept { return impl_->k_scale; }
double Theory::b_scale() const noexcept { return impl_->b_scale; }
double Theory::max_stiffness() const { return impl_->optimizer.region().alpha_max() * impl_->k_scale; }
double Theory::damping_at_max_stiffness() const {
    return impl_->optimizer.region().beta_at_alpha_max() * impl_->b_scale;
}

std::pair<double, double> Theory::damping_extent() const {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (const auto& p : impl_->optimizer.region().polygon(512)) {
        lo = std::min(lo, p.beta);
        hi = std::max(hi, p.beta);
    }
    return {lo * impl_->b_scale, hi * impl_->b_scale};
}

bool Theory::is_stable(double K, double B) const { return hapticopt::is_stable(impl_->plant, impl_->gains(K, B)); }

double Theory::spectral_radius(double K, double B) const {
    return hapticopt::stability(impl_->plant, impl_->gains(K, B)).spectral_radius;
}

double Theory::boundary_stiffness(double B) const {
    // Stable just above K = 0 (alpha = max(0, -gamma) + a tiny step), unstable beyond alpha_max.
    const double a_max = impl_->optimizer.region().alpha_max();
    double lo = 1e-9 * a_max, hi = 1.01 * a_max;
    if (!is_stable(lo * impl_->k_scale, B)) return 0.0;
    while (hi - lo > 1e-12 * a_max) {
        const double mid = (lo + hi) / 2.0;
        (is_stable(mid * impl_->k_scale, B) ? lo : hi) = mid;
    }
    return (lo + hi) / 2.0 * impl_->k_scale;
}

std::pair<double, double> Theory::stable_damping(double K) const {
    const auto [lo, hi] = impl_->optimizer.region().beta_range(K / impl_->k_scale);
    return {lo * impl_->b_scale, hi * impl_->b_scale};
}

double Theory::optimal_damping(int index, double K) const {
    return impl_->optimizer.optimal_beta(index, K / impl_->k_scale) * impl_->b_scale;
}

TheoryCosts Theory::costs(double K, double B, double overshoot_tolerance) const {
    const auto g = impl_->gains(K, B);
    const hapticopt::EnergyCosts e = hapticopt::energy_costs(impl_->plant, g);
    hapticopt::OvershootOptions o;
    o.tolerance = overshoot_tolerance;
    return {e.ce0, e.ce1, e.ce2, hapticopt::overshoot(impl_->plant, g, o).value};
}

std::pair<double, double> Theory::ce2_optimum() const {
    const hapticopt::Optimum o = impl_->optimizer.optimum(hapticopt::Criterion::CE2);
    return {o.alpha * impl_->k_scale, o.beta * impl_->b_scale};
}

std::vector<std::pair<double, double>> Theory::boundary_polyline(int points) const {
    return hapticopt::cli::scaled(hapticopt::cli::boundary_curve(impl_->optimizer.region(), points), impl_->k_scale,
                                  impl_->b_scale);
}

}  // namespace hapticd::experiment
