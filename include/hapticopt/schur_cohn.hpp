// SPDX-License-Identifier: Apache-2.0
// Schur stability of a real polynomial by the Schur-Cohn (Jury) recursion.
//
// For p(z) = sum_i a_i z^i of degree n with a_n != 0, let k = a_0 / a_n (reflection coefficient)
// and r(z) = (p(z) - k z^n p(1/z)) / z, of degree n - 1. Schur-Cohn theorem: all roots of p lie
// strictly inside the unit circle iff |k| < 1 and all roots of r do (E. I. Jury, "Theory and
// Application of the z-Transform Method", 1964; the same recursion as Levinson-Durbin).
// In exact arithmetic the verdict is exact for the given coefficients; in floating point the k_i carry
// rounding, so a verdict can be wrong only where some |k_i| is within rounding of 1. `margin` =
// min_i (1 - |k_i|) (or the failing 1 - |k_i| <= 0 when unstable) is zero exactly on the boundary (a
// root on the unit circle), so it measures how far from a decision change the test was; loop_verdict
// (loop_schur_form.hpp) uses it to recompute near-boundary verdicts in long double.
// Cost: n^2 flops.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>

namespace hapticopt {

template <typename Scalar>
struct SchurCohnResult {
    bool stable = false;  ///< every root strictly inside the unit circle
    Scalar margin = 0;    ///< min (1 - |k_i|) over the recursion; <= 0 when unstable
};

/// `coefficients` ascending (a_0 first); the leading one must be non-zero.
template <typename Scalar>
SchurCohnResult<Scalar> schur_cohn(Eigen::Matrix<Scalar, Eigen::Dynamic, 1> a) {
    using std::abs;
    SchurCohnResult<Scalar> result;
    result.margin = Scalar(1);
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1> r(a.size());  // the next polynomial, one buffer for every step
    for (Eigen::Index n = a.size() - 1; n > 0; --n) {
        const Scalar lead = a(n);
        if (!(std::isfinite(static_cast<double>(lead))) || lead == Scalar(0)) {
            result.margin = Scalar(0);
            return result;  // degenerate: not provably stable
        }
        a.head(n + 1) /= lead;
        const Scalar k = a(0);
        const Scalar m = Scalar(1) - abs(k);
        if (!(m > Scalar(0))) {  // also catches NaN
            result.margin = m == m ? m : Scalar(0);
            return result;
        }
        if (m < result.margin) result.margin = m;
        for (Eigen::Index i = 0; i < n; ++i) r(i) = a(i + 1) - k * a(n - 1 - i);
        a.head(n) = r.head(n);
    }
    result.stable = true;
    return result;
}

}  // namespace hapticopt
