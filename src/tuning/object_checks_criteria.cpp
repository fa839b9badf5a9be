// SPDX-License-Identifier: Apache-2.0
// GainChecker's gains by criterion: the optimum of a criterion for one of the device's masses, tuned once (off the
// loop, possibly on the server's criterion worker) and cached with its error (object_checks.hpp).
#include "tuning/object_checks.hpp"

#include "common/number_text.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <hapticopt/hapticopt.hpp>

#include "tuning/tuning.hpp"

namespace hapticd {

GainChecker::CachedCriterion GainChecker::tune_criterion(hapticopt::Criterion criterion, double m) {
    // With the loop's velocity estimator and the profile's force-noise budget (judged with the coarsest axis's
    // encoder step, GainCheckPlant::position_resolution): tune_wall's optimum is the config walls'.
    TuningPlant p = plant_;
    if (!free_mass_plant_) {
        p.mass = m;
    } else if (p.force_noise_budget) {
        // b = k = 0: one normalised optimum for every mass. The budget bounds sigma_F = (m q / T^2) g_F(alpha, beta)
        // (estimator_noise.hpp), tightest at the heaviest mass an object can act with: tuned there, the gains
        // (alpha m / T^2, beta m / T) meet it at every lighter mass.
        p.mass = mass_.largest();
    }
    CachedCriterion out;
    try {
        const TuningResult r = tune_wall(criterion, p);
        // Stable over the set: the optimum, or the largest fraction f of it that is (0: none; check_object refuses).
        double f = set_stable_factor(p.mass, r.alpha, r.beta);
        if (!(f > 0.0)) f = 1.0;
        if (p.force_noise_budget && f < 1.0) {
            // sigma_F is the closed loop's (estimator_noise.hpp), not linear in the gains: the derated gains are
            // judged again.
            const double sigma =
                hapticopt::force_noise_std(to_hapticopt(p), hapticopt::WallGains{f * r.K, f * r.B},
                                           p.position_resolution, to_hapticopt_estimator(p.velocity, p.period));
            if (!(sigma <= *p.force_noise_budget)) {
                out.error = "the optimum derated to " + short_number(f) +
                            " x to be stable over the plant set has force noise " + short_number(sigma) +
                            " N above force_noise_budget = " + short_number(*p.force_noise_budget) +
                            " N; accepted: explicit gains";
                return out;
            }
        }
        // Free mass: the normalised gains (alpha, beta) in the K, B fields.
        out.gains = free_mass_plant_ ? CriterionGains{f * r.alpha, f * r.beta} : CriterionGains{f * r.K, f * r.B};
    } catch (const std::exception& e) {
        out.error = e.what();
    }
    return out;
}

CriterionGains GainChecker::criterion_gains(hapticopt::Criterion criterion, double m) {
    const double T = plant_.period;
    const auto key = cache_key(criterion, m);
    std::optional<CachedCriterion> found;
    {
        std::lock_guard<std::mutex> lock(cache_mutex_);
        if (auto it = cache_.find(key); it != cache_.end()) found = it->second;
    }
    if (!found) {
        CachedCriterion tuned = tune_criterion(criterion, m);
        std::lock_guard<std::mutex> lock(cache_mutex_);
        found = cache_.emplace(key, std::move(tuned)).first->second;
    }
    if (!found->error.empty()) throw std::invalid_argument(found->error);
    if (!free_mass_plant_) return found->gains;
    return CriterionGains{found->gains.K * m / (T * T), found->gains.B * m / T};
}

bool GainChecker::criterion_ready(hapticopt::Criterion criterion) const {
    std::lock_guard<std::mutex> lock(cache_mutex_);
    return cache_.count(cache_key(criterion, plant_.mass)) != 0;
}

void GainChecker::prepare_criterion(hapticopt::Criterion criterion) noexcept {
    try {
        (void)criterion_gains(criterion, plant_.mass);
    } catch (...) {  // the error is cached: criterion_gains throws it to the request that asks
    }
}

}  // namespace hapticd
