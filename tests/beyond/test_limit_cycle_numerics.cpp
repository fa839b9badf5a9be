// SPDX-License-Identifier: Apache-2.0
// The numerics under predict_limit_cycle (include/hapticopt/limit_cycles.hpp) against slower independent methods:
// the closed-form exponential of the free mass against the Taylor series in long double, the loop transfer from
// the plant's and the estimator's factors against the characteristic polynomial's coefficients, the bias solver
// (Illinois) against bisection for both ends of the zero set, and the Illinois bracket itself.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>
#include <random>

#include <hapticopt/limit_cycles.hpp>

namespace limit_cycle_numerics_test {

using namespace hapticopt;
constexpr double eps = std::numeric_limits<double>::epsilon();

// Reference: the series of exponential_integrals.hpp in long double. Its error grows with the 2^s squarings
// (s = ceil(log2(2 ||A||_1 t))): about 2^(s+2) long-double roundings relative to the entry. The closed form
// takes a few roundings per entry and loses at most a factor e/(e - 1) in t - E1 (x >= 1); 16 eps covers both
// branches (the alternating series for x < 1 errs by about one rounding per term, relative to its first).
TEST(LimitCycleNumerics, FreeMassExponentialMatchesTheSeriesInLongDouble) {
    using LD = long double;
    int checked = 0;
    for (double delta : {0.0, 1e-12, 1e-6, 1e-3, 0.1, 0.5, 0.999, 1.0, 1.001, 3.0, 30.0, 1e3, 1e5}) {
        for (double t : {1e-3, 0.25, 0.5, 0.75, 1.0}) {
            const Matrix3<double> closed = free_mass_exponential(delta, t);
            const Matrix3<LD> a = plant_augmented_matrix<LD>(NormalizedPlant{0.0, delta, 0.0});
            const Matrix3<LD> reference = exponential<LD>(a, LD(t));
            const LD norm = detail::norm1_3(a) * LD(t);
            const int squarings = norm > LD(0.5) ? static_cast<int>(std::ceil(std::log2(norm / LD(0.5)))) : 0;
            const LD reference_error = std::ldexp(std::numeric_limits<LD>::epsilon(), squarings + 2);
            for (int i = 0; i < 3; ++i) {
                for (int j = 0; j < 3; ++j) {
                    const LD r = reference(i, j);
                    const LD tolerance = (LD(16 * eps) + reference_error) * std::abs(r) + LD(1e-300);
                    EXPECT_LE(std::abs(LD(closed(i, j)) - r), tolerance)
                        << "delta " << delta << " t " << t << " entry " << i << j << " closed " << closed(i, j)
                        << " series " << static_cast<double>(r);
                    ++checked;
                }
            }
        }
    }
    EXPECT_EQ(checked, 13 * 5 * 9);
}

// Higham's bound for Horner's rule on |z| = 1, |p^(z) - p(z)| <= gamma_2n sum |c_i| (gamma_2n ~ 2 n u; 4 n eps for
// the complex products), on the numerator and the denominator of the polynomial path; the coefficients of both
// paths come from exponentials that differ by up to ~16 eps relative (above), which the same sums scale. The
// factored path's own rounding (a few dozen operations) is the 64 eps. Printed: both paths' largest relative error
// against the polynomials in long double.
TEST(LimitCycleNumerics, TheFactoredTransferAgreesWithThePolynomialsWithinHornersBound) {
    auto horner = [](const Eigen::VectorXd& c, std::complex<double> z) {
        std::complex<double> v = 0;
        for (Eigen::Index i = c.size() - 1; i >= 0; --i) v = v * z + c(i);
        return v;
    };
    auto abs_sum = [](const Eigen::VectorXd& c) { return c.cwiseAbs().sum(); };
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> angle(1e-3, 3.14159265358979323846);
    int checked = 0;
    double worst = 0, worst_polynomial = 0, worst_factored = 0;
    using LD = long double;
    for (const VelocityEstimator& e :
         {VelocityEstimator{}, VelocityEstimator::low_pass(0.02), VelocityEstimator::moving_window(15)}) {
        for (double d : {0.0, 1.5, 6.0}) {
            for (double gamma : {0.0, 0.001}) {
                for (double delta : {0.0, 0.02, 5.0}) {
                    const detail::LimitCycleLinearPart linear(NormalizedPlant{gamma, 0.0, d}, 0.004, 0.1, e);
                    const AffineCharacteristicPolynomial<double> p = linear.polynomial(delta);
                    const PlantPolynomialFactors<double> f = linear.factors(delta);
                    const Eigen::VectorXd numerator = linear.alpha * p.alpha + linear.beta * p.beta;
                    const double n = static_cast<double>(p.base.size());
                    AffineCharacteristicPolynomial<LD> fine =
                        characteristic_polynomial(plant_transitions<LD>(NormalizedPlant{gamma, delta, d}));
                    if (e.kind != VelocityEstimatorKind::backward) fine = estimator_characteristic_polynomial(fine, e);
                    const Eigen::Matrix<LD, Eigen::Dynamic, 1> fine_numerator =
                        LD(linear.alpha) * fine.alpha + LD(linear.beta) * fine.beta;
                    for (int k = 0; k < 40; ++k) {
                        const double theta = angle(rng);
                        const std::complex<double> z = std::polar(1.0, theta);
                        const std::complex<double> num = horner(numerator, z), den = horner(p.base, z);
                        const std::complex<double> g_poly = num / den;
                        const std::complex<double> g_factored = linear.transfer(f, theta);
                        const double bound =
                            std::abs(g_poly) *
                            ((4 * n + 16) * eps *
                                 (abs_sum(numerator) / std::abs(num) + abs_sum(p.base) / std::abs(den)) +
                             64 * eps);
                        ASSERT_LE(std::abs(g_factored - g_poly), bound)
                            << "estimator " << static_cast<int>(e.kind) << " d " << d << " gamma " << gamma << " delta "
                            << delta << " theta " << theta;
                        worst = std::max(worst, std::abs(g_factored - g_poly) / std::abs(g_poly));
                        const std::complex<LD> zl = std::polar(LD(1), LD(theta));
                        std::complex<LD> nl = 0, dl = 0;
                        for (Eigen::Index i = fine.base.size() - 1; i >= 0; --i) {
                            nl = nl * zl + fine_numerator(i);
                            dl = dl * zl + fine.base(i);
                        }
                        const std::complex<LD> g_fine = nl / dl;
                        worst_polynomial = std::max(
                            worst_polynomial,
                            static_cast<double>(std::abs(std::complex<LD>(g_poly) - g_fine) / std::abs(g_fine)));
                        worst_factored = std::max(
                            worst_factored,
                            static_cast<double>(std::abs(std::complex<LD>(g_factored) - g_fine) / std::abs(g_fine)));
                        ++checked;
                    }
                }
            }
        }
    }
    EXPECT_EQ(checked, 3 * 3 * 2 * 3 * 40);
    std::printf(
        "largest relative difference of the two transfers: %.3g; against long double: polynomials %.3g, "
        "factors %.3g\n",
        worst, worst_polynomial, worst_factored);
}

// The bias by bisection alone, both ends of the zero set {g >= 0} and {g > 0} (the definition in the header).
double bias_by_bisection(double k, double stiffness, double force, double amplitude, double q, double* tol) {
    auto g = [&](double x0) {
        return k * x0 + stiffness * detail::quantiser_dual_input(x0, amplitude, q).first - force;
    };
    const double centre = force / (k + stiffness);
    const double reach = q + amplitude + std::abs(centre) * 1e-12;
    double lo = centre - reach, hi = centre + reach;
    while (g(lo) > 0) lo -= reach;
    while (g(hi) < 0) hi += reach;
    *tol = std::max(1e-14 * reach, 4 * eps * std::max(std::abs(lo), std::abs(hi)));
    const auto left = detail::bisect([&](double x) { return g(x) >= 0; }, lo, hi, *tol, 200);
    const auto right = detail::bisect([&](double x) { return g(x) > 0; }, lo, hi, *tol, 200);
    return (left.second + right.second) / 2;
}

// Both answers bracket the sign change: bisection's first point with g >= 0 (and > 0) lies within tol above it,
// Illinois's midpoint within tol / 2 either side: 1.5 tol apart at most; 2 tol leaves 0.5 tol for g's rounding
// (a sum over up to 2 A / q thresholds) making its sign change at more than one point. A flat zero set (k = 0,
// the amplitude below q / 2 and the force on a level) is answered by its middle, n q.
TEST(LimitCycleNumerics, TheBiasAgreesWithBisectionOnBothEndsOfTheZeroSet) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    const double q = 20e-6;
    double worst = 0;
    for (int i = 0; i < 4000; ++i) {
        const double stiffness = std::pow(10.0, 2 + 3 * u(rng));
        const double k = u(rng) < 0.5 ? 0.0 : stiffness * std::pow(10.0, -3 + 3 * u(rng));
        const double amplitude = q * std::pow(10.0, -3 + 5 * u(rng));
        const double force = (u(rng) < 0.2 ? std::round(200 * u(rng) - 100) : 200 * u(rng) - 100) * stiffness * q;
        double tol = 0;
        const double reference = bias_by_bisection(k, stiffness, force, amplitude, q, &tol);
        const double bias = detail::limit_cycle_bias(k, stiffness, force, amplitude, q);
        ASSERT_LE(std::abs(bias - reference), 2 * tol)
            << "k " << k << " K " << stiffness << " F " << force << " A " << amplitude;
        worst = std::max(worst, std::abs(bias - reference) / tol);
    }
    std::printf("largest |bias - bisection| / tol: %.3g\n", worst);
    // the flat case in binary fractions (q = 2^-16 m, K = 1024 N/m), so that g is exactly 0 on the zero set
    const double binary_q = std::ldexp(1.0, -16);
    for (int level : {-3, 0, 7, 100}) {
        const double stiffness = 1024, amplitude = 0.25 * binary_q;
        const double force = stiffness * level * binary_q;
        double tol = 0;
        const double reference = bias_by_bisection(0.0, stiffness, force, amplitude, binary_q, &tol);
        const double bias = detail::limit_cycle_bias(0.0, stiffness, force, amplitude, binary_q);
        EXPECT_NEAR(bias, level * binary_q, 2 * tol) << "level " << level;
        EXPECT_NEAR(bias, reference, 2 * tol) << "level " << level;
    }
}

