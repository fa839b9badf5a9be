// SPDX-License-Identifier: Apache-2.0
// Enclosures of the plant's matrix exponential and of its derivatives over a box of plants, by interval arithmetic:
// what arm_box_stability.hpp's zero exclusion bounds the plant's discrete coefficients with. Beyond Hulin et al. 2011.
//
// The matrix. A = [[0, 1, 0], [-gamma, -delta, -1], [0, 0, 0]] (sampled_plant.hpp: state (x, v) and the held force)
// and M = A t, with gamma, delta and t intervals.
//
// exp(M) for every point matrix of an interval matrix M (N x N): scaling M / 2^j with |M / 2^j|_inf <= 1/2, the Taylor
// series to degree 20 in Horner form, I + M (I + M/2 (I + ... (I + M/20))), its remainder |R|_inf <= 2 mu^21 / 21!
// (mu <= 1/2 the scaled norm; the tail sum_{k > 20} mu^k / k! <= 2 mu^21 / 21!) added to every entry, and j
// squarings; the result widened by 64 (20 + 2^j) eps times its largest entry (at least 1) for the rounding of the
// operations, which interval arithmetic here does not direct.
//
// Derivatives (Van Loan, "Computing integrals involving the matrix exponential", IEEE TAC 23(3), 1978, Theorem 1;
// Najfeld and Havel, Adv. Appl. Math. 16 (1995) 321-375): for a matrix family M(x),
//
//   exp([[M, E], [0, M]]) = [[exp(M), L(M, E)], [0, exp(M)]],   L(M, E) = d/de exp(M + e E) at e = 0,
//
// so with E = dM/dx the upper right block of the 6 x 6 block matrix's exponential is d exp(M(x)) / dx. The interval
// exponential of the block matrix (the same method, N = 6) encloses it for every point of the box. For t = 1 - phi,
// d exp(A (1 - phi)) / dphi = -A exp(A (1 - phi)) (an interval product).
//
// DualInterval carries a value and its three partial derivatives (gamma_H, delta_H, phi), each an interval: the
// forward mode of differentiation over intervals, so that a polynomial expression of the exponentials' entries
// (arm_box_stability.hpp's coefficients) yields enclosures of its value and of its gradient over the box.
// Cost: N^3 (20 + 2 j) interval products per exponential (N = 3 or 6). Not for the real-time loop.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

