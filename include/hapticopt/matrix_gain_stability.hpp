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
// Free directions: on null(A) ∩ null(B) no wall acts and P(z) u = P_0(z) u gives the free plant's roots
// (z = 1, and exp(-delta) or a double root at 1): these are the device's own, not the wall's. Because A
// and B are symmetric, the orthogonal complement of that null space is invariant under both, so P is
// restricted to it (basis from the eigenvectors of A^2 + B^2 above a relative threshold of 1e-12) and only
// that part is judged. A direction with damping but no stiffness keeps a root at z = 1 (the position
// integrates) and is therefore not asymptotically stable — as alpha + gamma > 0 is required in the scalar
// verdict.
//
// Accuracy and the verdict: the eigenvalues have a backward error of ~eps ||companion||; a root of
// multiplicity two moves by ~sqrt(eps) ~ 1.5e-8 times its conditioning. The non-commuting verdict is
// therefore "stable" only for a spectral radius below 1 - kMatrixGainRadiusMargin (1e-6): gain sets
// within that distance of the boundary are refused as not certifiably stable. The tests compare the
// spectral radius with long double eigenvalues of the loop's state-transition matrix built independently
// from the matrix exponential of the 3-axis plant (tests/beyond/matrix_gain_stability_test.cpp).
//
// Cost: a symmetric r x r eigen-decomposition, then either r Schur-Cohn tests (commuting) or one
// non-symmetric eigenvalue problem of size r (n + 3): ~15 x 15 for r = 3, d = 2 (tens of microseconds).
// Not for the real-time loop (allocates); the daemon calls it when a client commits a scene.
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>

#include "config.hpp"
#include "characteristic_polynomial.hpp"
#include "stability.hpp"

namespace hapticopt {

/// Distance from the unit circle below which a non-commuting gain set is not reported stable.
inline constexpr double kMatrixGainRadiusMargin = 1e-6;

struct MatrixGainStability {
  bool stable = false;            ///< every root of the restricted loop strictly inside the unit circle
  bool commuting = false;         ///< A B = B A (within 1e-12 relative): decided per common eigenvector
  int active_directions = 0;      ///< rank of the part where a wall acts (0: nothing to judge, stable)
  double spectral_radius = 0.0;   ///< largest |root| of the restricted loop (0 when nothing acts)
};

/// Stability of the loop with symmetric normalised gain matrices `A` (stiffness) and `B` (damping), same
/// plant on every axis. Throws InvalidParameter for a non-square, non-symmetric (beyond 1e-9 relative) or
/// non-finite matrix, matrices of different size, and the plant's own invalid parameters.
HAPTICOPT_FUNC MatrixGainStability matrix_gain_stability(const NormalizedPlant& plant, const Eigen::MatrixXd& A,
                                                         const Eigen::MatrixXd& B)
#if HAPTICOPT_DEFINITIONS
{
  const char* fn = "hapticopt::matrix_gain_stability";
  validate(plant, fn);
  if (A.rows() != A.cols() || B.rows() != B.cols() || A.rows() != B.rows() || A.rows() == 0) {
    throw InvalidParameter(fn, "gain matrix size", static_cast<double>(A.rows()),
                           "A and B square, of the same size >= 1");
  }
  if (!A.allFinite() || !B.allFinite()) {
    throw InvalidParameter(fn, "gain matrix entry", NAN, "finite");
  }
  const double scale = 1.0 + A.norm() + B.norm();
  if ((A - A.transpose()).norm() > 1e-9 * scale || (B - B.transpose()).norm() > 1e-9 * scale) {
    throw InvalidParameter(fn, "gain matrix asymmetry", std::max((A - A.transpose()).norm(), (B - B.transpose()).norm()),
                           "A and B symmetric (to 1e-9 relative)");
  }
  const Eigen::MatrixXd As = (A + A.transpose()) / 2, Bs = (B + B.transpose()) / 2;
  MatrixGainStability result;

  // The part where a wall acts: the range of A^2 + B^2.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> active(As * As + Bs * Bs);
  const double threshold = 1e-12 * std::max(1.0, active.eigenvalues().cwiseAbs().maxCoeff());
  Eigen::MatrixXd Q(As.rows(), 0);
  for (Eigen::Index c = 0; c < As.rows(); ++c) {
    if (active.eigenvalues()(c) > threshold) {
      Q.conservativeResize(Eigen::NoChange, Q.cols() + 1);
      Q.col(Q.cols() - 1) = active.eigenvectors().col(c);
    }
  }
  result.active_directions = static_cast<int>(Q.cols());
  if (Q.cols() == 0) {
    result.stable = true;
    result.commuting = true;
    return result;
  }
  const Eigen::MatrixXd Ar = Q.transpose() * As * Q, Br = Q.transpose() * Bs * Q;
  const Eigen::Index r = Ar.rows();

  const double commutator = (Ar * Br - Br * Ar).norm();
  result.commuting = commutator <= 1e-12 * (1.0 + Ar.norm() * Br.norm());
  if (result.commuting) {
    // Common eigenvectors: those of A + c B for a generic c separate A's repeated eigenvalues by B's.
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> common(Ar + 0.7548776662466927 * Br);
    result.stable = true;
    for (Eigen::Index c = 0; c < r; ++c) {
      const Eigen::VectorXd u = common.eigenvectors().col(c);
      const StabilityReport s = stability(plant, NormalizedGains{u.dot(Ar * u), u.dot(Br * u)});
      result.stable = result.stable && s.stable;
      result.spectral_radius = std::max(result.spectral_radius, s.spectral_radius);
    }
    return result;
  }

  const AffineCharacteristicPolynomial<double> p = characteristic_polynomial(SampledPlant<double>(plant));
  const int degree = p.degree();
  // Block companion matrix of P(z) = sum_k C_k z^k with C_degree = I: the roots z of det P are its
  // eigenvalues (first block row -C_{degree-1} ... -C_0, identity blocks below the diagonal).
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(r * degree, r * degree);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(r, r);
  for (int k = 0; k < degree; ++k) {
    const Eigen::MatrixXd Ck = p.base(k) * I + p.alpha(k) * Ar + p.beta(k) * Br;
    companion.block(0, r * (degree - 1 - k), r, r) = -Ck;
  }
  for (int b = 1; b < degree; ++b) companion.block(r * b, r * (b - 1), r, r) = I;
  const Eigen::EigenSolver<Eigen::MatrixXd> roots(companion, /*computeEigenvectors=*/false);
  if (roots.info() != Eigen::Success) {
    result.stable = false;
    result.spectral_radius = HUGE_VAL;
    return result;
  }
  result.spectral_radius = roots.eigenvalues().cwiseAbs().maxCoeff();
  result.stable = result.spectral_radius < 1.0 - kMatrixGainRadiusMargin;
  return result;
}
#else
;
#endif

}  // namespace hapticopt
