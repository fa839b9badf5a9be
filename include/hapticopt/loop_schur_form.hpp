// SPDX-License-Identifier: Apache-2.0
// The complex Schur form of the loop transition M = U T U^H (Eigen::ComplexSchur: Hessenberg
// reduction + shifted QR, ~25 N^3 flops), plus the stability verdict (Schur-Cohn) that gates the
// closed forms. The Schur form gives the spectral radius of StabilityReport and the complex-Schur
// cross-check detail::energy_costs_complex_schur; the energy costs and the overshoot bound themselves use
// the cheaper shift-structured Stein solver (stein_equation.hpp).
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <type_traits>

#include "characteristic_polynomial.hpp"
#include "closed_loop.hpp"
#include "schur_cohn.hpp"
#include "stein_equation.hpp"

namespace hapticopt {

template <typename Scalar>
struct LoopSchurForm {
    ComplexMatrix<Scalar> t;  ///< upper triangular, eigenvalues of M on the diagonal
    ComplexMatrix<Scalar> u;  ///< unitary
    Scalar spectral_radius = 0;
};

template <typename Scalar>
LoopSchurForm<Scalar> loop_schur_form(const DynamicMatrix<Scalar>& m) {
    Eigen::ComplexSchur<DynamicMatrix<Scalar>> schur(m);
    LoopSchurForm<Scalar> form;
    form.t = schur.matrixT();
    form.u = schur.matrixU();
    form.spectral_radius = form.t.diagonal().cwiseAbs().maxCoeff();
    return form;
}

/// The Schur-Cohn verdict on p(z) (characteristic_polynomial.hpp), refined near the boundary.
///
/// The recursion runs on rounded coefficients and rounds itself, so its verdict can be wrong only where
/// some reflection coefficient has |k_i| within rounding of 1, i.e. where |margin| is small. Whenever
/// |margin| < kStabilityRefinementMargin (1e-4) in double precision, the plant, the polynomial and the
/// recursion are recomputed in long double (64-bit significand on x86-64, 2^11 times finer than double)
/// and that verdict is returned, with `refined` set. Where long double is no wider than double (MSVC)
/// nothing is recomputed. Cost: n^2 flops for degree n; a refinement adds the long double plant
/// transitions (plant_transitions: one or two 3x3 matrix exponentials, no Gramians) and happens only
/// where the margin is that small (22 % of the stress
/// test's sets, which crowd the boundary; none of the optimisers' timings changed measurably).
/// The stress test (tests/stress) checks the trigger: wherever the plain double and the long double
/// verdicts differ, |margin| in double must be at most 1e-6, 100x inside the trigger (measured over
/// 10^6 sets: at most 8.8e-14).
inline constexpr double kStabilityRefinementMargin = 1e-4;

template <typename Scalar>
struct LoopVerdict {
    bool stable = false;   ///< alpha + gamma > 0 and every root of p strictly inside the unit circle
    Scalar margin = 0;     ///< Schur-Cohn margin of the deciding computation (schur_cohn.hpp)
    bool refined = false;  ///< decided in long double because |margin| in Scalar was below the trigger
};

template <typename Scalar>
LoopVerdict<Scalar> loop_verdict(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    LoopVerdict<Scalar> verdict;
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return verdict;
    const SchurCohnResult<Scalar> test = schur_cohn<Scalar>(characteristic_polynomial(plant).at(alpha, beta));
    verdict.stable = test.stable;
    verdict.margin = test.margin;
    if constexpr (std::is_same_v<Scalar, double> &&
                  std::numeric_limits<long double>::digits > std::numeric_limits<double>::digits) {
        using std::abs;
        if (abs(test.margin) < kStabilityRefinementMargin) {
            using LD = long double;
            const PlantTransitions<LD> fine = plant_transitions<LD>(plant.parameters());
            const SchurCohnResult<LD> refined = schur_cohn<LD>(characteristic_polynomial(fine).at(LD(alpha), LD(beta)));
            verdict.stable = refined.stable && LD(alpha) + LD(plant.parameters().gamma) > LD(0);
            verdict.margin = static_cast<Scalar>(refined.margin);
            verdict.refined = true;
        }
    }
    return verdict;
}

/// Stable iff alpha + gamma > 0 and the (refined) Schur-Cohn test passes on p(z): loop_verdict().
/// The closed forms additionally require every computed eigenvalue of M to have modulus < 1 (checked
/// by their callers), which guards against a rounding disagreement right at the boundary.
template <typename Scalar>
bool loop_is_stable(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    return loop_verdict(plant, alpha, beta).stable;
}

}  // namespace hapticopt