TEST(LimitCycleNumerics, TheIllinoisBracketHoldsTheSignChange) {
    int evaluations = 0;
    auto cubic = [&](double x) {
        ++evaluations;
        return x * x * x - 2;
    };
    // (x^3 - 2 may meet 0 exactly at a double: then the point is returned, unbracketed)
    const auto r = detail::illinois_bracket(cubic, 0.0, 2.0, -2.0, 6.0, 1e-15);
    if (r.bracketed) {
        EXPECT_LT(cubic(r.a), 0);
        EXPECT_GT(cubic(r.b), 0);
        EXPECT_LE(r.b - r.a, 1e-15);
    } else {
        EXPECT_EQ(cubic(r.a), 0);
    }
    EXPECT_LE(evaluations, 2 + 3 + 20);  // bisection: 51 steps from width 2 to 1e-15
    // an infinite slope at the root (a threshold at the cycle's edge looks like this): the bisection steps keep
    // it within three times bisection's count
    evaluations = 0;
    const double root = 0.3;
    auto cusp = [&](double x) {
        ++evaluations;
        return std::copysign(std::sqrt(std::abs(x - root)), x - root);
    };
    const auto c = detail::illinois_bracket(cusp, 0.0, 1.0, cusp(0.0), cusp(1.0), 1e-14);
    ASSERT_TRUE(c.bracketed);
    EXPECT_LE(c.a, root);
    EXPECT_GE(c.b, root);
    EXPECT_LE(c.b - c.a, 1e-14);
    EXPECT_LE(evaluations, 2 + 3 * 47);
    // g == 0 met exactly: not bracketed, the point returned
    auto flat = [](double x) { return x < 0.25 ? -1.0 : x > 0.75 ? 1.0 : 0.0; };
    const auto z = detail::illinois_bracket(flat, 0.0, 1.0, -1.0, 1.0, 1e-12);
    EXPECT_FALSE(z.bracketed);
    EXPECT_EQ(flat(z.a), 0.0);
    // tol 0: it stops at adjacent doubles (x^3 - 3: no double is its root, 3^(1/3) being irrational and x^3 of a
    // double with 53 bits needing up to 159)
    auto cubic3 = [](double x) { return x * x * x - 3; };
    const auto tight = detail::illinois_bracket(cubic3, 1.0, 2.0, -2.0, 5.0, 0.0);
    if (tight.bracketed) {
        EXPECT_EQ(std::nextafter(tight.a, 2.0), tight.b);
        EXPECT_LT(cubic3(tight.a), 0);
        EXPECT_GT(cubic3(tight.b), 0);
    } else {
        EXPECT_EQ(cubic3(tight.a), 0);
    }
}

}  // namespace limit_cycle_numerics_test
