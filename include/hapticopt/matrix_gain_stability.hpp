// SPDX-License-Identifier: Apache-2.0
// Stability of a multi-axis wall with matrix gains: several objects in contact at once, along directions
// that need not be parallel.
//
// The device moves in R^r with the same normalised plant on every axis (isotropic mass, damping and
// stiffness: m = T = 1, gamma, delta, delay d as in sampled_plant.hpp), and the wall force is
//
//   f_j = A x_j + B (x_j - x_{j-1}),   A = K T^2 / m,  B = B_phys T / m   (symmetric r x r matrices).
//
// The scalar loop's characteristic polynomial is affine in the gains (characteristic_polynomial.hpp):
// p(z) = P_0(z) + alpha P_alpha(z) + beta P_beta(z), obtained from x = P(z)(F - f) and f = C(z) z^-n x
// by multiplications with scalar polynomials only. With the gains as matrices the same steps give the
// matrix polynomial
//
//   P(z) = P_0(z) I + P_alpha(z) A + P_beta(z) B,    leading coefficient I,
//
// and det P(z) is the characteristic polynomial of the coupled loop. If A and B commute they have common
// eigenvectors u_i and det P(z) = prod_i p(z; u_i^T A u_i, u_i^T B u_i): the scalar analysis along each
// direction, decided here by the library's Schur-Cohn verdict (stability.hpp). Otherwise the roots are the
// eigenvalues of the block companion matrix of P (size r (n + 3), n + 4 for a fractional d), computed with
// Eigen's real EigenSolver.
//
// Free directions: on N = null(A) ∩ null(B) no wall acts and P(z) u = P_0(z) u gives the free plant's roots
// (z = 1, and exp(-delta) or a double root at 1): these are the device's own, not the wall's. With
// x = Q a + U b (U an orthonormal basis of N, Q of its orthogonal complement, the row space of [A; B]) the
// wall force A x + B (x - x_-1) depends on a only, so the loop is block-triangular: a evolves with the gains
// Q^T A Q, Q^T B Q alone, b is driven by it, and the roots are those of the restricted polynomial and the
// free plant's. This holds for any A and B, symmetric or not, so P is restricted to Q and only that part is
// judged. Q: the right singular vectors of the stacked [A; B] whose singular value exceeds
// kMatrixGainRoundingLevel (64 eps) times the largest — the rounding level of the matrices themselves
// (a plane's K n n^T has a second singular value of ~eps K from rounding alone), not a threshold on
// gains: every direction touched above rounding is judged, with the margin below. A direction left out
// has gains below 1.5e-14 of the largest, which move the free plant's roots at 1 by at most ~sqrt(1.5e-14)
// = 1.2e-7 (a double root) in either direction: no growth faster than e-fold per 8e6 ticks, and the device's
// own free motion is not asymptotically stable anyway. A direction with damping but no stiffness keeps a
// root at z = 1 (the position integrates) and is therefore not asymptotically stable — as alpha + gamma > 0
// is required in the scalar verdict.
//
// Accuracy and the verdict: the eigenvalues have a backward error of ~eps ||companion||; a root of
// multiplicity two moves by ~sqrt(eps) ~ 1.5e-8 times its conditioning. The verdict is therefore "stable"
// only for a spectral radius below 1 - kMatrixGainRadiusMargin (1e-6), in both paths (the commuting path
// takes the Schur-Cohn verdict and the radius of the scalar loops' transition matrices): gain sets within
// that distance of the boundary, or so weakly acting along some direction that a root lies within 1e-6 of
// z = 1 (a time constant above 1e6 periods), are refused as not certifiably stable. The tests compare the
// spectral radius with the eigenvalues of the loop's state-transition matrix built independently from the
// matrix exponential of the 3-axis plant (tests/beyond/test_matrix_gain_stability.cpp).
//
// The velocity estimator (velocity_estimator.hpp): with f_j = A x_j + B v_j and v_j from the estimator's
// difference equation A(1/z) v = B(1/z) x, the steps of estimator_characteristic_polynomial multiply the
// scalar polynomials by At(z) = z^L A(1/z) and Bt(z) = z^L B(1/z) only, so the matrix polynomial is
//
//   P(z) = P_0(z) At(z) I + P_alpha(z) At(z) A + P_alpha(z) Bt(z) B,    leading coefficient I,
//
// exactly that function's affine form, and the block companion matrix (size r (n + 3 + L)) gives its
// roots; when A and B commute the per-direction verdict is the scalar one with the estimator
// (stability(plant, gains, estimator): Schur-Cohn on p_est and the radius of the estimator's loop matrix).
// The backward difference (the default) takes the paths above unchanged (p_est = z p: the same roots and a
// root at 0). Free directions: P(z) u = P_0(z) At(z) u, the free plant's roots and the estimator's own
// poles (At's roots: lambda for the low-pass, 0 for a window), inside the unit circle, so restricting to
// the acting part is unchanged. Checked against an independently built state matrix with the estimator's
// difference equation and a time-stepping simulation (tests/beyond/test_matrix_gain_estimator.cpp).
//
// Gains as rendered (general_matrix_gain_stability): a force field f = J (x - x0) - B v renders the
// stiffness matrix -J, whose antisymmetric part (a curl) stores no energy but, with sampling, damping and
// delay, can destabilise the loop (follower-force flutter). The matrix polynomial above is derived with
// scalar polynomials times A and B only, so it holds for non-symmetric A and B: the roots of det P are the
// closed loop's, and the block companion matrix gives them. Symmetric A and B (to the rounding level) are
// handed to matrix_gain_stability (exact per-direction verdicts when they commute); anything else is
// decided by the companion eigenvalues with the margin. The same state-matrix comparison covers it.
//
// Cost: a symmetric r x r eigen-decomposition, then either r Schur-Cohn tests (commuting) or one
// non-symmetric eigenvalue problem of size r (n + 3): ~15 x 15 for r = 3, d = 2 (tens of microseconds).
// Not for the real-time loop (allocates); the daemon calls it when a client commits a scene.
#pragma once

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "estimator_stability.hpp"
#include "stability.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// Distance from the unit circle below which no gain set is reported stable (both paths).
inline constexpr double kMatrixGainRadiusMargin = 1e-6;
/// Relative singular value of the stacked gains [A; B] at or below which a direction counts as free (64 eps).
inline constexpr double kMatrixGainRoundingLevel = 64 * 2.220446049250313e-16;

