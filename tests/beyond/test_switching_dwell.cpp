// SPDX-License-Identifier: Apache-2.0
// The dwell certificate for switching gains and plants (switching_dwell.hpp, switching_loop.hpp), checked against:
//  * the loop of estimator_loop.hpp (the switching loop's spectral radius is the rendered loop's);
//  * an independent time-stepping simulation in physical units whose gains and plant change from tick to tick
//    (tests/common/switched_loop_simulation.hpp): the matrix products reproduce it across switches, random switching
//    sequences that respect the dwell decay within the theorem's bound, and two stable walls switched every 3 ticks
//    diverge (the dwell is needed);
//  * the powers of each mode computed one by one (the slower method): ||A^n||_2 <= M lambda^n for every n computed.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <hapticopt/estimator_stability.hpp>
#include <hapticopt/switching_dwell.hpp>
#include <hapticopt/switching_loop.hpp>
#include <random>
#include <vector>

#include "common/switched_loop_simulation.hpp"

namespace switching_dwell_test {

using hapticopt::DynamicMatrix;
using hapticopt::NormalizedPlant;
using hapticopt::SampledPlant;
using hapticopt::VelocityEstimator;
using Tick = switched_loop_simulation::Tick;

constexpr double kPeriod = 1e-3;
constexpr double kReferenceMass = 0.30;

// The shipped Falcon profile's loop (window 15, 6 ms) and its plant set (docs/robust-stability.md): the masses
// 0.200 .. 0.330 kg with 0.22 and 0.30 kg and the centre, each with the arm's corners (k_H / m in {0, 1000} s^-2,
// b_H / m in {0, 20} s^-1); the gains: the CE2 optimum for 0.30 kg (K 378.3 N/m, B 15.49 N s/m, the daemon's tuning
// line) and the same optimum for 0.22 kg (the normalised optimum is the mass's: K and B scaled by 0.22 / 0.30).
struct Family {
    std::vector<Tick> modes;
    std::vector<DynamicMatrix<double>> matrices;
};

DynamicMatrix<double> matrix_of(const Tick& t, const VelocityEstimator& e, double delay) {
    const NormalizedPlant plant{t.arm_stiffness * kPeriod * kPeriod / t.mass, t.arm_damping * kPeriod / t.mass, delay};
    return hapticopt::make_switching_loop(SampledPlant<double>(plant), e,
                                          t.stiffness * kPeriod * kPeriod / kReferenceMass,
                                          t.damping * kPeriod / kReferenceMass, kReferenceMass / t.mass);
}

Family falcon_family() {
    Family f;
    const double gripped_k = 378.3, gripped_b = 15.49;
    for (double m : {0.20, 0.22, 0.26, 0.30, 0.33}) {
        for (double k_per_m : {0.0, 1000.0}) {
            for (double b_per_m : {0.0, 20.0}) {
                for (double scale : {1.0, 0.22 / 0.30}) {
                    f.modes.push_back(Tick{gripped_k * scale, gripped_b * scale, m, k_per_m * m, b_per_m * m});
                    f.matrices.push_back(matrix_of(f.modes.back(), VelocityEstimator::moving_window(15), 6.0));
                }
            }
        }
    }
    return f;
}

// A random schedule: blocks of one mode each, lengths uniform in [shortest, longest].
std::vector<int> random_schedule(std::mt19937& rng, int modes, int blocks, int shortest, int longest) {
    std::uniform_int_distribution<int> pick(0, modes - 1), length(shortest, longest);
    std::vector<int> out;
    for (int b = 0; b < blocks; ++b) {
        const int mode = pick(rng), n = length(rng);
        out.insert(out.end(), static_cast<std::size_t>(n), mode);
    }
    return out;
}

// ||P||_2 as the square root of the largest eigenvalue of the Gram matrix P^T P (symmetric tridiagonal QR,
// SelfAdjointEigenSolver): the largest eigenvalue of a symmetric matrix is computed to about eps ||P^T P||, so the
// norm to about eps relative, as the SVD's largest singular value, at about a third of JacobiSVD's cost on these
// 23 x 23 powers. SpectralNormAgreesWithTheSvd checks the two against each other.
double spectral_norm(const DynamicMatrix<double>& p) {
    const DynamicMatrix<double> gram = p.transpose() * p;
    const Eigen::SelfAdjointEigenSolver<DynamicMatrix<double>> eigen(gram, Eigen::EigenvaluesOnly);
    return std::sqrt(std::max(eigen.eigenvalues().maxCoeff(), 0.0));
}

double svd_norm(const DynamicMatrix<double>& p) {
    return Eigen::JacobiSVD<DynamicMatrix<double>>(p).singularValues()(0);
}

// The switching loop's state at rest at x0 before t = 0 (window 15: 15 past samples, no force in flight).
Eigen::VectorXd rest_state(int size, int history, double x0) {
    Eigen::VectorXd s = Eigen::VectorXd::Zero(size);
    s(0) = x0;
    for (int i = 0; i < history; ++i) s(2 + i) = x0;
    return s;
}

TEST(SwitchingDwell, TheSwitchingLoopHasTheRenderedLoopsSpectralRadius) {
    struct Case {
        VelocityEstimator e;
        double delay;
    };
    for (const Case& c :
         {Case{VelocityEstimator::backward_difference(), 0.0}, Case{VelocityEstimator::backward_difference(), 1.5},
          Case{VelocityEstimator::low_pass(0.05), 2.0}, Case{VelocityEstimator::moving_window(15), 6.0},
          Case{VelocityEstimator::moving_window(4), 3.25}}) {
        for (double m : {0.2, 0.3}) {
            for (double k_per_m : {0.0, 1000.0}) {
                const double K = 0.02 * kReferenceMass / (kPeriod * kPeriod), B = 0.3 * kReferenceMass / kPeriod;
                const Tick t{K, B, m, k_per_m * m, 0.0};
                const NormalizedPlant plant{k_per_m * kPeriod * kPeriod, 0.0, c.delay};
                const double expected =
                    hapticopt::stability(plant, hapticopt::NormalizedGains{K * kPeriod * kPeriod / m, B * kPeriod / m},
                                         c.e)
                        .spectral_radius;
                const double radius = hapticopt::mode_schur_form(matrix_of(t, c.e, c.delay)).spectral_radius;
                EXPECT_NEAR(radius, expected, 1e-9) << "delay " << c.delay << " mass " << m;
            }
        }
    }
}

TEST(SwitchingDwell, TheMatrixProductsReproduceTheIndependentSimulationAcrossSwitches) {
    const Family f = falcon_family();
    std::mt19937 rng(7);
    // Blocks of 1 to 40 ticks: switches inside the delay line's 6 ticks, where recomputing the forces in flight
    // with the new gains would differ.
    const std::vector<int> schedule = random_schedule(rng, static_cast<int>(f.modes.size()), 150, 1, 40);
    std::vector<Tick> ticks;
    for (int i : schedule) ticks.push_back(f.modes[static_cast<std::size_t>(i)]);
    const double x0 = 1e-3;
    const std::vector<double> simulated = switched_loop_simulation::positions(ticks, kPeriod, 6.0, 15, x0);
    Eigen::VectorXd s = rest_state(static_cast<int>(f.matrices[0].rows()), 15, x0);
    double worst = 0, largest = 0;
    for (std::size_t j = 0; j < schedule.size(); ++j) {
        s = f.matrices[static_cast<std::size_t>(schedule[j])] * s;
        worst = std::max(worst, std::abs(s(0) - simulated[j + 1]));
        largest = std::max(largest, std::abs(simulated[j + 1]));
    }
    // Rounding (~1e-16 per operation over a few thousand ticks) and the arm's Runge-Kutta (~1e-14 per step).
    EXPECT_LT(worst, 1e-9 * largest) << "largest |x| " << largest;
}

TEST(SwitchingDwell, ThePowerBoundHoldsForEveryComputedPower) {
    const Family f = falcon_family();
    const hapticopt::DwellCertificate c = hapticopt::minimum_dwell(f.matrices);
    ASSERT_TRUE(c.certified);
    std::printf("Falcon family (%zu modes, N = %d): N_d = %d ticks, lambda = %.6f, M = %.1f, largest radius %.6f\n",
                f.matrices.size(), static_cast<int>(f.matrices[0].rows()), c.dwell_ticks, c.rate, c.constant,
                c.largest_spectral_radius);
    EXPECT_LT(c.largest_spectral_radius, c.rate);
    EXPECT_LT(c.switched_rate, 1.0);
    EXPECT_LT(c.constant * std::pow(c.rate, c.dwell_ticks), 1.0);
    EXPECT_GE(c.constant * std::pow(c.rate, c.dwell_ticks - 1), 1.0);
    // The powers one by one: the bound ||A^n||_2 <= M lambda^n holds at every n, and the computed sup of
    // ||A^n|| lambda^-n (what a tighter certificate could use) and the last n with ||A^n|| >= 1 are printed.
    // The Frobenius norm bounds the 2-norm from above (||P||_2 <= ||P||_F <= sqrt(23) ||P||_2), so where it already
    // meets the bound, stays below 1 (or below a last n already found) and below the sup found so far, the 2-norm
    // changes none of the three; everywhere else the 2-norm itself is computed (spectral_norm) and checked.
    const int horizon = c.dwell_ticks;
    double sup_ratio = 0;
    int last_above_one = 0;
    long exact = 0, powers = 0;
    for (const DynamicMatrix<double>& a : f.matrices) {
        DynamicMatrix<double> power = DynamicMatrix<double>::Identity(a.rows(), a.cols());
        double scale = 1.0;
        for (int n = 0; n <= horizon; ++n, ++powers) {
            const double bound = c.constant * scale * (1 + 1e-9), frobenius = power.norm();
            if (frobenius > bound || (frobenius >= 1.0 && n > last_above_one) || frobenius / scale > sup_ratio) {
                ++exact;
                const double norm = spectral_norm(power);
                ASSERT_LE(norm, bound) << "n = " << n;
                sup_ratio = std::max(sup_ratio, norm / scale);
                if (norm >= 1.0) last_above_one = std::max(last_above_one, n);
            }
            power = (a * power).eval();
            scale *= c.rate;
        }
    }
    std::printf("2-norms computed for %ld of %ld powers (the Frobenius norm settled the rest)\n", exact, powers);
    std::printf(
        "computed: sup_n ||A^n|| / lambda^n = %.1f (bound M = %.1f); ||A^n|| < 1 for every mode from n = %d "
        "to %d\n",
        sup_ratio, c.constant, last_above_one + 1, horizon);
    EXPECT_LE(last_above_one + 1, c.dwell_ticks);
}

// The rows of docs/robust-stability.md ("The switch certificate"): sub-families of the Falcon's. A sub-family's
// M(lambda) and radius are at most the family's at every rate, so its dwell is at most the family's.
TEST(SwitchingDwell, ASubFamilyNeedsNoLongerDwell) {
    const Family f = falcon_family();
    const hapticopt::DwellCertificate whole = hapticopt::minimum_dwell(f.matrices);
    ASSERT_TRUE(whole.certified);
    struct Row {
        const char* name;
        bool (*keep)(const Tick&);
    };
    const Row rows[] = {
        {"the released gains alone x the set", [](const Tick& t) { return t.stiffness < 300; }},
        {"both gains x the masses, no arm", [](const Tick& t) { return t.arm_stiffness == 0 && t.arm_damping == 0; }},
        {"both gains x {0.22, 0.30 kg}, no arm",
         [](const Tick& t) {
             return t.arm_stiffness == 0 && t.arm_damping == 0 && (t.mass == 0.22 || t.mass == 0.30);
         }},
        {"both gains x {0.30 kg with the arm's corners, 0.22 kg}",
         [](const Tick& t) {
             return t.mass == 0.30 || (t.mass == 0.22 && t.arm_stiffness == 0 && t.arm_damping == 0);
         }},
    };
    std::printf("%s: %zu modes, radius %.6f, lambda %.6f, M %.0f, N_d %d\n", "both gains x the set", f.matrices.size(),
                whole.largest_spectral_radius, whole.rate, whole.constant, whole.dwell_ticks);
    for (const Row& r : rows) {
        std::vector<DynamicMatrix<double>> sub;
        for (std::size_t i = 0; i < f.modes.size(); ++i) {
            if (r.keep(f.modes[i])) sub.push_back(f.matrices[i]);
        }
        const hapticopt::DwellCertificate c = hapticopt::minimum_dwell(sub);
        ASSERT_TRUE(c.certified) << r.name;
        std::printf("%s: %zu modes, radius %.6f, lambda %.6f, M %.0f, N_d %d\n", r.name, sub.size(),
                    c.largest_spectral_radius, c.rate, c.constant, c.dwell_ticks);
        EXPECT_LE(c.dwell_ticks, whole.dwell_ticks) << r.name;
        EXPECT_LE(c.largest_spectral_radius, whole.largest_spectral_radius) << r.name;
    }
}

// The power certificate: a shorter dwell than the Lyapunov bound's on the Falcon's family, its contraction checked
// against the 2-norm of the powers (spectral_norm) over [N, 2N) (the Frobenius bound it uses is >= the 2-norm), and
// random sequences that respect it decay in the independent simulation.
TEST(SwitchingDwell, ThePowerCertificateIsShorterAndHolds) {
    const Family f = falcon_family();
    const hapticopt::DwellCertificate lyapunov = hapticopt::minimum_dwell(f.matrices);
    const hapticopt::PowerDwellCertificate c = hapticopt::power_dwell(f.matrices, 2 * lyapunov.dwell_ticks);
    ASSERT_TRUE(c.certified);
    std::printf("power certificate: N = %d ticks (Lyapunov %d), q = %.4f, M_s = %.1f\n", c.dwell_ticks,
                lyapunov.dwell_ticks, c.contraction, c.short_block);
    EXPECT_LE(c.dwell_ticks, lyapunov.dwell_ticks);
    EXPECT_LT(c.contraction, 1.0);
    // Every mode's powers over [N, 2N): the Frobenius norm (>= the 2-norm) settles those it keeps below q, the
    // 2-norm (spectral_norm) is computed for the others.
    for (std::size_t i = 0; i < f.matrices.size(); ++i) {
        const DynamicMatrix<double>& a = f.matrices[i];
        DynamicMatrix<double> power = DynamicMatrix<double>::Identity(a.rows(), a.cols());
        for (int n = 1; n < 2 * c.dwell_ticks; ++n) {
            power = (a * power).eval();
            if (n < c.dwell_ticks || power.norm() <= c.contraction) continue;
            ASSERT_LE(spectral_norm(power), c.contraction) << "mode " << i << ", n = " << n;
        }
    }
    // Not certified when the horizon is too short to hold [N, 2N).
    EXPECT_FALSE(hapticopt::power_dwell(f.matrices, c.dwell_ticks).certified);
    std::mt19937 rng(5);
    for (int run = 0; run < 4; ++run) {
        const std::vector<int> schedule =
            random_schedule(rng, static_cast<int>(f.modes.size()), 10, c.dwell_ticks, c.dwell_ticks + 200);
        std::vector<Tick> ticks;
        for (int i : schedule) ticks.push_back(f.modes[static_cast<std::size_t>(i)]);
        const std::vector<double> x = switched_loop_simulation::positions(ticks, kPeriod, 6.0, 15, 1e-3);
        double last = 0;
        for (std::size_t j = x.size() - 500; j < x.size(); ++j) last = std::max(last, std::abs(x[j]));
        EXPECT_LT(last, 1e-6 * 1e-3) << "run " << run;
    }
}

TEST(SwitchingDwell, RandomSwitchingThatRespectsTheDwellDecaysWithinTheBound) {
    const Family f = falcon_family();
    const hapticopt::DwellCertificate c = hapticopt::minimum_dwell(f.matrices);
    ASSERT_TRUE(c.certified);
    std::mt19937 rng(11);
    const double x0 = 1e-3;
    const double start_norm = rest_state(static_cast<int>(f.matrices[0].rows()), 15, x0).norm();
    for (int run = 0; run < 4; ++run) {
        const std::vector<int> schedule =
            random_schedule(rng, static_cast<int>(f.modes.size()), 8, c.dwell_ticks, c.dwell_ticks * 3 / 2);
        std::vector<Tick> ticks;
        int switches = 0;
        for (std::size_t j = 0; j < schedule.size(); ++j) {
            ticks.push_back(f.modes[static_cast<std::size_t>(schedule[j])]);
            if (j > 0 && schedule[j] != schedule[j - 1]) ++switches;
        }
        const std::vector<double> x = switched_loop_simulation::positions(ticks, kPeriod, 6.0, 15, x0);
        int seen = 0;  // switches among the ticks 0 .. j - 1 that brought x_0 to x_j
        for (std::size_t j = 1; j < x.size(); ++j) {
            if (j >= 2 && schedule[j - 1] != schedule[j - 2]) ++seen;
            ASSERT_LE(std::abs(x[j]), hapticopt::switched_norm_bound(c, static_cast<int>(j), seen) * start_norm)
                << "run " << run << " tick " << j;
        }
        double last = 0;
        for (std::size_t j = x.size() - 500; j < x.size(); ++j) last = std::max(last, std::abs(x[j]));
        EXPECT_LT(last, 1e-6 * x0) << "run " << run << ", " << switches << " switches over " << schedule.size()
                                   << " ticks";
    }
}

// spectral_norm against the SVD's largest singular value on the powers 1, 2, 4 .. 4096 of every Falcon mode:
// 1e-12 relative, the two methods' rounding (both backward stable, eps ~ 2e-16, times the ~23-term sums of their
// sweeps) with room.
TEST(SwitchingDwell, SpectralNormAgreesWithTheSvd) {
    const Family f = falcon_family();
    for (std::size_t i = 0; i < f.matrices.size(); ++i) {
        const DynamicMatrix<double>& a = f.matrices[i];
        DynamicMatrix<double> power = a;
        for (int n = 1; n <= 4096; n *= 2) {
            const double svd = svd_norm(power);
            EXPECT_NEAR(spectral_norm(power), svd, 1e-12 * svd) << "mode " << i << ", n = " << n;
            power = (power * power).eval();
        }
    }
}

// Two stable walls of the backward-difference loop without delay on 0.3 kg: alpha 0.4, beta 0.3 (K 120 kN/m, B 90 N
// s/m) and alpha 0.01, beta 0.3 (K 3 kN/m, the same B). Switched every 3 ticks the handle's excursion grows (the
// product of the two 3-tick blocks has spectral radius > 1); switched no faster than the certificate's dwell it
// decays. The certificate's dwell must exceed 3.
TEST(SwitchingDwell, TwoStableWallsSwitchedFastDivergeAndTheDwellIsNeeded) {
    const Tick stiff{120e3, 90.0, 0.3}, soft{3e3, 90.0, 0.3};
    const VelocityEstimator e = VelocityEstimator::backward_difference();
    const std::vector<DynamicMatrix<double>> modes{matrix_of(stiff, e, 0.0), matrix_of(soft, e, 0.0)};
    for (const DynamicMatrix<double>& a : modes) EXPECT_LT(hapticopt::mode_schur_form(a).spectral_radius, 1.0);
    const hapticopt::DwellCertificate c = hapticopt::minimum_dwell(modes);
    ASSERT_TRUE(c.certified);
    EXPECT_GT(c.dwell_ticks, 3);
    std::printf("stiff/soft pair: N_d = %d ticks, lambda = %.6f, M = %.2f\n", c.dwell_ticks, c.rate, c.constant);
    auto run = [&](int block) {
        std::vector<Tick> ticks;
        for (int j = 0; j < 3000; ++j) ticks.push_back((j / block) % 2 == 0 ? stiff : soft);
        const std::vector<double> x = switched_loop_simulation::positions(ticks, kPeriod, 0.0, 1, 1e-3);
        double last = 0;
        for (std::size_t j = x.size() - 100; j < x.size(); ++j) last = std::max(last, std::abs(x[j]));
        return last / 1e-3;
    };
    const double fast = run(3), dwelled = run(c.dwell_ticks);
    std::printf("excursion after 3 s: switched every 3 ticks x %.3g, every N_d ticks x %.3g\n", fast, dwelled);
    EXPECT_GT(fast, 1e3);
    EXPECT_LT(dwelled, 1e-3);
}

TEST(SwitchingDwell, AnUnstableModeOrMalformedFamilyIsRefused) {
    const VelocityEstimator e = VelocityEstimator::backward_difference();
    const Tick stable{3e3, 90.0, 0.3}, unstable{3e3, -10.0, 0.3};
    const hapticopt::DwellCertificate c =
        hapticopt::minimum_dwell({matrix_of(stable, e, 0.0), matrix_of(unstable, e, 0.0)});
    EXPECT_FALSE(c.certified);
    EXPECT_EQ(c.unstable_mode, 1);
    EXPECT_GE(c.largest_spectral_radius, 1.0);
    EXPECT_THROW(hapticopt::minimum_dwell({}), hapticopt::InvalidParameter);
    EXPECT_THROW(hapticopt::minimum_dwell({matrix_of(stable, e, 0.0), matrix_of(stable, e, 1.0)}),
                 hapticopt::InvalidParameter);
    DynamicMatrix<double> bad = matrix_of(stable, e, 0.0);
    bad(0, 0) = std::nan("");
    EXPECT_THROW(hapticopt::minimum_dwell({bad}), hapticopt::InvalidParameter);
    EXPECT_THROW(hapticopt::make_switching_loop(SampledPlant<double>(NormalizedPlant{}), e, 0.1, 0.1, -1.0),
                 hapticopt::InvalidParameter);
}

}  // namespace switching_dwell_test
