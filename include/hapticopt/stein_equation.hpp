// Discrete Lyapunov (Stein) equations  X = M X M^T + C  solved on the complex Schur form
// M = U T U^H (T upper triangular), column by column by back substitution
// (Bartels-Stewart, CACM 15(9), 1972; Kitagawa, Int. J. Control 25(5), 1977).
//
// A solution exists and is unique iff lambda_i conj(lambda_k) != 1 for all eigenvalue pairs; for a
// Schur-stable M (spectral radius rho < 1) it is X = sum_j M^j C M^jT. The back substitution divides
// by 1 - conj(t_kk) t_ii, so its relative error grows like eps / (1 - rho^2).
// Cost: O(N^3) per equation once the Schur form is known (the Schur form itself ~ 25 N^3).
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <complex>

namespace hapticopt {

template <typename Scalar>
using ComplexMatrix = Eigen::Matrix<std::complex<Scalar>, Eigen::Dynamic, Eigen::Dynamic>;
template <typename Scalar>
using ComplexVector = Eigen::Matrix<std::complex<Scalar>, Eigen::Dynamic, 1>;

/// Solves X = T X T^H + C for upper-triangular T (only the upper triangle of T is read).
template <typename Scalar>
ComplexMatrix<Scalar> solve_triangular_stein(const ComplexMatrix<Scalar>& t,
                                             const ComplexMatrix<Scalar>& c) {
  using Complex = std::complex<Scalar>;
  const Eigen::Index n = t.rows();
  ComplexMatrix<Scalar> x(n, n);
  ComplexVector<Scalar> rhs(n);
  ComplexVector<Scalar> acc(n);
  for (Eigen::Index k = n - 1; k >= 0; --k) {
    rhs = c.col(k);
    const Eigen::Index later = n - k - 1;
    if (later > 0) {
      acc.noalias() = x.rightCols(later) * t.row(k).tail(later).adjoint();
      rhs.noalias() += t.template triangularView<Eigen::Upper>() * acc;
    }
    const Complex tk = std::conj(t(k, k));
    for (Eigen::Index i = n - 1; i >= 0; --i) {
      Complex s = rhs(i);
      for (Eigen::Index l = i + 1; l < n; ++l) s += tk * t(i, l) * x(l, k);
      x(i, k) = s / (Scalar(1) - tk * t(i, i));
    }
  }
  return x;
}

/// Reverses row and column order: J X J with J the exchange matrix. J T^H J is upper triangular
/// for upper-triangular T, which turns  Y = T^H Y T + C  into the form solved above.
template <typename Scalar>
ComplexMatrix<Scalar> flip(const ComplexMatrix<Scalar>& x) {
  return x.reverse();
}

}  // namespace hapticopt
