// SPDX-License-Identifier: Apache-2.0
// Discrete Lyapunov (Stein) equations X = M X M^T + C for a loop matrix whose rows are either dense or unit
// "shift" rows: row k is e_{s(k)}^T with s(k) < k (a delay line copies one state into the next). The dense
// rows are any others (r of them). This is ShiftSteinSolver (stein_equation.hpp) with any number of dense rows
// at any positions: the loop of estimator_loop.hpp with the low-pass estimator has three (x, x' and the
// filter's newest output v_j) and two shift chains (the measured positions y and the past outputs v).
//
// Method. For shift rows k, l the equation reads X[k, l] = X[s(k), s(l)] + C[k, l]; following the chains down
// to a dense row writes every entry of X as one unknown entry X[a, b] (a dense, any b; the pair (a, b) and (b, a)
// one unknown when both are dense) plus a known sum of C along the chain. The equations of the unknown entries,
//   X[a, b] = sum_m M[a, m] X[m, s(b)] + C[a, b]                    (b a shift row)
//   X[a, b] = sum_{m, l} M[a, m] M[b, l] X[m, l] + C[a, b]          (b dense),
// with every X[m, l] substituted, form a linear system in U = r N - r (r - 1) / 2 unknowns that depends on M
// only: one LU with partial pivoting serves every right-hand side, and its transpose gives the adjoint equation
// L = M^T L M + H (adjoint_solve). No eigen-decomposition; exact elimination, whose error is bounded by eps
// times the condition of the Stein operator, ~1 / (1 - rho^2) (rho = M's spectral radius), as for the complex
// Schur method (Bartels-Stewart / Kitagawa, stein_equation.hpp) it replaces.
// Cost: O(r^2 N^2) assembly, (2/3) U^3 flops for the LU, O(r N^2) per right-hand side; the low-pass loop at
// d = 6 (N = 14, r = 3, U = 39) against the complex Schur form's ~25 N^3 + the triangular solves: measured in
// docs/benchmarks.md (BM_EstimatorOptimumParts).
// The solver does not detect instability by itself (a Schur-stable M gives a non-singular system, the converse
// need not hold): callers decide stability first (Schur-Cohn on the characteristic polynomial).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "closed_loop.hpp"

namespace hapticopt {

/// Solver of X = M X M^T + C and L = M^T L M + H (C, H symmetric) for M with dense and shift rows (header
/// comment). A row is a shift row if it is a unit row e_s^T with s below the row's own index; every other
/// row is dense.
template <typename Scalar>
class RowShiftSteinSolver {
  public:
    using Square = DynamicMatrix<Scalar>;

    /// Classifies M's rows, assembles and factorises the reduced system. ok() is false if a pivot vanished
    /// or is not finite (M has eigenvalues with lambda_i lambda_k = 1, or is not finite).
    explicit RowShiftSteinSolver(const DynamicMatrix<Scalar>& m) : n_(static_cast<int>(m.rows())) {
        const int n = n_;
        source_.assign(static_cast<std::size_t>(n), -1);
        dense_position_.assign(static_cast<std::size_t>(n), -1);
        for (int k = 0; k < n; ++k) {
            int one = -1, nonzero = 0;
            for (int l = 0; l < n; ++l) {
                if (m(k, l) != Scalar(0)) {
                    ++nonzero;
                    if (m(k, l) == Scalar(1)) one = l;
                }
            }
            if (nonzero == 1 && one >= 0 && one < k) {
                source_[static_cast<std::size_t>(k)] = one;
            } else {
                dense_position_[static_cast<std::size_t>(k)] = static_cast<int>(dense_.size());
                dense_.push_back(k);
            }
        }
        const int r = static_cast<int>(dense_.size());
        top_.resize(r, n);
        for (int i = 0; i < r; ++i) top_.row(i) = m.row(dense_[static_cast<std::size_t>(i)]);
        // Unknowns: (a, b) for dense a and any b, except b dense and below a (then it is (b, a)).
        unknown_.resize(r, n);
        pairs_.clear();
        for (int i = 0; i < r; ++i) {
            const int a = dense_[static_cast<std::size_t>(i)];
            for (int b = 0; b < n; ++b) {
                const int j = dense_position_[static_cast<std::size_t>(b)];
                if (j >= 0 && b < a) {
                    unknown_(i, b) = unknown_(j, a);
                } else {
                    unknown_(i, b) = static_cast<int>(pairs_.size());
                    pairs_.emplace_back(i, b);
                }
            }
        }
        ref_.resize(n, n);
        for (int k = 0; k < n; ++k) {
            for (int l = 0; l < n; ++l) ref_(k, l) = reference(k, l);
        }
        const int u = static_cast<int>(pairs_.size());
        lu_.setZero(u, u);
        for (int eq = 0; eq < u; ++eq) {
            const int i = pairs_[static_cast<std::size_t>(eq)].first;
            const int b = pairs_[static_cast<std::size_t>(eq)].second;
            lu_(eq, eq) += Scalar(1);
            const int jb = dense_position_[static_cast<std::size_t>(b)];
            if (jb < 0) {
                const int sb = source_[static_cast<std::size_t>(b)];
                for (int q = 0; q < n; ++q) lu_(eq, ref_(q, sb)) -= top_(i, q);
            } else {
                for (int q = 0; q < n; ++q) {
                    if (top_(i, q) == Scalar(0)) continue;
                    for (int l = 0; l < n; ++l) lu_(eq, ref_(q, l)) -= top_(i, q) * top_(jb, l);
                }
            }
        }
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
            lu_.col(j).tail(rest) *= Scalar(1) / d;
            // The rank-1 update of the trailing block row by row (each entry a - f b, vectorised along the row),
            // skipping the rows whose multiplier f is zero (a - 0 b = a): the reduced system's shift equations
            // hold a few non-zeros each, so before the fill-in most rows have none here.
            for (int i = j + 1; i < u; ++i) {
                const Scalar f = lu_(i, j);
                if (f != Scalar(0)) lu_.row(i).tail(rest) -= f * lu_.row(j).tail(rest);
            }
        }
    }