struct MatrixGainStability {
    bool stable = false;           ///< every root of the restricted loop strictly inside the unit circle
    bool commuting = false;        ///< A B = B A (within 1e-12 relative): decided per common eigenvector
    int active_directions = 0;     ///< rank of the part where a wall acts (0: nothing to judge, stable)
    double spectral_radius = 0.0;  ///< largest |root| of the restricted loop (0 when nothing acts)
};

namespace detail {

// The plant's parameters, then A and B square, of one size >= 1, finite; InvalidParameter from `fn`.
inline void validate_gain_matrices(const NormalizedPlant& plant, const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                   const char* fn) {
    validate(plant, fn);
    if (A.rows() != A.cols() || B.rows() != B.cols() || A.rows() != B.rows() || A.rows() == 0) {
        throw InvalidParameter(fn, "gain matrix size", static_cast<double>(A.rows()),
                               "A and B square, of the same size >= 1");
    }
    if (!A.allFinite() || !B.allFinite()) {
        throw InvalidParameter(fn, "gain matrix entry", NAN, "finite");
    }
}

// An orthonormal basis (columns) of the row space of [A; B]: the directions where a wall acts.
HAPTICOPT_FUNC Eigen::MatrixXd acting_basis(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B)
#if HAPTICOPT_DEFINITIONS
{
    Eigen::MatrixXd stacked(2 * A.rows(), A.cols());
    stacked << A, B;
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(stacked, Eigen::ComputeFullV);
    const Eigen::VectorXd& sigma = svd.singularValues();
    const double threshold = kMatrixGainRoundingLevel * (sigma.size() > 0 ? sigma(0) : 0.0);
    Eigen::Index rank = 0;
    while (rank < sigma.size() && sigma(rank) > threshold) ++rank;
    return svd.matrixV().leftCols(rank);
}
#else
    ;
#endif

// Largest |root| of det(P_0(z) I + P_alpha(z) A + P_beta(z) B) (A, B any r x r matrices): the eigenvalues
// of the block companion matrix (first block row -C_{degree-1} ... -C_0, identity blocks below the
// diagonal), C_k = base_k I + alpha_k A + beta_k B, C_degree = I. HUGE_VAL if the eigen-solver fails.
HAPTICOPT_FUNC double companion_spectral_radius(const AffineCharacteristicPolynomial<double>& p,
                                                const Eigen::MatrixXd& A, const Eigen::MatrixXd& B)
#if HAPTICOPT_DEFINITIONS
{
    const Eigen::Index r = A.rows();
    const int degree = p.degree();
    Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(r * degree, r * degree);
    const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(r, r);
    for (int k = 0; k < degree; ++k) {
        companion.block(0, r * (degree - 1 - k), r, r) = -(p.base(k) * I + p.alpha(k) * A + p.beta(k) * B);
    }
    for (int b = 1; b < degree; ++b) companion.block(r * b, r * (b - 1), r, r) = I;
    const Eigen::EigenSolver<Eigen::MatrixXd> roots(companion, /*computeEigenvectors=*/false);
    if (roots.info() != Eigen::Success) return HUGE_VAL;
    return roots.eigenvalues().cwiseAbs().maxCoeff();
}
#else
    ;
#endif

// The scalar loops of symmetric, commuting A and B: (u^T A u, u^T B u) along their common eigenvectors u, those
// of A + c B for a generic c (which separates A's repeated eigenvalues by B's).
HAPTICOPT_FUNC std::vector<NormalizedGains> common_direction_gains(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B)
#if HAPTICOPT_DEFINITIONS
{
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> common(A + 0.7548776662466927 * B);
    std::vector<NormalizedGains> out;
    for (Eigen::Index c = 0; c < A.rows(); ++c) {
        const Eigen::VectorXd u = common.eigenvectors().col(c);
        out.push_back(NormalizedGains{u.dot(A * u), u.dot(B * u)});
    }
    return out;
}
#else
    ;
#endif

}  // namespace detail

