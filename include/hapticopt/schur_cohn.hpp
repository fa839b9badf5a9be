// SPDX-License-Identifier: Apache-2.0
// Schur stability of a real polynomial by the Schur-Cohn (Jury) recursion.
//
// For p(z) = sum_i a_i z^i of degree n with a_n != 0, let k = a_0 / a_n (reflection coefficient)
// and r(z) = (p(z) - k z^n p(1/z)) / z, of degree n - 1. Schur-Cohn theorem: all roots of p lie
// strictly inside the unit circle iff |k| < 1 and all roots of r do (E. I. Jury, "Theory and
// Application of the z-Transform Method", 1964; the same recursion as Levinson-Durbin).
// In exact arithmetic the verdict is exact for the given coefficients; in floating point the k_i carry
// rounding, so a verdict can be wrong only where some |k_i| is within rounding of 1. `margin` is
// min_i (1 - |k_i|) over the steps when stable; when a step fails it is -min(|1 - |k_f||, min_{i<f} (1 - |k_i|)),
// because after a step with |k_i| within rounding of 1 the next polynomial is rounding and the failing k_f can lie
// anywhere. It is zero exactly on the boundary (a root on the unit circle), so |margin| measures how far from a
// decision change the test was; loop_verdict (loop_schur_form.hpp) uses it to recompute near-boundary verdicts in
// long double.
// Cost: n^2 flops and n divisions.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

namespace hapticopt {

/// Polynomials up to this many coefficients are reduced without a heap allocation.
inline constexpr std::size_t kSchurCohnStackCoefficients = 64;

template <typename Scalar>
struct SchurCohnResult {
    bool stable = false;  ///< every root strictly inside the unit circle
    Scalar margin = 0;    ///< min (1 - |k_i|) over the recursion; <= 0 when unstable
};

/// `coefficients` ascending (a_0 first); the leading one must be non-zero. Each step scales by the reciprocal of
/// its leading coefficient (one division per step) and writes the next polynomial into the other of two buffers,
/// kept on the stack up to kSchurCohnStackCoefficients coefficients.
template <typename Scalar>
SchurCohnResult<Scalar> schur_cohn(Eigen::Matrix<Scalar, Eigen::Dynamic, 1> a) {
    using std::abs;
    SchurCohnResult<Scalar> result;
    result.margin = Scalar(1);
    std::array<Scalar, kSchurCohnStackCoefficients> stack;
    std::vector<Scalar> heap;
    Scalar* next = stack.data();
    if (a.size() > static_cast<Eigen::Index>(stack.size())) {
        heap.resize(static_cast<std::size_t>(a.size()));
        next = heap.data();
    }
    Scalar* current = a.data();
    for (Eigen::Index n = a.size() - 1; n > 0; --n) {
        const Scalar lead = current[n];
        if (!(std::isfinite(static_cast<double>(lead))) || lead == Scalar(0)) {
            result.margin = Scalar(0);
            return result;  // degenerate: not provably stable
        }
        const Scalar scale = Scalar(1) / lead;
        const Scalar k = current[0] * scale;
        const Scalar m = Scalar(1) - abs(k);
        if (!(m > Scalar(0))) {  // also catches NaN
            // After a step within rounding of the circle (a small margin so far) this k is rounding, whatever
            // its size: the margin is the nearer of the two distances, negative.
            const Scalar failing = m == m ? m : Scalar(0);
            result.margin = n + 1 == a.size() ? failing : std::max(failing, -result.margin);
            return result;
        }
        if (m < result.margin) result.margin = m;
        for (Eigen::Index i = 0; i < n; ++i) next[i] = (current[i + 1] - k * current[n - 1 - i]) * scale;
        std::swap(current, next);
    }
    result.stable = true;
    return result;
}

}  // namespace hapticopt
