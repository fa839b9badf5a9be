// SPDX-License-Identifier: Apache-2.0
// Discrete Lyapunov (Stein) equations  X = M X M^T + C  solved on the complex Schur form
// M = U T U^H (T upper triangular), column by column by back substitution
// (Bartels-Stewart, CACM 15(9), 1972; Kitagawa, Int. J. Control 25(5), 1977).
//
// A solution exists and is unique iff lambda_i conj(lambda_k) != 1 for all eigenvalue pairs; for a
// Schur-stable M (spectral radius rho < 1) it is X = sum_j M^j C M^jT. The back substitution divides
// by 1 - conj(t_kk) t_ii, so its relative error grows like eps / (1 - rho^2).
// Cost: O(N^3) per equation once the Schur form is known (the Schur form itself ~ 25 N^3).
//
// ShiftSteinSolver (used by the energy costs): the loop matrix M has only two dense rows; its rows
// k >= 2 are unit rows that shift the position history (closed_loop.hpp). Then X = M X M^T + C gives
//   X[k, l] = X[s(k), s(l)] + C[k, l]   for k, l >= 2   (s = shift_source),
// so every entry of X is one entry of its first two rows plus a known sum of C along a diagonal.
// Substituting this into the remaining equations (rows 0 and 1) leaves a dense linear system in the
// 2N - 1 entries X[0, :], X[1, 1:], solved by Gaussian elimination with partial pivoting. The
// system matrix depends on M only, so one LU serves any number of right-hand sides.
// Exact elimination, no eigen-decomposition: its error is that of the LU of the reduced system,
// bounded like the Schur method's by eps times the condition of the Stein operator, which grows
// like 1 / (1 - rho^2); measured against long double in tests/core/test_energy_costs.cpp.
// Cost: O(N^2) assembly + (2/3)(2N - 1)^3 flops for the LU, O(N^2) per right-hand side.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <utility>

#include "closed_loop.hpp"

