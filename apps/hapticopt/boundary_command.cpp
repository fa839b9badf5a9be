// SPDX-License-Identifier: Apache-2.0
// hapticopt boundary: the exact stability boundary in the (alpha, beta) plane; with --passivity the
// boundary of the passive set (delay-aware Colgate-Schenkel condition, passivity.hpp; with --velocity the
// estimator's, estimator_passivity.hpp) instead. With a --velocity estimator other than backward: the main stable
// region of the estimator's loop (EstimatorStabilityRegion; its boundary pointwise by estimator_region_boundary), its
// alpha_max, and the stable islands not connected to it, reported separately (alpha_max is the main region's).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include <hapticopt/estimator_passivity.hpp>
#include <hapticopt/estimator_region.hpp>
#include <hapticopt/passivity.hpp>
#include <hapticopt/stability_region.hpp>
#include <hapticopt/estimator_types.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt::cli {

namespace {

/// The passive set {alpha >= 0, delta > max_theta R} as a polygon, its largest alpha and alpha_max.
int print_passive_polygon(const NormalizedPlant& plant, const VelocityEstimator& estimator, int points, bool json,
                          bool csv) {
    // Both throw InvalidParameter for a fractional delay.
    const auto polygon = passive_polygon(plant, estimator, points);
    const PassiveAlphaLimit top = largest_passive_alpha(plant, estimator);
    const double alpha_max = estimator.kind == VelocityEstimatorKind::backward
                                 ? StabilityRegion(plant).alpha_max()
                                 : EstimatorStabilityRegion(plant, estimator).alpha_max();
    if (json) {
        nlohmann::json out;
        out["passive_set"] = true;
        out["velocity_estimator"] = velocity_json(estimator);
        out["largest_passive_alpha"] = top.alpha;
        out["beta_at_largest_passive_alpha"] = top.beta;
        out["alpha_max"] = alpha_max;
        nlohmann::json pts = nlohmann::json::array();
        for (const auto& p : polygon) pts.push_back({{"alpha", p.alpha}, {"beta", p.beta}});
        out["points"] = std::move(pts);
        std::cout << out.dump() << '\n';
        return int{kOk};
    }
    if (csv) {
        std::printf("alpha,beta\n");
        for (const auto& p : polygon) std::printf("%.17g,%.17g\n", p.alpha, p.beta);
        return int{kOk};
    }
    if (polygon.empty()) {
        std::printf("passive set      empty (delta = %g)\n", plant.delta);
        return int{kOk};
    }
    std::printf("velocity         %s\n", velocity_text(estimator).c_str());
    std::printf("largest passive alpha %.12f at beta %.12f (alpha_max %.12f, ratio %.4f)\n", top.alpha, top.beta,
                alpha_max, top.alpha / alpha_max);
    std::printf("%14s %14s\n", "alpha", "beta");
    for (const auto& p : polygon) std::printf("%14.10f %14.10f\n", p.alpha, p.beta);
    return int{kOk};
}

/// The main stable region with the estimator: alpha_max, boundary points (closed), islands.
int print_estimator_boundary(const NormalizedPlant& plant, const VelocityEstimator& estimator, int points, bool json,
                             bool csv) {
    const EstimatorStabilityRegion region(plant, estimator);
    const auto polygon = estimator_region_boundary(region, points);
    if (json) {
        nlohmann::json out;
        out["velocity_estimator"] = velocity_json(estimator);
        out["alpha_max"] = region.alpha_max();
        out["beta_at_alpha_max"] = region.beta_at_alpha_max();
        nlohmann::json pts = nlohmann::json::array();
        for (const auto& [a, b] : polygon) pts.push_back({{"alpha", a}, {"beta", b}});
        out["points"] = std::move(pts);
        out["stable_islands"] = islands_json(region);
        std::cout << out.dump() << '\n';
        return int{kOk};
    }
    if (csv) {
        std::printf("alpha,beta\n");
        for (const auto& [a, b] : polygon) std::printf("%.17g,%.17g\n", a, b);
        return int{kOk};
    }
    std::printf("velocity         %s\nalpha_max        %.12f at beta %.12f (main region)\n",
                velocity_text(estimator).c_str(), region.alpha_max(), region.beta_at_alpha_max());
    for (const StableIsland& i : region.islands()) {
        std::printf("stable island    alpha [%.6g, %.6g], beta [%.6g, %.6g] (not connected to the main region)\n",
                    i.alpha_min, i.alpha_max, i.beta_min, i.beta_max);
    }
    std::printf("%14s %14s\n", "alpha", "beta");
    for (const auto& [a, b] : polygon) std::printf("%14.10f %14.10f\n", a, b);
    return int{kOk};
}

}  // namespace

CommandRunner add_boundary_command(CLI::App& app) {
    struct Args {
        PlantOptions plant;
        VelocityOption velocity;
        int points = 256;
        bool json = false, csv = false, passivity = false;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = app.add_subcommand("boundary", "stability boundary points (closed polygon) and alpha_max");
    args->plant.add_to(*sub);
    args->velocity.add_to(*sub);
    sub->add_option("--points", args->points,
                    "points on the complex-root branch (>= 8); with --velocity: alphas per edge of the main region")
        ->capture_default_str();
    CLI::Option* json = sub->add_flag("--json", args->json, "print one JSON object");
    CLI::Option* csv = sub->add_flag("--csv", args->csv, "print CSV: theta,alpha,beta (with --velocity: alpha,beta)");
    json->excludes(csv);
    sub->add_flag("--passivity", args->passivity,
                  "print the passive set's boundary instead (closed polygon, --points alphas per side; integer delays "
                  "only); CSV: alpha,beta");
    return [args]() {
        const VelocityEstimator estimator = args->velocity.parse(0.0);
        if (args->passivity)
            return print_passive_polygon(args->plant.normalized(), estimator, args->points, args->json, args->csv);
        if (estimator.kind != VelocityEstimatorKind::backward) {
            return print_estimator_boundary(args->plant.normalized(), estimator, args->points, args->json, args->csv);
        }
        const StabilityRegion region(args->plant.normalized());
        const auto polygon = region.polygon(args->points);
        if (args->json) {
            nlohmann::json out;
            out["alpha_max"] = region.alpha_max();
            out["beta_at_alpha_max"] = region.beta_at_alpha_max();
            out["alpha_min"] = region.alpha_min();
            nlohmann::json pts = nlohmann::json::array();
            for (const auto& p : polygon) pts.push_back({{"theta", p.theta}, {"alpha", p.alpha}, {"beta", p.beta}});
            out["points"] = std::move(pts);
            std::cout << out.dump() << '\n';
            return int{kOk};
        }
        if (args->csv) {
            std::printf("theta,alpha,beta\n");
            for (const auto& p : polygon) std::printf("%.17g,%.17g,%.17g\n", p.theta, p.alpha, p.beta);
            return int{kOk};
        }
        std::printf("stiffness range  [%.10f, %.10f]\nalpha_max        %.12f at beta %.12f\n", region.alpha_min(),
                    region.alpha_max(), region.alpha_max(), region.beta_at_alpha_max());
        std::printf("%10s %14s %14s\n", "theta", "alpha", "beta");
        for (const auto& p : polygon) std::printf("%10.6f %14.10f %14.10f\n", p.theta, p.alpha, p.beta);
        return int{kOk};
    };
}

}  // namespace hapticopt::cli
