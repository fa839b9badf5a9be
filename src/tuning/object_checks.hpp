// The checks of the clients' scene objects against hapticopt's exact stability region (docs/protocol.md,
// section 5). Runs in the server thread (never in the loop).
//
//  * One object: the pair (K, B) with alpha = K T^2 / m, beta = B T / m, for the plant (m, b, k) of the
//    device profile (isotropic: the profile gives one mass for every axis, so m = n^T M n = m for any unit n)
//    and the total delay d = (device + buffer) / T, is stable iff the characteristic polynomial of the
//    exact sampled-data loop has all roots inside the unit circle (hapticopt::is_stable, Schur-Cohn).
//    The largest stable K at that B: bisection in alpha on is_stable between a stable alpha and
//    alpha_max (beyond which nothing is stable), 60 halvings (relative width 2^-60 of alpha_max).
//  * By criterion: hapticopt::optimal_wall for the criterion, computed once per criterion and cached.
//  * The sum: with K_sum = sum K_i P_i and B_sum = sum B_i P_i (3x3, symmetric), the coupled loop's exact
//    verdict hapticopt::matrix_gain_stability (its matrix characteristic polynomial P0 I + Palpha A + Pbeta B
//    restricted to the directions where a wall acts: per common eigenvector when K_sum and B_sum commute,
//    block-companion eigenvalues with a 1e-6 margin to the unit circle otherwise). The refusal names the
//    first eigen-direction whose pair alone is unstable, or the coupled spectral radius.
//    Cost: 3x3 eigen-decompositions and at most 3 Schur-Cohn tests, or one ~3(d+3)-square eigenproblem.
#pragma once

#include <array>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "tuning/tuning.hpp"

namespace hapticd {

using Matrix3 = std::array<std::array<double, 3>, 3>;

// The plant the objects are checked for: the profile's mass, damping and stiffness, the period, the total delay.
using GainCheckPlant = TuningPlant;

struct PairVerdict {
    bool stable = false;
    double alpha = 0.0, beta = 0.0;
    double alpha_max = 0.0;         // largest stable alpha of the plant (any beta)
    double largest_stable_K = 0.0;  // N/m at this B (0: none)
};

struct CriterionGains {
    double K = 0.0, B = 0.0;
};

class GainChecker {
public:
    explicit GainChecker(const GainCheckPlant& plant);

    [[nodiscard]] const GainCheckPlant& plant() const noexcept { return plant_; }

    // Stability of one (K, B) (N/m, N s/m, finite): one Schur-Cohn verdict (what a commit needs).
    [[nodiscard]] bool pair_is_stable(double K, double B) const;

    // Stability of one (K, B) and the largest stable K at that B (61 verdicts: for a refusal's message).
    [[nodiscard]] PairVerdict check_pair(double K, double B) const;

    // The optimum of a criterion (CE0 .. CE2+OV): computed on first use, then cached. std::nullopt for
    // an unknown name.
    std::optional<CriterionGains> criterion_gains(const std::string& criterion);

    // A field's Jacobian J: the stiffness it renders is S = -sym(J); returns the extreme eigenvalues of S
    // and the spectral norm of J (for the force bound ||F0|| + ||J|| radius).
    struct FieldStiffness {
        double min_stiffness = 0.0, max_stiffness = 0.0, jacobian_norm = 0.0;
    };
    [[nodiscard]] static FieldStiffness field_stiffness(const Matrix3& J);

    // The summed-gain check above. On failure `why` names the direction and the pair, or the coupled radius.
    [[nodiscard]] bool sum_is_stable(const Matrix3& K_sum, const Matrix3& B_sum, std::string& why) const;

private:
    GainCheckPlant plant_;
    double alpha_max_ = 0.0;
    std::mutex cache_mutex_;
    std::map<std::string, CriterionGains> cache_;
};

}  // namespace hapticd
