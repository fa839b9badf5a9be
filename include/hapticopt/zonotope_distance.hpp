// SPDX-License-Identifier: Apache-2.0
// The distance from the origin to a zonotope of the complex plane: the value set, at one point of the unit circle, of
// a polynomial whose coefficients are affine in bounded parameters (arm_box_stability.hpp's mean-value exclusion).
// Beyond Hulin et al. 2011.
//
// Z = {c + sum_k t_k g_k : t_k in [-1, 1]} with c, g_k in C (points of R^2) is a centrally symmetric convex polygon
// with at most 2 m vertices (m non-zero generators). With the generators turned into the upper half-plane (g and -g
// give the same set) and sorted by argument in [0, pi), its boundary counter-clockwise is the walk from
// c - sum g_k adding 2 g_k in that order, then subtracting them in the same order (e.g. Ziegler, Lectures on
// Polytopes, 1995, lecture 7: zonotopes as Minkowski sums of segments). The origin lies in Z iff it lies on the left
// of every edge; else the distance is the least distance to an edge.
// Accuracy: each vertex is a sum of at most 2 m + 1 terms, so the result is exact up to ~(2 m + 2) eps (|c| + 2 sum
// |g_k|): the caller adds that to its threshold. Cost: O(m log m), no allocation (m <= kZonotopeMaxGenerators).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstddef>

namespace hapticopt {

inline constexpr std::size_t kZonotopeMaxGenerators = 16;

/// The distance from 0 to {c + sum_k t_k g[k] : |t_k| <= 1} (0 when 0 lies in it), m <= kZonotopeMaxGenerators
/// generators (more: only the first kZonotopeMaxGenerators count, so the caller must not pass more).
inline double zonotope_origin_distance(std::complex<double> c, const std::complex<double>* g, std::size_t m) {
    if (m == 0) return std::sqrt(std::norm(c));
    std::array<std::complex<double>, kZonotopeMaxGenerators> gens{};
    std::size_t count = 0;
    for (std::size_t k = 0; k < m && count < kZonotopeMaxGenerators; ++k) {
        std::complex<double> v = g[k];
        if (v == 0.0) continue;
        if (v.imag() < 0 || (v.imag() == 0 && v.real() < 0)) v = -v;
        gens[count++] = v;
    }
    if (count == 0) return std::sqrt(std::norm(c));
    // By argument in [0, pi): a before b iff b lies counter-clockwise of a (their cross product is positive).
    std::sort(
        gens.begin(), gens.begin() + static_cast<std::ptrdiff_t>(count),
        [](std::complex<double> a, std::complex<double> b) { return a.real() * b.imag() - a.imag() * b.real() > 0; });
    std::complex<double> v = c;
    for (std::size_t k = 0; k < count; ++k) v -= gens[k];
    bool inside = true;
    double distance = std::sqrt(std::norm(v));
    for (int pass = 0; pass < 2; ++pass) {
        for (std::size_t k = 0; k < count; ++k) {
            const std::complex<double> e = (pass == 0 ? 2.0 : -2.0) * gens[k];
            // The origin relative to the edge from v to v + e: on its left iff cross(e, -v) >= 0.
            const double cross = e.real() * (-v.imag()) - e.imag() * (-v.real());
            if (cross < 0) inside = false;
            const double along = std::clamp(-(v.real() * e.real() + v.imag() * e.imag()) / std::norm(e), 0.0, 1.0);
            distance = std::min(distance, std::sqrt(std::norm(v + along * e)));
            v += e;
        }
    }
    return inside ? 0.0 : distance;
}

}  // namespace hapticopt