/// Stability of the loop with symmetric normalised gain matrices `A` (stiffness) and `B` (damping), same
/// plant on every axis, velocity from `estimator` (default: the backward difference). Throws InvalidParameter
/// for a non-square, non-symmetric (beyond 1e-9 relative) or non-finite matrix, matrices of different size,
/// the plant's own invalid parameters and an invalid estimator (validate(VelocityEstimator)).
HAPTICOPT_FUNC MatrixGainStability matrix_gain_stability(const NormalizedPlant& plant, const Eigen::MatrixXd& A,
                                                         const Eigen::MatrixXd& B,
                                                         const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::matrix_gain_stability";
    detail::validate_gain_matrices(plant, A, B, fn);
    validate(estimator, fn);
    const bool backward = estimator.kind == VelocityEstimatorKind::backward;
    const double scale = 1.0 + A.norm() + B.norm();
    if ((A - A.transpose()).norm() > 1e-9 * scale || (B - B.transpose()).norm() > 1e-9 * scale) {
        throw InvalidParameter(fn, "gain matrix asymmetry",
                               std::max((A - A.transpose()).norm(), (B - B.transpose()).norm()),
                               "A and B symmetric (to 1e-9 relative)");
    }
    const Eigen::MatrixXd As = (A + A.transpose()) / 2, Bs = (B + B.transpose()) / 2;
    MatrixGainStability result;

    // The part where a wall acts: the row space of [A; B] above the rounding level.
    const Eigen::MatrixXd Q = detail::acting_basis(As, Bs);
    result.active_directions = static_cast<int>(Q.cols());
    if (Q.cols() == 0) {
        result.stable = true;
        result.commuting = true;
        return result;
    }
    const Eigen::MatrixXd Ar = Q.transpose() * As * Q, Br = Q.transpose() * Bs * Q;

    const double commutator = (Ar * Br - Br * Ar).norm();
    result.commuting = commutator <= 1e-12 * (1.0 + Ar.norm() * Br.norm());
    if (result.commuting) {
        result.stable = true;
        for (const NormalizedGains& gains : detail::common_direction_gains(Ar, Br)) {
            const StabilityReport s = backward ? stability(plant, gains) : stability(plant, gains, estimator);
            result.stable = result.stable && s.stable;
            result.spectral_radius = std::max(result.spectral_radius, s.spectral_radius);
        }
        result.stable = result.stable && result.spectral_radius < 1.0 - kMatrixGainRadiusMargin;
        return result;
    }

    const AffineCharacteristicPolynomial<double> p = characteristic_polynomial(SampledPlant<double>(plant));
    result.spectral_radius =
        detail::companion_spectral_radius(backward ? p : estimator_characteristic_polynomial(p, estimator), Ar, Br);
    result.stable = result.spectral_radius < 1.0 - kMatrixGainRadiusMargin;
    return result;
}
#else
    ;
