// The complex Schur form of the loop transition M = U T U^H (Eigen::ComplexSchur: Hessenberg
// reduction + shifted QR, ~25 N^3 flops), plus the stability verdict (Schur-Cohn) that gates the
// closed forms. The Schur form gives the spectral radius of StabilityReport and the complex-Schur
// cross-check energy_costs_complex_schur; the energy costs and the overshoot bound themselves use
// the cheaper shift-structured Stein solver (stein_equation.hpp).
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>

#include "characteristic_polynomial.hpp"
#include "closed_loop.hpp"
#include "schur_cohn.hpp"
#include "stein_equation.hpp"

namespace hapticopt {

template <typename Scalar>
struct LoopSchurForm {
  ComplexMatrix<Scalar> t;  ///< upper triangular, eigenvalues of M on the diagonal
  ComplexMatrix<Scalar> u;  ///< unitary
  Scalar spectral_radius = 0;
};

template <typename Scalar>
LoopSchurForm<Scalar> loop_schur_form(const DynamicMatrix<Scalar>& m) {
  Eigen::ComplexSchur<DynamicMatrix<Scalar>> schur(m);
  LoopSchurForm<Scalar> form;
  form.t = schur.matrixT();
  form.u = schur.matrixU();
  form.spectral_radius = form.t.diagonal().cwiseAbs().maxCoeff();
  return form;
}

/// Stable iff alpha + gamma > 0 and the Schur-Cohn test passes on p(z). The closed forms
/// additionally require every computed eigenvalue of M to have modulus < 1 (checked by their
/// callers), which guards against a rounding disagreement right at the boundary.
template <typename Scalar>
bool loop_is_stable(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
  if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return false;
  return schur_cohn<Scalar>(characteristic_polynomial(plant).at(alpha, beta)).stable;
}

}  // namespace hapticopt
