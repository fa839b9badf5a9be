// SPDX-License-Identifier: Apache-2.0
// The closed loop of the wall with its velocity estimator (velocity_estimator.hpp) in the exact model
// (normalised units m = T = 1): the loop matrix M, the segment maps R_s, the step's initial state and the
// commanded force's form.
//
// Loop state (deviations from the final values): s_j = (x_j - x_inf, x'_j, y_{j-1} - x_inf, ...,
// y_{j-Hy} - x_inf, v_{j-1}, ..., v_{j-Hv} [, e_j]). The positions are the plant's (SampledPlant,
// exact per period and per delay segment); the force acting on segment s is f_{j-a_s}. For an FIR estimator
// (na = 0) v_{j-a} is written out in the y's (Hv = 0, Hy = max(1, a_max + nb - 1)); for the low-pass the
// v's are states (Hv = max(1, a_max), Hy = max(1, a_max, nb - 1)). For the backward difference this is
// exactly the state of closed_loop.hpp. Step response from rest: s_0 = -x_inf on the position entries,
// 0 on x', the v's and e. e_j, the measured position's rounding error, is the state of estimator_noise.hpp;
// nb and na are the estimator's coefficient counts (velocity_estimator.hpp: EstimatorCoefficients).
#pragma once

#include <algorithm>
#include <cstddef>

#include "closed_loop.hpp"
#include "sampled_plant.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// The closed loop with the estimator (header comment): M, s_0, R_s as in ClosedLoop, plus the force's form.
template <typename Scalar>
struct EstimatorLoop {
    ClosedLoop<Scalar> loop;
    DynamicVector<Scalar> force;  ///< c: f_j - f_inf = c^T s_j
    int noise_index = -1;         ///< index of e_j in s_j, -1 without the noise state
};

/// Builds the loop of the header comment. Cost O(N^2). Requires alpha + gamma != 0 unless `derivative`.
/// M and R_s are affine in (alpha, beta); with `derivative` = true the constant part is left out, so that
/// (alpha, beta) = (da, db) gives their derivative along that direction (initial state, force and final position
/// are then not meaningful).
template <typename Scalar>
EstimatorLoop<Scalar> make_estimator_loop(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                          Scalar alpha, Scalar beta, bool with_noise, bool derivative = false) {
    const EstimatorCoefficients<Scalar> co = estimator_coefficients<Scalar>(estimator);
    const int nb = static_cast<int>(co.b.size());
    const int na = static_cast<int>(co.a.size());
    const int age_max = plant.segment(0).force_age;  // segment 0 carries the older force
    const bool fir = na == 0;
    const int hy = fir ? std::max(1, age_max + nb - 1) : std::max({1, age_max, nb - 1});
    const int hv = fir ? 0 : std::max({1, age_max, na});
    const int n = 2 + hy + hv + (with_noise ? 1 : 0);
    using Vec = DynamicVector<Scalar>;
    auto unit = [n](int i) {
        Vec v = Vec::Zero(n);
        v(i) = Scalar(1);
        return v;
    };
    const int noise = with_noise ? n - 1 : -1;
    auto measured = [&](int i) {  // y_{j-i} - x_inf
        if (i == 0) {
            Vec v = unit(0);
            if (noise >= 0) v(noise) = Scalar(1);
            return v;
        }
        return unit(1 + i);
    };
    auto v_slot = [&](int k) { return 1 + hy + k; };  // index of v_{j-k}, k >= 1
    auto velocity = [&](int age) {                    // v_{j-age}
        Vec v = Vec::Zero(n);
        if (fir || age == 0) {
            for (int i = 0; i < nb; ++i) v += co.b[static_cast<std::size_t>(i)] * measured(age + i);
            if (!fir) {
                for (int k = 1; k <= na; ++k) v(v_slot(k)) += co.a[static_cast<std::size_t>(k - 1)];
            }
        } else {
            v(v_slot(age)) = Scalar(1);
        }
        return v;
    };
    EstimatorLoop<Scalar> out;
    out.noise_index = noise;
    out.force = alpha * measured(0) + beta * velocity(0);
    ClosedLoop<Scalar>& loop = out.loop;
    loop.alpha = alpha;
    loop.beta = beta;
    loop.total_stiffness = alpha + Scalar(plant.parameters().gamma);
    loop.final_position = Scalar(1) / loop.total_stiffness;
    DynamicMatrix<Scalar> rows = DynamicMatrix<Scalar>::Zero(2, n);
    if (!derivative) {
        rows(0, 0) = 1;
        rows(1, 1) = 1;
    }
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        DynamicMatrix<Scalar>& r = loop.segment_map[static_cast<std::size_t>(s)];
        r = DynamicMatrix<Scalar>::Zero(3, n);
        r.topRows(2) = rows;
        r.row(2) = (alpha * measured(seg.force_age) + beta * velocity(seg.force_age)).transpose();
        DynamicMatrix<Scalar> next(2, n);
        for (int i = 0; i < 2; ++i) {
            next.row(i) = seg.exp(i, 0) * r.row(0) + seg.exp(i, 1) * r.row(1) + seg.exp(i, 2) * r.row(2);
        }
        rows = next;
    }
    DynamicMatrix<Scalar>& m = loop.transition;
    m = DynamicMatrix<Scalar>::Zero(n, n);
    m.topRows(2) = rows;
    if (derivative) return out;
    m.row(2) = measured(0).transpose();             // y_j becomes y_{(j+1)-1}
    for (int i = 2; i <= hy; ++i) m(1 + i, i) = 1;  // y_{j-i+1} becomes y_{(j+1)-i}
    if (hv > 0) {
        m.row(v_slot(1)) = velocity(0).transpose();  // v_j becomes v_{(j+1)-1}
        for (int k = 2; k <= hv; ++k) m(v_slot(k), v_slot(k - 1)) = 1;
    }
    loop.initial_state = Vec::Zero(n);
    loop.initial_state(0) = -loop.final_position;
    for (int i = 1; i <= hy; ++i) loop.initial_state(1 + i) = -loop.final_position;
    return out;
}

}  // namespace hapticopt