#endif

/// Stability of the loop with any real normalised gain matrices `A` (stiffness, e.g. -J of a force field
/// with a curl) and `B` (damping), same plant on every axis: the gains as the loop renders them. Symmetric
/// A and B (asymmetry at most kMatrixGainRoundingLevel relative) go to matrix_gain_stability; otherwise the
/// restricted block companion matrix decides, stable only for a spectral radius below 1 -
/// kMatrixGainRadiusMargin (commuting = false). Velocity from `estimator` (default: the backward
/// difference), as in matrix_gain_stability. Throws InvalidParameter for non-square, differently sized
/// or non-finite matrices, the plant's own invalid parameters and an invalid estimator. Cost: one SVD of a
/// 2r x r matrix and one non-symmetric eigenproblem of size r (n + 3) (~18 x 18 for r = 3, d = 3; r L more
/// with an estimator: L = 1 for the low-pass, N for a window of N).
HAPTICOPT_FUNC MatrixGainStability general_matrix_gain_stability(const NormalizedPlant& plant, const Eigen::MatrixXd& A,
                                                                 const Eigen::MatrixXd& B,
                                                                 const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::general_matrix_gain_stability";
    detail::validate_gain_matrices(plant, A, B, fn);
    validate(estimator, fn);
    const double scale = A.norm() + B.norm();
    if ((A - A.transpose()).norm() <= kMatrixGainRoundingLevel * scale &&
        (B - B.transpose()).norm() <= kMatrixGainRoundingLevel * scale) {
        return matrix_gain_stability(plant, (A + A.transpose()) / 2, (B + B.transpose()) / 2, estimator);
    }
    MatrixGainStability result;
    const Eigen::MatrixXd Q = detail::acting_basis(A, B);
    result.active_directions = static_cast<int>(Q.cols());
    const Eigen::MatrixXd Ar = Q.transpose() * A * Q, Br = Q.transpose() * B * Q;
    const AffineCharacteristicPolynomial<double> p = characteristic_polynomial(SampledPlant<double>(plant));
    result.spectral_radius = detail::companion_spectral_radius(
        estimator.kind == VelocityEstimatorKind::backward ? p : estimator_characteristic_polynomial(p, estimator), Ar,
        Br);
    result.stable = result.spectral_radius < 1.0 - kMatrixGainRadiusMargin;
    return result;
}
#else
    ;
#endif

}  // namespace hapticopt