namespace hapticopt {
namespace detail {

/// A closed interval of reals; arithmetic encloses every result of its operands (up to rounding: the caller widens).
struct Interval {
    double lo = 0, hi = 0;
    Interval() = default;
    Interval(double v) : lo(v), hi(v) {}  // NOLINT: a point is an interval
    Interval(double l, double h) : lo(l), hi(h) {}
    double magnitude() const { return std::max(std::abs(lo), std::abs(hi)); }
    double mid() const { return 0.5 * (lo + hi); }
    /// The largest distance from mid() to an end.
    double radius() const { return std::max(hi - mid(), mid() - lo); }
};
inline Interval operator+(Interval a, Interval b) { return {a.lo + b.lo, a.hi + b.hi}; }
inline Interval operator-(Interval a, Interval b) { return {a.lo - b.hi, a.hi - b.lo}; }
inline Interval operator-(Interval a) { return {-a.hi, -a.lo}; }
inline Interval operator*(Interval a, Interval b) {
    const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
    return {*std::min_element(p, p + 4), *std::max_element(p, p + 4)};
}
inline Interval widened(Interval a, double w) { return {a.lo - w, a.hi + w}; }

template <std::size_t N>
using IntervalMatrix = std::array<std::array<Interval, N>, N>;
using IntervalMatrix3 = IntervalMatrix<3>;

template <std::size_t N>
IntervalMatrix<N> interval_product(const IntervalMatrix<N>& a, const IntervalMatrix<N>& b) {
    IntervalMatrix<N> c{};
    for (std::size_t i = 0; i < N; ++i) {
        for (std::size_t j = 0; j < N; ++j) {
            Interval s(0.0);
            for (std::size_t k = 0; k < N; ++k) s = s + a[i][k] * b[k][j];
            c[i][j] = s;
        }
    }
    return c;
}

/// An enclosure of exp(M) for every point matrix of M (header comment).
template <std::size_t N>
IntervalMatrix<N> interval_exponential(IntervalMatrix<N> m) {
    double norm = 0;
    for (const auto& row : m) {
        double sum = 0;
        for (const Interval& e : row) sum += e.magnitude();
        norm = std::max(norm, sum);
    }
    int squarings = 0;
    if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
    const double scale = std::ldexp(1.0, -squarings);
    for (auto& row : m) {
        for (auto& e : row) e = Interval(e.lo * scale, e.hi * scale);
    }
    const double mu = norm * scale;
    constexpr int kDegree = 20;
    IntervalMatrix<N> result{};
    for (std::size_t i = 0; i < N; ++i) {
        for (std::size_t j = 0; j < N; ++j) result[i][j] = Interval(i == j ? 1.0 : 0.0);
    }
    for (int k = kDegree; k >= 1; --k) {
        IntervalMatrix<N> next = interval_product(m, result);
        for (std::size_t i = 0; i < N; ++i) {
            for (std::size_t j = 0; j < N; ++j) {
                next[i][j] = Interval(next[i][j].lo / k, next[i][j].hi / k) + Interval(i == j ? 1.0 : 0.0);
            }
        }
        result = next;
    }
    double remainder = 2.0;  // 2 mu^21 / 21!, mu <= 1/2: the series' tail in the infinity norm bounds every entry
    for (int k = 1; k <= kDegree + 1; ++k) remainder *= mu / k;
    for (auto& row : result) {
        for (auto& e : row) e = widened(e, remainder);
    }
    for (int i = 0; i < squarings; ++i) result = interval_product(result, result);
    double largest = 0;
    for (const auto& row : result) {
        for (const auto& e : row) largest = std::max(largest, e.magnitude());
    }
    const double rounding =
        64.0 * (kDegree + std::ldexp(1.0, squarings)) * std::numeric_limits<double>::epsilon() * std::max(largest, 1.0);
    for (auto& row : result) {
        for (auto& e : row) e = widened(e, rounding);
    }
    return result;
}

/// The interval matrix A t of the plant (header comment).
inline IntervalMatrix3 plant_interval_matrix(Interval gamma, Interval delta, Interval t) {
    IntervalMatrix3 m{};
    for (auto& row : m) row.fill(Interval(0.0));
    m[0][1] = t;
    m[1][0] = -(gamma * t);
    m[1][1] = -(delta * t);
    m[1][2] = -t;
    return m;
}

/// An enclosure of exp(A t) for every gamma, delta, t of the intervals.
inline IntervalMatrix3 interval_exponential(Interval gamma, Interval delta, Interval t) {
    return interval_exponential<3>(plant_interval_matrix(gamma, delta, t));
}

/// Enclosures of d exp(A t) / dgamma and d exp(A t) / ddelta over the intervals (header comment: the block matrix
/// [[A t, E t], [0, A t]] with E = dA/dgamma = -e_1 e_0^T, dA/ddelta = -e_1 e_1^T).
inline std::array<IntervalMatrix3, 2> interval_exponential_derivatives(Interval gamma, Interval delta, Interval t) {
    const IntervalMatrix3 m = plant_interval_matrix(gamma, delta, t);
    std::array<IntervalMatrix3, 2> out{};
    for (std::size_t x = 0; x < 2; ++x) {
        IntervalMatrix<6> block{};
        for (auto& row : block) row.fill(Interval(0.0));
        for (std::size_t i = 0; i < 3; ++i) {
            for (std::size_t j = 0; j < 3; ++j) block[i][j] = block[i + 3][j + 3] = m[i][j];
        }
        block[1][3 + x] = -t;  // E t: row 1 (the velocity's), column gamma -> 0, delta -> 1
        const IntervalMatrix<6> e = interval_exponential<6>(block);
        for (std::size_t i = 0; i < 3; ++i) {
            for (std::size_t j = 0; j < 3; ++j) out[x][i][j] = e[i][j + 3];
        }
    }
    return out;
}

/// A value and its partial derivatives along (gamma_H, delta_H, phi), each an interval (header comment).
struct DualInterval {
    Interval v;
    std::array<Interval, 3> d{};
    DualInterval() = default;
    DualInterval(double c) : v(c) {}  // NOLINT: a constant
    DualInterval(Interval value, std::array<Interval, 3> derivative) : v(value), d(derivative) {}
};
inline DualInterval operator+(const DualInterval& a, const DualInterval& b) {
    return {a.v + b.v, {a.d[0] + b.d[0], a.d[1] + b.d[1], a.d[2] + b.d[2]}};
}
inline DualInterval operator-(const DualInterval& a, const DualInterval& b) {
    return {a.v - b.v, {a.d[0] - b.d[0], a.d[1] - b.d[1], a.d[2] - b.d[2]}};
}
inline DualInterval operator-(const DualInterval& a) { return {-a.v, {-a.d[0], -a.d[1], -a.d[2]}}; }
inline DualInterval operator*(const DualInterval& a, const DualInterval& b) {
    return {a.v * b.v, {a.d[0] * b.v + a.v * b.d[0], a.d[1] * b.v + a.v * b.d[1], a.d[2] * b.v + a.v * b.d[2]}};
}

}  // namespace detail
}  // namespace hapticopt
