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
// multiplicity two moves by ~sqrt(eps) ~ 1.5e-8 times its conditioning. A spectral radius below
// 1 - kMatrixGainRadiusMargin (1e-6) is "stable" at once, in both paths (the commuting path takes the Schur-Cohn
// verdict and the radius of the scalar loops' transition matrices). Nearer the circle a root is certified one by one
// (detail::companion_roots): with C the companion matrix (n x n), lambda a computed root, x and y its right and left
// eigenvectors (inverse iteration from lambda) and s = |y^H x| / (|x| |y|) its reciprocal condition number, the
// root of the exact matrix lies within e = n eps ||C||_F / s of lambda to first order (Wilkinson; LAPACK Users'
// Guide, 3rd ed., section 4.8.1: the approximate error bound eps ||A|| / RCONDE of xGEEVX, here with the factor n of
// the QR algorithm's backward error). The root counts as inside when |lambda| + e < 1 and e is below a quarter of its
// distance to the nearest other root (the first-order term dominates: a cluster of roots, e.g. the free plant's
// double root at 1 barely split, is not certified). So a stable loop whose slow root lies within 1e-6 of the circle
// is reported stable when that root is well conditioned: a weak spring beside a damped or delayed one (a plane
// ramping in over a slow ramp beside a wall, the hand's damping b_H on a nearly free direction: a root k T / b_H
// from 1, a time constant of hours). Cost there: one complex LU of C per near-circle root. A root within its bound
// of the circle, or in a cluster, is refused as not certifiably stable. The tests compare the spectral radius with the
// eigenvalues of the loop's state-transition matrix built independently from the matrix exponential of the 3-axis
// plant (tests/beyond/test_matrix_gain_stability.cpp), in long double near the circle.
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
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <complex>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "estimator_stability.hpp"
#include "stability.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// Distance from the unit circle within which a root is reported inside only if certified by its error bound.
inline constexpr double kMatrixGainRadiusMargin = 1e-6;
/// Relative singular value of the stacked gains [A; B] at or below which a direction counts as free (64 eps).
inline constexpr double kMatrixGainRoundingLevel = 64 * 2.220446049250313e-16;

