// SPDX-License-Identifier: Apache-2.0
// The closed loop of Fig. 2 for given wall gains: the exact one-period transition of the loop
// state and the unit-step initial condition, in deviation coordinates.
//
// Wall force (backward difference): f_j = alpha x_j + beta (x_j - x_{j-1}). Step input F = 1 at
// t = 0 from rest (x = 0, no earlier forces); final position x_inf = 1 / (alpha + gamma).
// Loop state e_j = (x_j - x_inf, x'_j, x_{j-1} - x_inf, ..., x_{j-H} - x_inf), e_{j+1} = M e_j,
// e_0 = -x_inf (1, 0, 1, ..., 1). On segment s of period j the augmented state is xi = R_s e_j.
// Only the first two rows of M are dense; the others shift the position history. The compact form
// keeps just those two rows (fixed-capacity storage, no heap allocation); the hot paths use it.
#pragma once

#include <Eigen/Core>
#include <array>

#include "sampled_plant.hpp"

namespace hapticopt {

template <typename Scalar>
using DynamicMatrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
template <typename Scalar>
using DynamicVector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

/// Storage of at most MaxN entries per dimension (Eigen::Dynamic: heap storage, any size); the
/// fast paths use MaxN = kStackStateDimension so that one evaluation allocates nothing.
inline constexpr int kStackStateDimension = 16;  // d <= 13

/// The loop in compact form: M is the 2 x N block of its first two rows (x_{j+1}, x'_{j+1})
/// followed by the shift rows x_{j-i} <- x_{j-i+1}, which are implicit (shift_source below).
template <typename Scalar, int MaxN = Eigen::Dynamic>
struct CompactClosedLoop {
    Scalar alpha = 0;
    Scalar beta = 0;
    Scalar total_stiffness = 0;
    Scalar final_position = 0;
    int state_dimension = 0;
    Eigen::Matrix<Scalar, 2, Eigen::Dynamic, 0, 2, MaxN> top;                         ///< rows 0, 1 of M
    std::array<Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, MaxN>, 2> segment_map;  ///< R_s
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1, 0, MaxN, 1> initial_state;               ///< e_0
};

/// Row k >= 2 of M is the unit row e_{shift_source(k)}^T (x_{j-i} at step j+1 is x_{j-i+1}).
inline int shift_source(int k) { return k == 2 ? 0 : k - 1; }

/// Builds the compact loop. Cost O(N). Requires alpha + gamma != 0.
template <typename Scalar, int MaxN = Eigen::Dynamic>
CompactClosedLoop<Scalar, MaxN> make_compact_closed_loop(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    const int n = plant.state_dimension();
    CompactClosedLoop<Scalar, MaxN> loop;
    loop.alpha = alpha;
    loop.beta = beta;
    loop.state_dimension = n;
    loop.total_stiffness = alpha + Scalar(plant.parameters().gamma);
    loop.final_position = Scalar(1) / loop.total_stiffness;
    using Rows = Eigen::Matrix<Scalar, 2, Eigen::Dynamic, 0, 2, MaxN>;
    Rows rows = Rows::Zero(2, n);  // (x, x') at segment start
    rows(0, 0) = 1;
    rows(1, 1) = 1;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        auto& r = loop.segment_map[static_cast<std::size_t>(s)];
        r.setZero(3, n);
        r.template topRows<2>() = rows;
        // Deviation force u = f_{j-age} - f_inf as a function of e_j.
        r(2, SampledPlant<Scalar>::position_index(seg.force_age)) += alpha + beta;
        r(2, SampledPlant<Scalar>::position_index(seg.force_age + 1)) -= beta;
        for (int l = 0; l < n; ++l) {  // (x, x') at segment end: rows 0, 1 of exp(A h) times R_s
            for (int i = 0; i < 2; ++i)
                rows(i, l) = seg.exp(i, 0) * r(0, l) + seg.exp(i, 1) * r(1, l) + seg.exp(i, 2) * r(2, l);
        }
    }
    loop.top = rows;
    loop.initial_state.setConstant(n, -loop.final_position);
    loop.initial_state(1) = 0;
    return loop;
}

template <typename Scalar>
struct ClosedLoop {
    Scalar alpha = 0;
    Scalar beta = 0;
    Scalar total_stiffness = 0;                        ///< alpha + gamma (must be > 0 for a final position to exist)
    Scalar final_position = 0;                         ///< x_inf = 1 / (alpha + gamma)
    DynamicMatrix<Scalar> transition;                  ///< M, N x N
    DynamicVector<Scalar> initial_state;               ///< e_0
    std::array<DynamicMatrix<Scalar>, 2> segment_map;  ///< R_s, 3 x N
};

/// Builds M, e_0 and R_s. Cost O(N^2). Requires alpha + gamma != 0 (callers check stability,
/// which implies alpha + gamma > 0).
template <typename Scalar>
ClosedLoop<Scalar> make_closed_loop(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    const CompactClosedLoop<Scalar> compact = make_compact_closed_loop<Scalar>(plant, alpha, beta);
    const int n = compact.state_dimension;
    ClosedLoop<Scalar> loop;
    loop.alpha = alpha;
    loop.beta = beta;
    loop.total_stiffness = compact.total_stiffness;
    loop.final_position = compact.final_position;
    for (int s = 0; s < plant.segment_count(); ++s) {
        loop.segment_map[static_cast<std::size_t>(s)] = compact.segment_map[static_cast<std::size_t>(s)];
    }
    DynamicMatrix<Scalar>& m = loop.transition;
    m = DynamicMatrix<Scalar>::Zero(n, n);
    m.topRows(2) = compact.top;
    for (int k = 2; k < n; ++k) m(k, shift_source(k)) = 1;
    loop.initial_state = compact.initial_state;
    return loop;
}

}  // namespace hapticopt
