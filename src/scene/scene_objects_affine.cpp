// SPDX-License-Identifier: Apache-2.0
// SceneObjects' affine laws (scene_objects.hpp, "Linear part, in closed form"): each linear object's term
// w (c_i - K_i x - B_i v), their sum, and its constant term kept exact under moves by a compensated sum (TwoSum).
#include "scene/scene_objects.hpp"

#include <cmath>

#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;
using scene_objects_detail::norm1;

namespace {

// Knuth's TwoSum (TAOCP vol. 2, section 4.2.2, theorem B): s = fl(a + b) and the exact error e, a + b = s + e.
// 6 flops, exact in any rounding-to-nearest arithmetic without reassociation.
void two_sum(double a, double b, double& s, double& e) noexcept {
    s = a + b;
    const double bv = s - a;
    e = (a - (s - bv)) + (b - bv);
}

}  // namespace

// A moved entry's constant term replaced in its law's running sum: sum - before + after, each step by
// TwoSum with the errors kept in carry, so that c = sum + carry is the exact sum of the entries' terms up to
// eps |c| + (moves + 1) eps^2 (sum of the terms' magnitudes) — a compensated sum (Neumaier 1974, Higham 2002
// section 4.3): a client moving a proxy every tick for days drifts by nothing that matters, without a
// re-sum of the n entries (whose chain of additions cost ~70 ns for 64 entries).
void SceneObjects::replace_constant(AffineLaw& l, AxisVector& stored, const AxisVector& now) noexcept {
    for (std::size_t a = 0; a < 3; ++a) {
        double s1 = 0.0, e1 = 0.0, s2 = 0.0, e2 = 0.0;
        two_sum(l.sum[a], -stored[a], s1, e1);
        two_sum(s1, now[a], s2, e2);
        l.sum[a] = s2;
        l.carry[a] += e1 + e2;
        l.c[a] = l.sum[a] + l.carry[a];
    }
    stored = now;
}

void SceneObjects::start_constants(AffineLaw& l, const Members& m) const noexcept {
    l.sum = sum_constants(m);
    l.carry = AxisVector{};
    l.c = l.sum;
}

// The members' constant terms summed in four partial sums (entries i = 0, 1, 2, 3 mod 4), then
// (s0 + s1) + (s2 + s3): four independent chains of additions instead of one (a classification's sum).
// Rounding: at most (n / 4 + 2) eps times the sum of the magnitudes (Higham 2002, section 4.2), within the
// bound of recursive summation.
AxisVector SceneObjects::sum_constants(const Members& m) const noexcept {
    double s[4][3] = {};
    std::size_t i = 0;
    for (; i + 4 <= m.count; i += 4) {
        for (std::size_t j = 0; j < 4; ++j) {
            const AxisVector& c = entry_c_[m.entry[i + j]];
            s[j][0] += c[0];
            s[j][1] += c[1];
            s[j][2] += c[2];
        }
    }
    for (std::size_t j = 0; i < m.count; ++i, ++j) {
        const AxisVector& c = entry_c_[m.entry[i]];
        s[j][0] += c[0];
        s[j][1] += c[1];
        s[j][2] += c[2];
    }
    return {(s[0][0] + s[1][0]) + (s[2][0] + s[3][0]), (s[0][1] + s[1][1]) + (s[2][1] + s[3][1]),
            (s[0][2] + s[1][2]) + (s[2][2] + s[3][2])};
}

// One linear object's term w (c_i - K_i x - B_i v) of the affine law:
//   plane (bilateral), spring to a plane:  K_i = k u u^T,       B_i = b u u^T,       c_i = k u (u.point)
//   spring to a line (direction u):        K_i = k (I - u u^T), B_i = b (I - u u^T), c_i = k (point - u (u.point))
//   spring to a point:                     K_i = k I,           B_i = b I,           c_i = k point
//   field, handle inside:                  K_i = -J,            B_i = b I,           c_i = F0 - J x0
// (a plane's u.point is its offset). With the ramp factor r the stiffness terms are weighted r^2, the
// damping and a field's constant force r (ramp_weights): add_linear adds r^2 K_i and r B_i;
// linear_constant gives r^2 k (..) or r F0 - r^2 J x0.
void SceneObjects::add_linear(AffineLaw& l, const ObjectParams& p, double r) noexcept {
    const double w = r * r;  // the stiffness weight
    const double wk = w * p.K, wb = r * p.B;
    const AxisVector& u = p.direction;
    l.any = true;
    if (p.kind == ObjectKind::Field) {
        for (std::size_t r = 0; r < 3; ++r) {
            for (std::size_t c = 0; c < 3; ++c) l.K[r][c] -= w * p.jacobian[r][c];
            l.B[r][r] += wb;
        }
        return;
    }
    // A mesh counts as what the server checks it as: a spring of K and a damper of B in every direction.
    if ((p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Point) || p.kind == ObjectKind::Mesh) {
        for (std::size_t r = 0; r < 3; ++r) {
            l.K[r][r] += wk;
            l.B[r][r] += wb;
        }
        return;
    }
    if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Line) {  // I - u u^T
        for (std::size_t r = 0; r < 3; ++r) {
            for (std::size_t c = 0; c < 3; ++c) {
                const double P = (r == c ? 1.0 : 0.0) - u[r] * u[c];
                l.K[r][c] += wk * P;
                l.B[r][c] += wb * P;
            }
        }
        return;
    }
    for (std::size_t r = 0; r < 3; ++r) {  // u u^T
        const double kr = wk * u[r], br = wb * u[r];
        for (std::size_t c = 0; c < 3; ++c) {
            l.K[r][c] += kr * u[c];
            l.B[r][c] += br * u[c];
        }
    }
}

AxisVector SceneObjects::linear_constant(const ObjectParams& p, double ramp) noexcept {
    AxisVector c{};
    const double w = ramp * ramp;  // the stiffness weight
    const double wk = w * p.K;
    const AxisVector& u = p.direction;
    if (p.kind == ObjectKind::Field) {
        for (std::size_t r = 0; r < 3; ++r) c[r] = ramp * p.force[r] - w * dot(p.jacobian[r], p.point);
    } else if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Point) {
        for (std::size_t r = 0; r < 3; ++r) c[r] = wk * p.point[r];
    } else {
        const double up = p.kind == ObjectKind::Plane ? p.offset : dot(u, p.point);
        const bool line = p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Line;
        for (std::size_t r = 0; r < 3; ++r) c[r] = line ? wk * (p.point[r] - u[r] * up) : wk * u[r] * up;
    }
    // The damping relative to the object's motion: + r B (the rate in the damped directions).
    const double wb = ramp * p.B;
    if (p.kind == ObjectKind::Plane) {
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * p.offset_rate * u[r];
    } else if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Plane) {
        const double ur = dot(u, p.point_rate);
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * ur * u[r];
    } else if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Line) {
        const double ur = dot(u, p.point_rate);
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * (p.point_rate[r] - u[r] * ur);
    } else {
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * p.point_rate[r];
    }
    return c;
}

}  // namespace hapticd