    bool ok() const { return ok_; }
    int size() const { return n_; }
    int dense_rows() const { return static_cast<int>(dense_.size()); }
    int unknowns() const { return static_cast<int>(pairs_.size()); }

    /// X with X = M X M^T + c (c symmetric; only valid when ok()). O(r N^2).
    Square solve(const Square& c) const {
        const int n = n_;
        const int u = unknowns();
        Square offset(n, n);  // X[k, l] = offset[k, l] + unknown[ref[k, l]]
        for (int k = 0; k < n; ++k) {
            const int sk = source_[static_cast<std::size_t>(k)];
            for (int l = 0; l < n; ++l) {
                const int sl = source_[static_cast<std::size_t>(l)];
                offset(k, l) = (sk < 0 || sl < 0) ? Scalar(0) : offset(sk, sl) + c(k, l);
            }
        }
        const Square p = top_ * offset;  // rows of M offset at the dense rows
        Vector rhs(u);
        for (int eq = 0; eq < u; ++eq) {
            const int i = pairs_[static_cast<std::size_t>(eq)].first;
            const int b = pairs_[static_cast<std::size_t>(eq)].second;
            const int a = dense_[static_cast<std::size_t>(i)];
            const int jb = dense_position_[static_cast<std::size_t>(b)];
            const Scalar v = jb < 0 ? p(i, source_[static_cast<std::size_t>(b)]) : p.row(i).dot(top_.row(jb));
            rhs(eq) = c(a, b) + v;
        }
        for (int j = 0; j < u; ++j) {
            if (pivot_(j) != j) std::swap(rhs(j), rhs(pivot_(j)));
        }
        lu_.template triangularView<Eigen::UnitLower>().solveInPlace(rhs);
        lu_.template triangularView<Eigen::Upper>().solveInPlace(rhs);
        Square x(n, n);
        for (int k = 0; k < n; ++k) {
            for (int l = 0; l < n; ++l) x(k, l) = offset(k, l) + rhs(ref_(k, l));
        }
        return x;
    }

