// SPDX-License-Identifier: Apache-2.0
// Independent references for the mesh tests, written without src/mesh's code: brute force over every triangle
// (barycentric coordinates, Moller-Trumbore rays), the closest point on intersected half-spaces by
// enumeration with Eigen's complete orthogonal decomposition, an inside test by ray parity, and random meshes (bumpy
// spheres, height fields).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "mesh/procedural_meshes.hpp"
#include "mesh/triangle_mesh.hpp"

namespace hapticd::mesh::reference {

struct Face {
    Eigen::Vector3d a, b, c, normal;
};

inline std::vector<Face> faces(const TriangleMesh& m) {
    std::vector<Face> f;
    for (const auto& t : m.triangles) {
        Face x{m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], {}};
        x.normal = (x.b - x.a).cross(x.c - x.a).normalized();
        f.push_back(x);
    }
    return f;
}

// Barycentric coordinates (u, v, w) of x's projection on the face's plane (x = u a + v b + w c).
inline Eigen::Vector3d barycentric(const Face& f, const Eigen::Vector3d& x) {
    const Eigen::Vector3d e0 = f.b - f.a, e1 = f.c - f.a, r = x - f.a;
    const double d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1), d20 = r.dot(e0), d21 = r.dot(e1);
    const double det = d00 * d11 - d01 * d01;
    const double v = (d11 * d20 - d01 * d21) / det;
    const double w = (d00 * d21 - d01 * d20) / det;
    return {1.0 - v - w, v, w};
}

// Distance from x to the closed triangle (the three edges' segments when the projection is outside).
inline double distance_to_face(const Face& f, const Eigen::Vector3d& x) {
    const Eigen::Vector3d bc = barycentric(f, x);
    if (bc.minCoeff() >= 0.0) return std::abs(f.normal.dot(x - f.a));
    const auto segment = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
        const double s = std::clamp((x - p).dot(q - p) / (q - p).squaredNorm(), 0.0, 1.0);
        return (p + s * (q - p) - x).norm();
    };
    return std::min({segment(f.a, f.b), segment(f.b, f.c), segment(f.c, f.a)});
}

// Moller-Trumbore: the ray x + t dir (t > 0) meets the face.
inline bool ray_meets(const Face& f, const Eigen::Vector3d& x, const Eigen::Vector3d& dir) {
    const Eigen::Vector3d e1 = f.b - f.a, e2 = f.c - f.a;
    const Eigen::Vector3d pv = dir.cross(e2);
    const double det = e1.dot(pv);
    if (std::abs(det) < 1e-300) return false;
    const Eigen::Vector3d tv = x - f.a;
    const double u = tv.dot(pv) / det;
    if (u < 0.0 || u > 1.0) return false;
    const Eigen::Vector3d qv = tv.cross(e1);
    const double v = dir.dot(qv) / det;
    if (v < 0.0 || u + v > 1.0) return false;
    return e2.dot(qv) / det > 0.0;
}

// Inside a closed mesh: the majority of three rays in fixed generic directions cross it an odd number of times.
inline bool inside_by_ray_parity(const std::vector<Face>& f, const Eigen::Vector3d& x) {
    static const Eigen::Vector3d dirs[3] = {Eigen::Vector3d(0.5773, 0.3141, 0.7541).normalized(),
                                            Eigen::Vector3d(-0.2718, 0.8284, -0.4142).normalized(),
                                            Eigen::Vector3d(0.1732, -0.6931, -0.2236).normalized()};
    int odd = 0;
    for (const auto& d : dirs) {
        int crossings = 0;
        for (const auto& face : f) crossings += ray_meets(face, x, d) ? 1 : 0;
        odd += crossings % 2;
    }
    return odd >= 2;
}

struct HalfSpace {
    Eigen::Vector3d normal;  // unit
    double offset;           // normal . x >= offset
};

