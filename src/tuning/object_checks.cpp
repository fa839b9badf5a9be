#include "tuning/object_checks.hpp"

#include <cmath>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <hapticopt/hapticopt.hpp>

#include "tuning/tuning.hpp"

namespace hapticd {


GainChecker::GainChecker(const GainCheckPlant& plant) : plant_(plant) {
    alpha_max_ = hapticopt::StabilityRegion(hapticopt::normalize(to_hapticopt(plant_))).alpha_max();
}

bool GainChecker::pair_is_stable(double K, double B) const {
    const double T = plant_.period, m = plant_.mass;
    return hapticopt::is_stable(hapticopt::normalize(to_hapticopt(plant_)),
                                hapticopt::NormalizedGains{K * T * T / m, B * T / m});
}

PairVerdict GainChecker::check_pair(double K, double B) const {
    const hapticopt::NormalizedPlant np = hapticopt::normalize(to_hapticopt(plant_));
    PairVerdict v;
    const double T = plant_.period, m = plant_.mass;
    v.alpha = K * T * T / m;
    v.beta = B * T / m;
    v.alpha_max = alpha_max_;
    v.stable = hapticopt::is_stable(np, hapticopt::NormalizedGains{v.alpha, v.beta});
    // Largest stable alpha at this beta: bisection on is_stable over (0, alpha_max].
    double lo = v.stable && v.alpha > 0.0 ? v.alpha : alpha_max_ * 1e-9;
    if (!hapticopt::is_stable(np, hapticopt::NormalizedGains{lo, v.beta})) {
        v.largest_stable_K = 0.0;
        return v;
    }
    double hi = alpha_max_ * (1.0 + 1e-9);
    if (hapticopt::is_stable(np, hapticopt::NormalizedGains{hi, v.beta})) {
        lo = hi;  // cannot happen (alpha_max is the tip of the region); kept as a safe answer
    } else {
        for (int i = 0; i < 60; ++i) {
            const double mid = 0.5 * (lo + hi);
            if (hapticopt::is_stable(np, hapticopt::NormalizedGains{mid, v.beta})) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
    v.largest_stable_K = lo * m / (T * T);
    return v;
}

std::optional<CriterionGains> GainChecker::criterion_gains(const std::string& criterion) {
    if (!is_accepted_criterion(criterion)) return std::nullopt;
    std::lock_guard<std::mutex> lock(cache_mutex_);
    const auto it = cache_.find(criterion);
    if (it != cache_.end()) return it->second;
    const TuningResult r = tune_wall(criterion, plant_);
    const CriterionGains g{r.K, r.B};
    cache_.emplace(criterion, g);
    return g;
}

GainChecker::FieldStiffness GainChecker::field_stiffness(const Matrix3& J) {
    Eigen::Matrix3d m, s;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m(i, j) = J[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    }
    s = -0.5 * (m + m.transpose());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(s, Eigen::EigenvaluesOnly);
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m);
    FieldStiffness f;
    f.min_stiffness = es.eigenvalues().minCoeff();
    f.max_stiffness = es.eigenvalues().maxCoeff();
    f.jacobian_norm = svd.singularValues()(0);
    return f;
}

bool GainChecker::sum_is_stable(const Matrix3& K_sum, const Matrix3& B_sum, std::string& why) const {
    Eigen::Matrix3d K, B;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            K(i, j) = 0.5 * (K_sum[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] +
                             K_sum[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)]);
            B(i, j) = 0.5 * (B_sum[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] +
                             B_sum[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)]);
        }
    }
    if (K.isZero(0.0) && B.isZero(0.0)) return true;
    // The decision: the coupled loop's exact verdict (hapticopt::matrix_gain_stability).
    const double T = plant_.period, m = plant_.mass;
    const hapticopt::MatrixGainStability coupled = hapticopt::matrix_gain_stability(
        hapticopt::normalize(to_hapticopt(plant_)), Eigen::MatrixXd(K * (T * T / m)), Eigen::MatrixXd(B * (T / m)));
    if (coupled.stable) return true;
    // The explanation: a direction along which the pair alone is already unstable, if there is one.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ek(K), eb(B);
    for (const auto* solver : {&ek, &eb}) {
        for (int c = 0; c < 3; ++c) {
            const Eigen::Vector3d u = solver->eigenvectors().col(c);
            const double k = u.dot(K * u), b = u.dot(B * u);
            if (k <= 1e-12 * (1.0 + K.norm()) && b <= 1e-12 * (1.0 + B.norm())) continue;  // nothing acts along u
            const PairVerdict v = check_pair(k, b);
            if (v.stable) continue;
            std::ostringstream s;
            s.precision(6);
            s << "summed gains along u = (" << u(0) << ", " << u(1) << ", " << u(2) << "): K = " << k
              << " N/m, B = " << b << " N s/m (alpha = " << v.alpha << ", beta = " << v.beta
              << ") are outside the stability region; the largest stable K at that B is " << v.largest_stable_K
              << " N/m";
            why = s.str();
            return false;
        }
    }
    std::ostringstream s;
    s.precision(10);
    s << "summed gains: each direction is stable on its own, but the coupled loop of the non-commuting K_sum and "
         "B_sum has spectral radius "
      << coupled.spectral_radius << " (stable needs < 1 - " << hapticopt::kMatrixGainRadiusMargin << ")";
    why = s.str();
    return false;
}

}  // namespace hapticd