    /// L with L = M^T L M + h (h symmetric; only valid when ok()): the gradient of the linear function
    /// <h, X(C)> of C, by the transposed LU and the reverse of solve()'s substitutions. O(r N^2).
    Square adjoint_solve(const Square& h) const {
        const int n = n_;
        const int u = unknowns();
        Vector lambda = Vector::Zero(u);
        for (int l = 0; l < n; ++l) {
            for (int k = 0; k < n; ++k) lambda(ref_(k, l)) += h(k, l);
        }
        lu_.transpose().template triangularView<Eigen::Lower>().solveInPlace(lambda);
        lu_.transpose().template triangularView<Eigen::UnitUpper>().solveInPlace(lambda);
        for (int j = u - 1; j >= 0; --j) {
            if (pivot_(j) != j) std::swap(lambda(j), lambda(pivot_(j)));
        }
        // d <h, X> / d offset: h, plus lambda_eq times the offsets' weights in equation eq.
        Square phi = h;
        for (int eq = 0; eq < u; ++eq) {
            const int i = pairs_[static_cast<std::size_t>(eq)].first;
            const int b = pairs_[static_cast<std::size_t>(eq)].second;
            const int jb = dense_position_[static_cast<std::size_t>(b)];
            const Scalar l = lambda(eq);
            if (jb < 0) {
                phi.col(source_[static_cast<std::size_t>(b)]) += l * top_.row(i).transpose();
            } else {
                phi.noalias() += (l * top_.row(i).transpose()) * top_.row(jb);
            }
        }
        // offset[k, l] = offset[s(k), s(l)] + C[k, l] along the chains (s(k) < k): children first.
        Square g = Square::Zero(n, n);
        for (int k = n - 1; k >= 0; --k) {
            const int sk = source_[static_cast<std::size_t>(k)];
            if (sk < 0) continue;
            for (int l = n - 1; l >= 0; --l) {
                const int sl = source_[static_cast<std::size_t>(l)];
                if (sl < 0) continue;
                g(k, l) += phi(k, l);
                if (source_[static_cast<std::size_t>(sk)] >= 0 && source_[static_cast<std::size_t>(sl)] >= 0) {
                    g(sk, sl) += g(k, l);
                }
            }
        }
        for (int eq = 0; eq < u; ++eq) {
            const int i = pairs_[static_cast<std::size_t>(eq)].first;
            const int b = pairs_[static_cast<std::size_t>(eq)].second;
            g(dense_[static_cast<std::size_t>(i)], b) = lambda(eq);
        }
        const Square sym = (g + g.transpose()) / Scalar(2);
        return sym;
    }

    /// M X M^T using the row structure: O(r N^2).
    Square propagate(const Square& x) const {
        const Square y = rows_times(x);                        // M X
        return rows_times(Square(y.transpose())).transpose();  // (M (M X)^T)^T = M X M^T
    }

    /// M^T X M using the row structure: O(r N^2).
    Square transpose_congruence(const Square& x) const {
        const Square y = transpose_times(x);  // M^T X
        return transpose_times(Square(y.transpose())).transpose();
    }

  private:
    using Vector = DynamicVector<Scalar>;

    /// M x.
    Square rows_times(const Square& x) const {
        Square y(n_, x.cols());
        for (int k = 0; k < n_; ++k) {
            const int sk = source_[static_cast<std::size_t>(k)];
            if (sk >= 0) {
                y.row(k) = x.row(sk);
            } else {
                y.row(k).noalias() = top_.row(dense_position_[static_cast<std::size_t>(k)]) * x;
            }
        }
        return y;
    }

    /// M^T x.
    Square transpose_times(const Square& x) const {
        Square z = Square::Zero(n_, x.cols());
        for (int k = 0; k < n_; ++k) {
            const int sk = source_[static_cast<std::size_t>(k)];
            if (sk >= 0) {
                z.row(sk) += x.row(k);
            } else {
                z.noalias() += top_.row(dense_position_[static_cast<std::size_t>(k)]).transpose() * x.row(k);
            }
        }
        return z;
    }

    /// The unknown that X[k, l] refers to: pairs with a dense member directly, others along the chains.
    int reference(int k, int l) const {
        const int i = dense_position_[static_cast<std::size_t>(k)];
        if (i >= 0) return unknown_(i, l);
        const int j = dense_position_[static_cast<std::size_t>(l)];
        if (j >= 0) return unknown_(j, k);
        return ref_(source_[static_cast<std::size_t>(k)], source_[static_cast<std::size_t>(l)]);
    }

    int n_;
    bool ok_ = true;
    std::vector<int> source_;          ///< s(k) for a shift row, -1 for a dense row
    std::vector<int> dense_position_;  ///< index into dense_ of a dense row, -1 for a shift row
    std::vector<int> dense_;           ///< the dense rows, ascending
    DynamicMatrix<Scalar> top_;        ///< M's dense rows (r x N)
    Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic> unknown_;  ///< (dense position, column) -> unknown
    std::vector<std::pair<int, int>> pairs_;                      ///< unknown -> (dense position, column)
    Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic> ref_;
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> lu_;
    Eigen::Matrix<int, Eigen::Dynamic, 1> pivot_;
};

}  // namespace hapticopt
