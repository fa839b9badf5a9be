// SPDX-License-Identifier: Apache-2.0
// The plant of Fig. 2 sampled exactly, in normalised units (m = T = 1), for a real delay d >= 0.
//
// Plant (eq. 1 normalised): x'' + delta x' + gamma x = F - f(t). The wall force f_j, computed at
// t = j, acts during [j + d, j + 1 + d) (zero-order hold, then delay; Hulin et al. 2011, Sect. II). Within period
// [j, j + 1) the force acting is f_{j - n} for integer d = n; for d = n + phi, 0 < phi < 1, it is
// f_{j-n-1} on [j, j + phi) and f_{j-n} on [j + phi, j + 1): two segments, each discretised
// exactly. On a segment the augmented state xi = (x - x_inf, x', u), u the deviation of the
// acting wall force from its final value, obeys xi' = A xi with
//
//        [  0      1     0 ]
//   A =  [ -gamma -delta -1 ]
//        [  0      0     0 ]
//
// This header precomputes, once per (gamma, delta, d), exp(A h) and the Gramians Z_p(h) of each
// segment for the two energy terms; nothing here depends on the wall gains.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "exponential_integrals.hpp"
#include "parameters.hpp"

namespace hapticopt {

template <typename Scalar>
struct PlantSegment {
    Scalar start = 0;                                 ///< where the segment begins inside the period
    Scalar length = 1;                                ///< its length
    int force_age = 0;                                ///< the force acting is f_{j - force_age}
    Matrix3<Scalar> exp;                              ///< exp(A length)
    std::array<Matrix3<Scalar>, 3> position_gramian;  ///< Z_p with Q = e1 e1^T
    std::array<Matrix3<Scalar>, 3> velocity_gramian;  ///< Z_p with Q = e2 e2^T
    /// The segment cut into `pieces` equal pieces, each short enough that x' has at most one zero
    /// in it (omega h_piece <= 3 < pi for an oscillating plant) and that the Taylor series of the
    /// motion converges fast (||A||_1 h_piece <= 2). One piece for every realistic haptic plant.
    int pieces = 1;
    Matrix3<Scalar> piece_exp;  ///< exp(A length / pieces)
};

/// The augmented matrix A of the plant (header comment) in Scalar.
template <typename Scalar>
Matrix3<Scalar> plant_augmented_matrix(const NormalizedPlant& plant) {
    Matrix3<Scalar> a;
    a << 0, 1, 0, -Scalar(plant.gamma), -Scalar(plant.delta), -1, 0, 0, 0;
    return a;
}

/// The one-period transition of the plant alone: the segments of the period for d = n + phi (one
/// segment [0, 1) for phi = 0, else [0, phi) and [phi, 1)) and exp(A length) of each, by the same
/// series as SampledPlant (exponential_integrals.hpp). What the characteristic polynomial needs; the
/// stability refinement in long double computes only this. Expects a validated plant.
template <typename Scalar>
struct PlantTransitions {
    int whole_delay = 0;
    int segment_count = 1;
    std::array<Matrix3<Scalar>, 2> exp;  ///< exp(A length_s), s < segment_count
};

/// The transitions with exp(A length) taken from `exponential_of(length)` (e.g. free_mass_exponential where
/// gamma = 0); plant_transitions uses the series.
template <typename Scalar, typename Exponential>
PlantTransitions<Scalar> plant_transitions_with(const NormalizedPlant& plant, const Exponential& exponential_of) {
    PlantTransitions<Scalar> t;
    const double whole = std::floor(plant.delay);
    t.whole_delay = static_cast<int>(whole);
    const Scalar fraction = Scalar(plant.delay) - Scalar(whole);
    if (fraction == Scalar(0)) {
        t.exp[0] = exponential_of(Scalar(1));
    } else {
        t.segment_count = 2;
        t.exp[0] = exponential_of(fraction);
        t.exp[1] = exponential_of(Scalar(1) - fraction);
    }
    return t;
}

template <typename Scalar>
PlantTransitions<Scalar> plant_transitions(const NormalizedPlant& plant) {
    const Matrix3<Scalar> a = plant_augmented_matrix<Scalar>(plant);
    return plant_transitions_with<Scalar>(plant, [&a](Scalar length) { return exponential<Scalar>(a, length); });
}

template <typename Scalar>
class SampledPlant {
  public:
    /// Throws InvalidParameter for NaN, infinite or negative gamma, delta, d, and for d > 1000
    /// (the state dimension is ceil(d) + 3).
    explicit SampledPlant(const NormalizedPlant& plant) : parameters_(plant) {
        validate(plant, "hapticopt::SampledPlant");
        detail::require_in_range("hapticopt::SampledPlant", "delay", plant.delay, 0.0, false, 1e3,
                                 "0 <= d <= 1000 periods");
        const double whole = std::floor(plant.delay);
        whole_delay_ = static_cast<int>(whole);
        fraction_ = Scalar(plant.delay) - Scalar(whole);
        A_ = plant_augmented_matrix<Scalar>(plant);
        if (fraction_ == Scalar(0)) {
            segment_count_ = 1;
            segments_[0] = make_segment(Scalar(0), Scalar(1), whole_delay_);
        } else {
            segment_count_ = 2;
            segments_[0] = make_segment(Scalar(0), fraction_, whole_delay_ + 1);
            segments_[1] = make_segment(fraction_, Scalar(1) - fraction_, whole_delay_);
        }
        history_ = segments_[0].force_age + 1;  // oldest x needed: x_{j - force_age - 1}
    }