// The point closest to h in the intersection of the half-spaces, by brute force: the minimiser is the
// projection of h on the planes of some subset of at most three of them (the face of the feasible polyhedron it
// lies in), so it is the feasible one of those projections nearest h. Each projection is the minimum-norm
// solution of (N N^T) lambda = c - N h by a complete orthogonal decomposition (dependent planes allowed).
inline Eigen::Vector3d closest_feasible_point(const std::vector<HalfSpace>& s, const Eigen::Vector3d& h) {
    const int n = static_cast<int>(s.size());
    const auto feasible = [&](const Eigen::Vector3d& x) {
        for (const auto& hs : s)
            if (hs.normal.dot(x) < hs.offset - 1e-11) return false;
        return true;
    };
    Eigen::Vector3d best = h;
    double best_distance = feasible(h) ? 0.0 : HUGE_VAL;
    std::vector<int> subset;
    for (int a = 0; a < n; ++a)
        for (int b = a; b < n; ++b)
            for (int c = b; c < n; ++c) {
                subset = {a};
                if (b != a) subset.push_back(b);
                if (c != b) subset.push_back(c);
                if (b == a && c != b) continue;  // each subset once: {a}, {a, b}, {a, b, c}
                const int k = static_cast<int>(subset.size());
                Eigen::MatrixXd N(k, 3);
                Eigen::VectorXd r(k);
                for (int i = 0; i < k; ++i) {
                    N.row(i) = s[subset[i]].normal.transpose();
                    r[i] = s[subset[i]].offset - s[subset[i]].normal.dot(h);
                }
                const Eigen::VectorXd lambda = (N * N.transpose()).completeOrthogonalDecomposition().solve(r);
                const Eigen::Vector3d x = h + N.transpose() * lambda;
                if ((N * x - (r + N * h)).cwiseAbs().maxCoeff() > 1e-11) continue;  // inconsistent planes
                if (feasible(x) && (x - h).norm() < best_distance) {
                    best = x;
                    best_distance = (x - h).norm();
                }
            }
    return best;
}

// The faces the point rests on: within `reach` of the face, and between `lowest` and the offset (+ 1e-9 m) in
// front of its plane (on the plane moved out by the offset, or, for the further triangles of a vertex shared by
// more than three, a little below it).
inline std::vector<HalfSpace> resting_planes(const std::vector<Face>& f, const Eigen::Vector3d& p, double offset,
                                             double reach, double lowest) {
    std::vector<HalfSpace> out;
    for (const auto& face : f) {
        const double level = face.normal.dot(p - face.a);
        if (level >= lowest && level <= offset + 1e-9 && distance_to_face(face, p) <= offset + reach) {
            out.push_back({face.normal, face.normal.dot(face.a) + offset});
        }
    }
    return out;
}

// A star-shaped closed mesh: an icosphere whose vertices' radii are scaled by 1 + amplitude * U(-1, 1).
inline TriangleMesh bumpy_sphere(double radius, int subdivisions, double amplitude, std::mt19937_64& rng) {
    TriangleMesh m = icosphere(radius, subdivisions);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (auto& v : m.vertices) v *= 1.0 + amplitude * u(rng);
    return m;
}

// An open surface facing +z: z = bumps(x, y) on an n x n grid over [-half, half]^2.
inline TriangleMesh height_field(double half, int n, double amplitude, std::mt19937_64& rng) {
    TriangleMesh m;
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j)
            m.vertices.emplace_back(-half + 2.0 * half * i / n, -half + 2.0 * half * j / n, amplitude * u(rng));
    const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(i * (n + 1) + j); };
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return m;
}

// The height of the height field's surface above (x, y): the face whose projection on z = 0 holds the point.
inline double surface_height(const std::vector<Face>& f, double x, double y) {
    for (const auto& face : f) {
        const Eigen::Vector3d q(x, y, 0.0);
        Face flat = face;
        flat.a.z() = flat.b.z() = flat.c.z() = 0.0;
        flat.normal = Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d bc = barycentric(flat, q);
        if (bc.minCoeff() >= -1e-12) return bc[0] * face.a.z() + bc[1] * face.b.z() + bc[2] * face.c.z();
    }
    return -HUGE_VAL;
}

}  // namespace hapticd::mesh::reference
