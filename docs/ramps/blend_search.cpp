// SPDX-License-Identifier: Apache-2.0
// The random search of docs/protocol.md, section 5 ("The ramps"): 3-axis scenes of 0-2 planes ("rest", stable
// alone) plus an old and a new plane, both endpoint scenes stable by hapticopt::matrix_gain_stability; counts
// the linear blends rest + (1-s) old + s new (s = k/30) and ramp-ins rest + s new that are not certifiably stable.
// Build and run: g++ -O2 -std=c++20 -Iinclude -I/usr/include/eigen3 docs/ramps/blend_search.cpp -o /tmp/blend_search &&
// /tmp/blend_search
#include <hapticopt/hapticopt.hpp>
#include <cstdio>
#include <random>
#include <vector>
using namespace hapticopt;
int main() {
    setvbuf(stdout, nullptr, _IONBF, 0);
    std::mt19937_64 rng(3);
    std::normal_distribution<double> N(0, 1);
    std::uniform_real_distribution<double> U(0, 1);
    for (double d : {0.0, 1.0, 3.0}) {
        NormalizedPlant p{0.0, 0.0, d};
        double amax = 0, bmin = 1e9, bmax = -1e9;
        for (int i = 0; i <= 100; ++i)
            for (int j = 0; j <= 100; ++j) {
                NormalizedGains g{1.0 * i / 100.0, -0.5 + 2.5 * j / 100.0};
                if (g.alpha > 0 && is_stable(p, g)) {
                    amax = std::max(amax, g.alpha);
                    bmin = std::min(bmin, g.beta);
                    bmax = std::max(bmax, g.beta);
                }
            }
        std::uniform_real_distribution<double> A(0.0, amax), Bt(bmin, bmax);
        auto plane = [&](Eigen::MatrixXd& K, Eigen::MatrixXd& B) {
            Eigen::Vector3d n(N(rng), N(rng), N(rng));
            n.normalize();
            double a = A(rng), b = Bt(rng);
            K = a * n * n.transpose();
            B = b * n * n.transpose();
        };
        long pairs = 0, bad = 0, badramp = 0, tried = 0;
        while (pairs < 3000 && tried < 300000) {
            ++tried;
            Eigen::MatrixXd Kr = Eigen::MatrixXd::Zero(3, 3), Br = Kr, Ko, Bo, Kn, Bn, k, b;
            int nrest = static_cast<int>(U(rng) * 3);
            for (int r = 0; r < nrest; ++r) {
                plane(k, b);
                Kr += k;
                Br += b;
            }
            plane(Ko, Bo);
            plane(Kn, Bn);
            if (nrest > 0 && !matrix_gain_stability(p, Kr, Br).stable) continue;
            if (!matrix_gain_stability(p, Kr + Ko, Br + Bo).stable) continue;
            if (!matrix_gain_stability(p, Kr + Kn, Br + Bn).stable) continue;
            ++pairs;
            for (int s30 = 1; s30 < 30; ++s30) {
                double s = s30 / 30.0;
                auto r = matrix_gain_stability(p, Kr + (1 - s) * Ko + s * Kn, Br + (1 - s) * Bo + s * Bn);
                if (!r.stable) {
                    ++bad;
                    if (r.spectral_radius > 1.0)
                        std::printf("  d=%g blend unstable s=%g radius %.9f (rest %d)\n", d, s, r.spectral_radius,
                                    nrest);
                    break;
                }
            }
            for (int s30 = 1; s30 < 30; ++s30) {
                double s = s30 / 30.0;
                auto r = matrix_gain_stability(p, Kr + s * Kn, Br + s * Bn);
                if (!r.stable && nrest > 0) {
                    ++badramp;
                    if (r.spectral_radius > 1.0)
                        std::printf("  d=%g ramp-in unstable s=%g radius %.9f\n", d, s, r.spectral_radius);
                    break;
                }
            }
        }
        std::printf(
            "d=%g: %ld stable endpoint pairs (of %ld tried); unstable blends %ld; unstable ramp-ins (rest>0) %ld\n", d,
            pairs, tried, bad, badramp);
    }
}