namespace hapticopt {

template <typename Scalar>
using ComplexMatrix = Eigen::Matrix<std::complex<Scalar>, Eigen::Dynamic, Eigen::Dynamic>;
template <typename Scalar>
using ComplexVector = Eigen::Matrix<std::complex<Scalar>, Eigen::Dynamic, 1>;

/// Solves X = T X T^H + C for upper-triangular T (only the upper triangle of T is read).
template <typename Scalar>
ComplexMatrix<Scalar> solve_triangular_stein(const ComplexMatrix<Scalar>& t, const ComplexMatrix<Scalar>& c) {
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

/// Solver of X = M X M^T + C (C symmetric) for M with the shift structure of the loop: rows 0, 1 of
/// M given as `top` (2 x N), row k >= 2 the unit row e_{shift_source(k)}^T. Storage of at most MaxN
/// states (Eigen::Dynamic: heap). See the header comment for the method.
template <typename Scalar, int MaxN = Eigen::Dynamic>
class ShiftSteinSolver {
  public:
    static constexpr int kMaxUnknowns = MaxN == Eigen::Dynamic ? Eigen::Dynamic : 2 * MaxN - 1;
    using Square = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN>;
    using Top = Eigen::Matrix<Scalar, 2, Eigen::Dynamic, 0, 2, MaxN>;

    /// Assembles and factorises the reduced system. `ok()` is false if a pivot vanished (M has an
    /// eigenvalue pair with lambda_i lambda_k = 1, i.e. M is not Schur-stable).
    explicit ShiftSteinSolver(const Top& top) : top_(top), n_(static_cast<int>(top.cols())) {
        const int n = n_;
        const int u = 2 * n - 1;
        for (int a = 0; a < 2; ++a) {
            nonzero_[a].resize(n);
            int count = 0;
            for (int m = 0; m < n; ++m) {
                if (top_(a, m) != Scalar(0)) nonzero_[a](count++) = m;
            }
            nonzero_[a].conservativeResize(count);
        }
        ref_.resize(n, n);
        for (int k = 0; k < n; ++k) {
            for (int l = 0; l < n; ++l) {
                ref_(k, l) =
                    (k < 2 || l < 2) ? basic(std::min(k, l), std::max(k, l)) : ref_(shift_source(k), shift_source(l));
            }
        }
        lu_.setZero(u, u);
        for (int b = 0; b < n; ++b) {
            for (int a = 0; a <= std::min(1, b); ++a) {
                const int eq = basic(a, b);
                lu_(eq, eq) += Scalar(1);
                if (b >= 2) {
                    const int sb = shift_source(b);
                    for (const int m : nonzero_[a]) lu_(eq, ref_(m, sb)) -= top_(a, m);
                } else {
                    for (const int m : nonzero_[a]) {
                        for (const int l : nonzero_[b]) lu_(eq, ref_(m, l)) -= top_(a, m) * top_(b, l);
                    }
                }
            }
        }
        // In-place LU with partial pivoting (row permutation in pivot_).
        using std::abs;
        pivot_.resize(u);
        for (int j = 0; j < u; ++j) {
            int p = j;
            Scalar largest = abs(lu_(j, j));
            for (int i = j + 1; i < u; ++i) {
                const Scalar v = abs(lu_(i, j));
                if (v > largest) {
                    largest = v;
                    p = i;
                }
            }
            pivot_(j) = p;
            if (p != j) lu_.row(p).swap(lu_.row(j));
            const Scalar d = lu_(j, j);
            if (!(d != Scalar(0)) || !std::isfinite(static_cast<double>(d))) {
                ok_ = false;
                return;
            }
            const int rest = u - j - 1;
            lu_.col(j).tail(rest) *= Scalar(1) / d;  // the multipliers by the pivot's reciprocal (as LAPACK's getf2)
            // The rank-1 update of the trailing block row by row (each entry a - f b, vectorised along the row),
            // skipping the rows whose multiplier f is zero (a - 0 b = a): the reduced system's shift equations
            // hold few non-zeros (n + 1 of its 2n - 1 columns), so before the fill-in most rows have none here.
            for (int i = j + 1; i < u; ++i) {
                const Scalar f = lu_(i, j);
                if (f != Scalar(0)) lu_.row(i).tail(rest) -= f * lu_.row(j).tail(rest);
            }
        }
    }

    bool ok() const { return ok_; }
    int size() const { return n_; }

    /// X with X = M X M^T + c (c symmetric; only valid when ok()).
    Square solve(const Square& c) const {
        const int n = n_;
        const int u = 2 * n - 1;
        Square offset(n, n);  // X[k, l] = offset[k, l] + unknown[ref[k, l]]
        for (int k = 0; k < n; ++k) {
            for (int l = 0; l < n; ++l) {
                offset(k, l) = (k < 2 || l < 2) ? Scalar(0) : offset(shift_source(k), shift_source(l)) + c(k, l);
            }
        }
        const Top p = top_times(offset);
        Vector rhs(u);
        for (int b = 0; b < n; ++b) {
            for (int a = 0; a <= std::min(1, b); ++a) {
                Scalar v;
                if (b >= 2) {
                    v = p(a, shift_source(b));
                } else {
                    v = 0;
                    for (const int m : nonzero_[b]) v += p(a, m) * top_(b, m);
                }
                rhs(basic(a, b)) = c(a, b) + v;
            }
        }
        for (int j = 0; j < u; ++j) {
            if (pivot_(j) != j) std::swap(rhs(j), rhs(pivot_(j)));
        }
        if (u >= kVectorisedSolveUnknowns) {
            lu_.template triangularView<Eigen::UnitLower>().solveInPlace(rhs);
            lu_.template triangularView<Eigen::Upper>().solveInPlace(rhs);
        } else {
            for (int i = 1; i < u; ++i) {
                Scalar v = 0;
                for (int m = 0; m < i; ++m) v += lu_(i, m) * rhs(m);
                rhs(i) -= v;
            }
            for (int i = u - 1; i >= 0; --i) {
                Scalar v = 0;
                for (int m = i + 1; m < u; ++m) v += lu_(i, m) * rhs(m);
                rhs(i) = (rhs(i) - v) / lu_(i, i);
            }
        }
        Square x(n, n);
        for (int k = 0; k < n; ++k) {
            for (int l = 0; l < n; ++l) x(k, l) = offset(k, l) + rhs(ref_(k, l));
        }
        return x;
    }

    /// P = sum_k (M^T)^k M^k, the solution of P = M^T P M + I (only valid when ok()): adjoint_solve(I).
    Square observability_gramian() const { return adjoint_solve(Square::Identity(n_, n_)); }

    /// L with L = M^T L M + h (h symmetric; only valid when ok()), the adjoint Stein equation. Since
    /// <h, X(C)> = <L, C> for the solution X(C) of X = M X M^T + C, L is the gradient of that linear
    /// function of C: one solve with the transposed LU, then the reverse of solve()'s substitutions.
    /// Cost O(N^2) after the factorisation.
    Square adjoint_solve(const Square& h) const {
        const int n = n_;
        const int u = 2 * n - 1;
        Vector lambda = Vector::Zero(u);  // K^-T (d <h, X> / d unknowns)
        for (int l = 0; l < n; ++l) {
            for (int k = 0; k < n; ++k) lambda(ref_(k, l)) += h(k, l);
        }
        if (u >= kVectorisedSolveUnknowns) {
            lu_.transpose().template triangularView<Eigen::Lower>().solveInPlace(lambda);      // U^T y = w
            lu_.transpose().template triangularView<Eigen::UnitUpper>().solveInPlace(lambda);  // L^T z = y
        } else {
            for (int i = 0; i < u; ++i) {  // U^T y = w
                Scalar v = 0;
                for (int m = 0; m < i; ++m) v += lu_(m, i) * lambda(m);
                lambda(i) = (lambda(i) - v) / lu_(i, i);
            }
            for (int i = u - 2; i >= 0; --i) {  // L^T z = y
                Scalar v = 0;
                for (int m = i + 1; m < u; ++m) v += lu_(m, i) * lambda(m);
                lambda(i) -= v;
            }
        }
        for (int j = u - 1; j >= 0; --j) {
            if (pivot_(j) != j) std::swap(lambda(j), lambda(pivot_(j)));
        }
        // d <h, X> / d offset: h, plus lambda_eq times the offsets' weights in equation eq.
        Square phi = h;
        for (int b = 0; b < n; ++b) {
            for (int a = 0; a <= std::min(1, b); ++a) {
                const Scalar l = lambda(basic(a, b));
                if (b >= 2) {
                    const int sb = shift_source(b);
                    for (const int k : nonzero_[a]) phi(k, sb) += l * top_(a, k);
                } else {
                    for (const int m : nonzero_[b]) {
                        for (const int k : nonzero_[a]) phi(k, m) += l * top_(a, k) * top_(b, m);
                    }
                }
            }
        }
        // offset[k, l] = offset[s(k), s(l)] + C[k, l]: accumulate along the chains, children first.
        Square g = Square::Zero(n, n);
        for (int k = n - 1; k >= 2; --k) {
            for (int l = n - 1; l >= 2; --l) {
                g(k, l) += phi(k, l);
                const int sk = shift_source(k), sl = shift_source(l);
                if (sk >= 2 && sl >= 2) g(sk, sl) += g(k, l);
            }
        }
        for (int b = 0; b < n; ++b) {
            for (int a = 0; a <= std::min(1, b); ++a) g(a, b) = lambda(basic(a, b));
        }
        Square sym(n, n);
        for (int l = 0; l < n; ++l) {
            for (int k = 0; k < n; ++k) sym(k, l) = (g(k, l) + g(l, k)) / Scalar(2);
        }
        return sym;
    }

    /// M X M^T for symmetric X, using the shift structure: O(N^2).
    Square propagate(const Square& x) const {
        const int n = n_;
        const Top p = top_times(x);  // rows 0, 1 of M X
        Square y(n, n);
        for (int a = 0; a < 2; ++a) {
            for (int b = 0; b < 2; ++b) {
                Scalar v = 0;
                for (const int m : nonzero_[b]) v += p(a, m) * top_(b, m);
                y(a, b) = v;
            }
        }
        for (int l = 2; l < n; ++l) {
            const int sl = shift_source(l);
            y(0, l) = y(l, 0) = p(0, sl);
            y(1, l) = y(l, 1) = p(1, sl);
            for (int k = 2; k < n; ++k) y(k, l) = x(shift_source(k), sl);
        }
        return y;
    }

    /// M^T X M (the adjoint equation's map), using the shift structure: O(N^2).
    Square transpose_congruence(const Square& x) const {
        const int n = n_;
        Square y(n, n);  // X M: columns 0, 1 of X times the top rows, plus column k >= 2 of X into column s(k)
        for (int j = 0; j < n; ++j) y.col(j) = x.col(0) * top_(0, j) + x.col(1) * top_(1, j);
        for (int k = 2; k < n; ++k) y.col(shift_source(k)) += x.col(k);
        Square z(n, n);  // M^T (X M), the same by rows
        for (int i = 0; i < n; ++i) z.row(i) = top_(0, i) * y.row(0) + top_(1, i) * y.row(1);
        for (int k = 2; k < n; ++k) z.row(shift_source(k)) += y.row(k);
        return z;
    }

  private:
    /// From this many unknowns the triangular solves are Eigen's (vectorised); below, written-out loops. Measured
    /// in standalone builds: the loops 3 % faster for the backward optimum at d = 0, 1 (5 to 7 unknowns) and as fast
    /// at d = 6 (17); Eigen's 3 % faster for the window-15 estimator optimum at d = 1 (35).
    static constexpr int kVectorisedSolveUnknowns = 24;
    using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1, 0, kMaxUnknowns, 1>;
    /// top x (2 x N), the product written out.
    Top top_times(const Square& x) const {
        const int n = n_;
        Top p(2, n);
        for (int l = 0; l < n; ++l) {
            Scalar v0 = 0, v1 = 0;
            for (const int m : nonzero_[0]) v0 += top_(0, m) * x(m, l);
            for (const int m : nonzero_[1]) v1 += top_(1, m) * x(m, l);
            p(0, l) = v0;
            p(1, l) = v1;
        }
        return p;
    }

    /// Index of the unknown X[a, b], a in {0, 1}, a <= b.
    int basic(int a, int b) const { return a == 0 ? b : n_ + b - 1; }

    Top top_;
    /// The columns m where top_(a, m) != 0, ascending: the sums over m above skip the zero terms (v + 0 m = v, so
    /// the results are those of the full sums); an estimator's force row reads few of the history's entries.
    std::array<Eigen::Matrix<int, Eigen::Dynamic, 1, 0, MaxN, 1>, 2> nonzero_;
    int n_;
    bool ok_ = true;
    Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, 0, MaxN, MaxN> ref_;
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, kMaxUnknowns, kMaxUnknowns> lu_;
    Eigen::Matrix<int, Eigen::Dynamic, 1, 0, kMaxUnknowns, 1> pivot_;
};

}  // namespace hapticopt
