// SPDX-License-Identifier: Apache-2.0
// The rendered loop as one mode of a switched system: the wall's gains and the plant's mass may change between two
// ticks, and the state must mean the same physical thing before and after.
//
// The loop state of estimator_loop.hpp recomputes the forces still in the delay line from past positions with the
// current gains, which is exact for fixed gains but not across a change of gains: the forces already sent were
// computed with the old ones. Here the forces in flight are states. Time is normalised by T (x' = T dx/dt), positions
// are lengths, and a force F is stored as w = F T^2 / m_ref for a fixed reference mass m_ref, so that no coordinate
// depends on the gains or on the mass. State at tick j (before the sample y_j = x_j):
//
//   s_j = (x_j, x'_j, y_{j-1}, ..., y_{j-Hy}, v_{j-1}, ..., v_{j-Hv}, w_{j-1}, ..., w_{j-A})
//
// with v the estimator's velocity (states for the low-pass only: Hv = max(1, na); FIR estimators Hv = 0),
// Hy = max(1, nb - 1), and A the age of the oldest force acting in a period (plant.segment(0).force_age: n for a
// whole delay d = n, n + 1 for a fractional one). The wall force computed at tick j is
//
//   w_j = a_ref y_j + b_ref v_j,   a_ref = K T^2 / m_ref,  b_ref = B T / m_ref,
//
// and on segment s of the period the force w_{j - a_s} acts on the mass m = m_ref / r: the plant of
// sampled_plant.hpp (normalised by m, with gamma = k T^2 / m, delta = b T / m) sees u = r w. The transition is
// linear, s_{j+1} = A(K, B, m) s_j, and a switch of gains or mass at tick j is exactly a change of the matrix used
// from tick j on. The wall's equilibrium is the origin (x = 0 at the wall's surface, no external force): the loop
// in contact, the hand's force held off. Its nonzero eigenvalues are those of estimator_loop.hpp's M for the
// normalised gains (r a_ref, r b_ref) (the extra states are the delay line, determined by the others after A ticks);
// tests/beyond/test_switching_dwell.cpp compares the spectral radii.
// Not for the real-time loop (allocates).
#pragma once

#include <algorithm>
#include <cstddef>

#include "closed_loop.hpp"
#include "config.hpp"
#include "errors.hpp"
#include "estimator_types.hpp"
#include "sampled_plant.hpp"

namespace hapticopt {

/// The mode's transition A(K, B, m) of the header comment for the plant `plant` (normalised by the mode's mass),
/// gains (a_ref, b_ref) normalised by the reference mass and mass_ratio r = m_ref / m. Throws InvalidParameter for a
/// non-finite gain or a ratio that is not finite and > 0. Cost O(N^2), N = 2 + Hy + Hv + A.
HAPTICOPT_DEFERRED inline DynamicMatrix<double> make_switching_loop(const SampledPlant<double>& plant,
                                                                    const VelocityEstimator& estimator, double a_ref,
                                                                    double b_ref, double mass_ratio) {
    constexpr const char* kFunction = "hapticopt::make_switching_loop";
    detail::require_finite(kFunction, "a_ref", a_ref);
    detail::require_finite(kFunction, "b_ref", b_ref);
    detail::require_positive(kFunction, "mass_ratio", mass_ratio);
    validate(estimator, kFunction);
    const EstimatorCoefficients<double> co = estimator_coefficients<double>(estimator);
    const int nb = static_cast<int>(co.b.size());
    const int na = static_cast<int>(co.a.size());
    const int hy = std::max(1, nb - 1);
    const int hv = na == 0 ? 0 : std::max(1, na);
    const int ages = plant.segment(0).force_age;
    const int n = 2 + hy + hv + ages;
    const int v0 = 2 + hy;       // index of v_{j-1}
    const int f0 = 2 + hy + hv;  // index of w_{j-1}
    using Row = DynamicVector<double>;
    auto unit = [n](int i) {
        Row v = Row::Zero(n);
        v(i) = 1.0;
        return v;
    };
    auto measured = [&](int i) { return unit(i == 0 ? 0 : 1 + i); };  // y_{j-i}
    Row velocity = Row::Zero(n);                                      // v_j
    for (int i = 0; i < nb; ++i) velocity += co.b[static_cast<std::size_t>(i)] * measured(i);
    for (int k = 1; k <= na; ++k) velocity(v0 + k - 1) += co.a[static_cast<std::size_t>(k - 1)];
    const Row force_now = a_ref * measured(0) + b_ref * velocity;  // w_j
    auto force = [&](int age) { return age == 0 ? force_now : unit(f0 + age - 1); };
    DynamicMatrix<double> rows = DynamicMatrix<double>::Zero(2, n);
    rows(0, 0) = 1.0;
    rows(1, 1) = 1.0;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        const Row u = mass_ratio * force(seg.force_age);
        DynamicMatrix<double> next(2, n);
        for (int i = 0; i < 2; ++i) {
            next.row(i) = seg.exp(i, 0) * rows.row(0) + seg.exp(i, 1) * rows.row(1) + seg.exp(i, 2) * u.transpose();
        }
        rows = next;
    }
    DynamicMatrix<double> m = DynamicMatrix<double>::Zero(n, n);
    m.topRows(2) = rows;
    m.row(2) = measured(0).transpose();             // y_j becomes y_{(j+1)-1}
    for (int i = 2; i <= hy; ++i) m(1 + i, i) = 1;  // y_{j-i+1} becomes y_{(j+1)-i}
    if (hv > 0) {
        m.row(v0) = velocity.transpose();
        for (int k = 2; k <= hv; ++k) m(v0 + k - 1, v0 + k - 2) = 1;
    }
    if (ages > 0) {
        m.row(f0) = force_now.transpose();
        for (int a = 2; a <= ages; ++a) m(f0 + a - 1, f0 + a - 2) = 1;
    }
    return m;
}

}  // namespace hapticopt
