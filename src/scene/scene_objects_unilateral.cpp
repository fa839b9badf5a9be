// SPDX-License-Identifier: Apache-2.0
// SceneObjects' unilateral planes evaluated one by one (scene_objects.hpp, "Near or nonlinear objects"): four
// planes at a time in the lanes of a vector, branch-free.
#include "scene/scene_objects.hpp"

#include <cstring>

namespace hapticd {

// f += sum_i max(k_i p_i - b_i n_i.v, 0) n_i over the planes with p_i = offset_i - n_i.x > 0, mask |= their
// slots' bits. Four planes at a time in the lanes of a 4-double vector (GCC's vector extension: two SSE2
// registers on baseline x86-64, one AVX2 register in the avx2 clone chosen at load time), with the clamp and
// the contact test as lane masks, not branches: the flags of planes the handle moves across flip from tick
// to tick and a branch on them mispredicts; the flags are each lane's slot bit ANDed with its contact mask
// and ORed across lanes once at the end (a shift per lane took about a third of the loop's samples in
// perf). The lists are padded with zero planes to a multiple of four (pen = 0: no contact, no force). Each lane is its
// own partial sum, added (l0 + l1) + (l2 + l3) at the end. Rounding: at most (n / 4 + 2) eps of the magnitudes (Higham
// 2002, section 4.2).
namespace {
using Lanes = double __attribute__((vector_size(32)));
using LaneMask = std::int64_t __attribute__((vector_size(32)));
// Into a reference, not returned: a 32-byte vector return value has another ABI with AVX than without.
void load_lanes(Lanes& r, const double* p) noexcept { std::memcpy(&r, p, sizeof r); }
}  // namespace

// The sanitizers' runtimes are not set up when an ifunc resolver runs (at load time), so a TSan binary
// with target_clones crashed before main: sanitizer builds take the baseline version only.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
#define HAPTICD_UNILATERAL_CLONES
#else
#define HAPTICD_UNILATERAL_CLONES __attribute__((target_clones("avx2", "default")))
#endif
HAPTICD_UNILATERAL_CLONES
void SceneObjects::add_unilateral(const NearPlanes& n, const double (&x)[3], const double (&v)[3], double (&f)[3],
                                  std::uint64_t& mask) noexcept {
    const double x0 = x[0], x1 = x[1], x2 = x[2], v0 = v[0], v1 = v[1], v2 = v[2];
    Lanes a0{}, a1{}, a2{};
    LaneMask m{};
    for (std::size_t i = 0; i < n.count; i += 4) {
        Lanes nx, ny, nz, offset, K, B, rate;
        LaneMask bits;
        load_lanes(nx, &n.nx[i]);
        load_lanes(ny, &n.ny[i]);
        load_lanes(nz, &n.nz[i]);
        load_lanes(offset, &n.offset[i]);
        load_lanes(K, &n.K[i]);
        load_lanes(B, &n.B[i]);
        load_lanes(rate, &n.rate[i]);
        std::memcpy(&bits, &n.slot_bit[i], sizeof bits);
        const Lanes pen = offset - (nx * x0 + ny * x1 + nz * x2);
        const Lanes vn = nx * v0 + ny * v1 + nz * v2 - rate;  // relative to the surface's motion
        const Lanes fn = K * pen - B * vn;
        const LaneMask contact = pen > 0.0;
        const LaneMask keep = contact & (fn > 0.0);  // unilateral: never pulls
        const Lanes s = reinterpret_cast<Lanes>(reinterpret_cast<LaneMask>(fn) & keep);
        a0 += s * nx;
        a1 += s * ny;
        a2 += s * nz;
        m |= contact & bits;  // a lane's contact mask is all ones or all zeros
    }
    f[0] += (a0[0] + a0[1]) + (a0[2] + a0[3]);
    f[1] += (a1[0] + a1[1]) + (a1[2] + a1[3]);
    f[2] += (a2[0] + a2[1]) + (a2[2] + a2[3]);
    mask |= static_cast<std::uint64_t>((m[0] | m[1]) | (m[2] | m[3]));
}

}  // namespace hapticd