    const NormalizedPlant& parameters() const { return parameters_; }
    /// Integer part n and fractional part phi of the delay d.
    int whole_delay() const { return whole_delay_; }
    Scalar fraction() const { return fraction_; }
    /// Number of past positions x_{j-1}, ..., x_{j-H} in the loop state.
    int history_length() const { return history_; }
    /// N = 2 + H: (x_j, x'_j, x_{j-1}, ..., x_{j-H}).
    int state_dimension() const { return 2 + history_; }
    int segment_count() const { return segment_count_; }
    const PlantSegment<Scalar>& segment(int i) const { return segments_[static_cast<std::size_t>(i)]; }
    const Matrix3<Scalar>& augmented_matrix() const { return A_; }

    /// Index of x_{j-i} in the loop state.
    static int position_index(int i) { return i == 0 ? 0 : i + 1; }

  private:
    PlantSegment<Scalar> make_segment(Scalar start, Scalar length, int force_age) const {
        PlantSegment<Scalar> s;
        s.start = start;
        s.length = length;
        s.force_age = force_age;
        Matrix3<Scalar> qx = Matrix3<Scalar>::Zero();
        qx(0, 0) = 1;
        Matrix3<Scalar> qv = Matrix3<Scalar>::Zero();
        qv(1, 1) = 1;
        const auto ix = exponential_integrals<Scalar>(A_, qx, length);
        const auto iv = exponential_integrals<Scalar>(A_, qv, length);
        s.exp = ix.exp;
        s.position_gramian = ix.gramian;
        s.velocity_gramian = iv.gramian;
        using std::sqrt;
        const Scalar norm = detail::norm1_3(A_);
        const Scalar omega2 = Scalar(parameters_.gamma) - Scalar(parameters_.delta * parameters_.delta) / 4;
        const Scalar omega = omega2 > 0 ? sqrt(omega2) : Scalar(0);
        const Scalar needed = std::max(norm * length / Scalar(2), omega * length / Scalar(3));
        s.pieces = needed > Scalar(1) ? static_cast<int>(std::ceil(static_cast<double>(needed))) : 1;
        s.piece_exp = s.pieces == 1 ? s.exp : exponential<Scalar>(A_, length / Scalar(s.pieces));
        return s;
    }

    NormalizedPlant parameters_;
    int whole_delay_ = 0;
    Scalar fraction_ = 0;
    int history_ = 1;
    int segment_count_ = 1;
    Matrix3<Scalar> A_;
    std::array<PlantSegment<Scalar>, 2> segments_;
};

}  // namespace hapticopt