struct MatrixGainStability {
    bool stable = false;           ///< every root of the restricted loop strictly inside the unit circle (certified)
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

// The block companion matrix of det(P_0(z) I + P_alpha(z) A + P_beta(z) B) (A, B any r x r matrices): first block
// row -C_{degree-1} ... -C_0, identity blocks below the diagonal, C_k = base_k I + alpha_k A + beta_k B, C_degree = I.
HAPTICOPT_FUNC Eigen::MatrixXd block_companion(const AffineCharacteristicPolynomial<double>& p,
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
    return companion;
}
#else
    ;
#endif

// The reciprocal condition number s = |y^H x| / (|x| |y|) of the eigenvalue `lambda` of C: x and y from two steps of
// inverse iteration on C - lambda I and its adjoint (one LU). 0 when the shifted matrix is singular to working
// precision (no finite iterate).
HAPTICOPT_FUNC double eigenvalue_reciprocal_condition(const Eigen::MatrixXd& C, std::complex<double> lambda)
#if HAPTICOPT_DEFINITIONS
{
    const Eigen::Index n = C.rows();
    const Eigen::MatrixXcd shifted = C.cast<std::complex<double>>() - lambda * Eigen::MatrixXcd::Identity(n, n);
    const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(shifted);
    Eigen::VectorXcd x(n), y(n);
    for (Eigen::Index i = 0; i < n; ++i) x(i) = y(i) = std::complex<double>(1.0, 0.5 + 0.25 * std::sin(1.0 + i));
    for (int step = 0; step < 2; ++step) {
        x = lu.solve(x);
        y = lu.adjoint().solve(y);
        if (!x.allFinite() || !y.allFinite() || x.norm() == 0.0 || y.norm() == 0.0) return 0.0;
        x.normalize();
        y.normalize();
    }
    return std::abs(y.dot(x));
}
#else
    ;
#endif

// The roots of det P: the largest |root| and whether the roots within kMatrixGainRadiusMargin of the unit circle (or
// beyond it) are each certified inside by its first-order error bound (the header's "Accuracy and the verdict").
struct CompanionRoots {
    double radius = HUGE_VAL;  // HUGE_VAL if the eigen-solver fails
    bool inside = false;       // every root certified strictly inside the unit circle
};

HAPTICOPT_FUNC CompanionRoots companion_roots(const AffineCharacteristicPolynomial<double>& p, const Eigen::MatrixXd& A,
                                              const Eigen::MatrixXd& B)
#if HAPTICOPT_DEFINITIONS
{
    CompanionRoots out;
    const Eigen::MatrixXd C = block_companion(p, A, B);
    const Eigen::EigenSolver<Eigen::MatrixXd> roots(C, /*computeEigenvectors=*/false);
    if (roots.info() != Eigen::Success) return out;
    const Eigen::VectorXcd& lambda = roots.eigenvalues();
    out.radius = lambda.cwiseAbs().maxCoeff();
    if (!(out.radius < 1.0)) return out;
    if (out.radius < 1.0 - kMatrixGainRadiusMargin) {
        out.inside = true;
        return out;
    }
    const double backward = static_cast<double>(C.rows()) * 2.220446049250313e-16 * C.norm();
    for (Eigen::Index i = 0; i < lambda.size(); ++i) {
        if (std::abs(lambda(i)) < 1.0 - kMatrixGainRadiusMargin) continue;
        double gap = HUGE_VAL;
        for (Eigen::Index j = 0; j < lambda.size(); ++j) {
            if (j != i) gap = std::min(gap, std::abs(lambda(i) - lambda(j)));
        }
        const double s = eigenvalue_reciprocal_condition(C, lambda(i));
        const double bound = s > 0.0 ? backward / s : HUGE_VAL;
        if (!(bound < 0.25 * gap && std::abs(lambda(i)) + bound < 1.0)) return out;
    }
    out.inside = true;
    return out;
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
        if (result.stable && result.spectral_radius >= 1.0 - kMatrixGainRadiusMargin) {
            // A root near the circle: each direction's scalar loop certified root by root.
            const AffineCharacteristicPolynomial<double> p = characteristic_polynomial(SampledPlant<double>(plant));
            const AffineCharacteristicPolynomial<double> pe =
                backward ? p : estimator_characteristic_polynomial(p, estimator);
            for (const NormalizedGains& gains : detail::common_direction_gains(Ar, Br)) {
                const Eigen::MatrixXd a = Eigen::MatrixXd::Constant(1, 1, gains.alpha);
                const Eigen::MatrixXd b = Eigen::MatrixXd::Constant(1, 1, gains.beta);
                result.stable = result.stable && detail::companion_roots(pe, a, b).inside;
            }
        }
        return result;
    }

    const AffineCharacteristicPolynomial<double> p = characteristic_polynomial(SampledPlant<double>(plant));
    const detail::CompanionRoots roots =
        detail::companion_roots(backward ? p : estimator_characteristic_polynomial(p, estimator), Ar, Br);
    result.spectral_radius = roots.radius;
    result.stable = roots.inside;
    return result;
}
#else
    ;
#endif

/// Stability of the loop with any real normalised gain matrices `A` (stiffness, e.g. -J of a force field
/// with a curl) and `B` (damping), same plant on every axis: the gains as the loop renders them. Symmetric
/// A and B (asymmetry at most kMatrixGainRoundingLevel relative) go to matrix_gain_stability; otherwise the
/// restricted block companion matrix decides, stable for a spectral radius below 1 - kMatrixGainRadiusMargin or with
/// every root nearer the circle certified inside (commuting = false). Velocity from `estimator` (default: the backward
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
    const detail::CompanionRoots roots = detail::companion_roots(
        estimator.kind == VelocityEstimatorKind::backward ? p : estimator_characteristic_polynomial(p, estimator), Ar,
        Br);
    result.spectral_radius = roots.radius;
    result.stable = roots.inside;
    return result;
}
#else
    ;
#endif

}  // namespace hapticopt
