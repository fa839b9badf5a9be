// SPDX-License-Identifier: Apache-2.0
#include "identification/identification.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "devices/zoh_plant.hpp"

namespace hapticd {

namespace {

constexpr int kNonlinear = 3;         // m, b, k
constexpr int kFixedDelayParams = 6;  // m, b, k, x0, v0, F0
constexpr int kAllParams = 7;         // + d

PlantEstimate with_params(const PlantEstimate& base, const Eigen::VectorXd& theta) {
    PlantEstimate p = base;
    p.mass = theta(0);
    p.damping = theta(1);
    p.stiffness = theta(2);
    p.x0 = theta(3);
    p.v0 = theta(4);
    p.offset_force = theta(5);
    return p;
}

Eigen::VectorXd params_of(const PlantEstimate& p) {
    Eigen::VectorXd t(kFixedDelayParams);
    t << p.mass, p.damping, p.stiffness, p.x0, p.v0, p.offset_force;
    return t;
}

Eigen::VectorXd to_eigen(const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

double rss_of(const IdentificationData& data, const PlantEstimate& p) {
    const std::vector<double> x = simulate_sampled_plant(p, data.period, data.force);
    double s = 0.0;
    for (std::size_t j = 0; j < x.size(); ++j) {
        const double r = data.position[j] - x[j];
        s += r * r;
    }
    return std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
}

// Jacobian of the model output in (m, b, k, x0, v0, F0) [and d when with_delay].
Eigen::MatrixXd jacobian(const IdentificationData& data, const PlantEstimate& p, bool with_delay) {
    const auto N = static_cast<Eigen::Index>(data.force.size());
    const double T = data.period;
    Eigen::MatrixXd J(N, with_delay ? kAllParams : kFixedDelayParams);
    const std::array<double, 3> h{1e-6 * p.mass, 1e-6 * std::max(std::abs(p.damping), 1e-2 * p.mass / T),
                                  1e-6 * std::max(std::abs(p.stiffness), 1e-3 * p.mass / (T * T))};
    for (int i = 0; i < kNonlinear; ++i) {
        PlantEstimate lo = p;
        PlantEstimate hi = p;
        double* fields_lo[] = {&lo.mass, &lo.damping, &lo.stiffness};
        double* fields_hi[] = {&hi.mass, &hi.damping, &hi.stiffness};
        *fields_lo[i] -= h[static_cast<std::size_t>(i)];
        *fields_hi[i] += h[static_cast<std::size_t>(i)];
        J.col(i) = (to_eigen(simulate_sampled_plant(hi, T, data.force)) -
                    to_eigen(simulate_sampled_plant(lo, T, data.force))) /
                   (2.0 * h[static_cast<std::size_t>(i)]);
    }
    // x0, v0, F0 enter linearly: their columns are the responses to a unit value alone.
    const std::vector<double> zero(data.force.size(), 0.0);
    for (int i = 0; i < 3; ++i) {
        PlantEstimate unit = p;
        unit.x0 = i == 0 ? 1.0 : 0.0;
        unit.v0 = i == 1 ? 1.0 : 0.0;
        unit.offset_force = i == 2 ? 1.0 : 0.0;
        J.col(3 + i) = to_eigen(simulate_sampled_plant(unit, T, zero));
    }
    if (with_delay) {
        const double hd = 1e-3;
        PlantEstimate hi = p;
        PlantEstimate lo = p;
        hi.delay_periods = p.delay_periods + hd;
        lo.delay_periods = std::max(0.0, p.delay_periods - hd);
        J.col(6) = (to_eigen(simulate_sampled_plant(hi, T, data.force)) -
                    to_eigen(simulate_sampled_plant(lo, T, data.force))) /
                   (hi.delay_periods - lo.delay_periods);
    }
    return J;
}

struct OeFit {
    PlantEstimate plant;
    double rss = std::numeric_limits<double>::infinity();
};

// Levenberg-Marquardt on (m, b, k, x0, v0, F0) at the fixed delay start.delay_periods.
OeFit fit_output_error(const IdentificationData& data, const PlantEstimate& start, int max_iterations) {
    OeFit best{start, rss_of(data, start)};
    if (!std::isfinite(best.rss)) return best;
    const Eigen::VectorXd y = to_eigen(data.position);
    double lambda = 1e-3;
    for (int it = 0; it < max_iterations; ++it) {
        const Eigen::MatrixXd J = jacobian(data, best.plant, false);
        const Eigen::VectorXd r = y - to_eigen(simulate_sampled_plant(best.plant, data.period, data.force));
        Eigen::VectorXd D = J.colwise().norm().transpose();
        for (Eigen::Index i = 0; i < D.size(); ++i) {
            if (!(D(i) > 0.0) || !std::isfinite(D(i))) D(i) = 1.0;
        }
        const Eigen::MatrixXd Js = J * D.cwiseInverse().asDiagonal();
        const Eigen::MatrixXd A = Js.transpose() * Js;
        const Eigen::VectorXd g = Js.transpose() * r;
        bool improved = false;
        double step_size = 0.0;
        while (lambda < 1e12) {
            Eigen::MatrixXd M = A;
            M.diagonal().array() += lambda;
            const Eigen::VectorXd ds = M.ldlt().solve(g);
            const Eigen::VectorXd delta = ds.cwiseQuotient(D);
            const Eigen::VectorXd theta = params_of(best.plant) + delta;
            if (theta.allFinite() && theta(0) > 0.0) {
                const PlantEstimate trial = with_params(best.plant, theta);
                const double rss = rss_of(data, trial);
                if (rss < best.rss) {
                    const double gain = (best.rss - rss) / best.rss;
                    best = {trial, rss};
                    lambda = std::max(lambda * 0.1, 1e-12);
                    improved = true;
                    step_size = ds.norm();
                    if (gain < 1e-13) step_size = 0.0;
                    break;
                }
            }
            lambda *= 10.0;
        }
        if (!improved || step_size < 1e-10) break;
    }
    return best;
}

Eigen::Index rows_of(std::size_t n) { return static_cast<Eigen::Index>(n); }

}  // namespace

std::vector<double> simulate_sampled_plant(const PlantEstimate& p, double period, const std::vector<double>& force) {
    const std::size_t N = force.size();
    std::vector<double> x(N, 0.0);
    if (N == 0) return x;
    const double d = std::max(0.0, p.delay_periods);
    const double whole = std::floor(d);
    const auto n = static_cast<long long>(whole);
    const double f = d - whole;
    const PlantParameters plant{p.mass, p.damping, p.stiffness};
    const ZohStep first = discretize(plant, f * period);
    const ZohStep second = discretize(plant, (1.0 - f) * period);
    const auto input = [&](long long i) {
        return i < 0 || i >= static_cast<long long>(N) ? 0.0 : force[static_cast<std::size_t>(i)];
    };
    double xs = p.x0;
    double vs = p.v0;
    x[0] = xs;
    for (std::size_t j = 0; j + 1 < N; ++j) {
        const auto jj = static_cast<long long>(j);
        first.apply(xs, vs, p.offset_force + input(jj - n - 1));
        second.apply(xs, vs, p.offset_force + input(jj - n));
        x[j + 1] = xs;
    }
    return x;
}

std::optional<ArxFit> fit_arx(const IdentificationData& data, int n) {
    const std::size_t N = data.position.size();
    if (N < 20 || data.force.size() != N || n < 0) return std::nullopt;
    const std::size_t rows = N - 2;  // j = 1 .. N-2
    Eigen::MatrixXd X(rows_of(rows), 6);
    Eigen::VectorXd Y(rows_of(rows));
    const auto u = [&](long long i) { return i < 0 ? 0.0 : data.force[static_cast<std::size_t>(i)]; };
    for (std::size_t j = 1; j + 1 < N; ++j) {
        const auto r = rows_of(j - 1);
        const auto jj = static_cast<long long>(j);
        X(r, 0) = data.position[j];
        X(r, 1) = data.position[j - 1];
        X(r, 2) = u(jj - n);
        X(r, 3) = u(jj - n - 1);
        X(r, 4) = u(jj - n - 2);
        X(r, 5) = 1.0;
        Y(r) = data.position[j + 1];
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(X);
    if (qr.rank() < 6) return std::nullopt;
    Eigen::VectorXd c = qr.solve(Y);
    // Instrumental variables (two passes): the noisy regressors y_j, y_{j-1} are instrumented by the
    // noise-free output of the previous fit's difference equation driven by u, which removes the
    // equation-error bias of least squares when y carries measurement noise.
    for (int pass = 0; pass < 2; ++pass) {
        std::vector<double> xs(N, 0.0);
        xs[0] = data.position[0];
        xs[1] = data.position[1];
        double bound = 0.0;
        for (double y : data.position) bound = std::max(bound, std::abs(y));
        bool sane = true;
        for (std::size_t j = 1; j + 1 < N; ++j) {
            const auto jj = static_cast<long long>(j);
            xs[j + 1] =
                c(0) * xs[j] + c(1) * xs[j - 1] + c(2) * u(jj - n) + c(3) * u(jj - n - 1) + c(4) * u(jj - n - 2) + c(5);
            if (!std::isfinite(xs[j + 1]) || std::abs(xs[j + 1]) > 100.0 * bound + 1.0) {
                sane = false;
                break;
            }
        }
        if (!sane) break;
        Eigen::MatrixXd Z = X;
        for (std::size_t j = 1; j + 1 < N; ++j) {
            Z(rows_of(j - 1), 0) = xs[j];
            Z(rows_of(j - 1), 1) = xs[j - 1];
        }
        const Eigen::MatrixXd ZX = Z.transpose() * X;
        const Eigen::FullPivLU<Eigen::MatrixXd> lu(ZX);
        if (!lu.isInvertible()) break;
        const Eigen::VectorXd civ = lu.solve(Z.transpose() * Y);
        if (!civ.allFinite()) break;
        c = civ;
    }
    ArxFit fit;
    fit.delay = n;
    fit.a1 = c(0);
    fit.a2 = c(1);
    fit.c = {c(2), c(3), c(4)};
    fit.constant = c(5);
    fit.rss = (Y - X * c).squaredNorm();
    if (!std::isfinite(fit.rss)) return std::nullopt;
    return fit;
}

std::optional<PlantEstimate> arx_to_plant(const ArxFit& fit, double T) {
    const double product = -fit.a2;  // z1 z2
    if (!(product > 0.0)) return std::nullopt;
    const double c1 = -std::log(product) / T;  // b/m = -(s1 + s2)
    const double disc = fit.a1 * fit.a1 - 4.0 * product;
    double c0 = 0.0;  // k/m = s1 s2
    if (disc >= 0.0) {
        const double z1 = 0.5 * (fit.a1 + std::sqrt(disc));
        const double z2 = 0.5 * (fit.a1 - std::sqrt(disc));
        if (!(z1 > 0.0) || !(z2 > 0.0)) return std::nullopt;
        c0 = std::log(z1) * std::log(z2) / (T * T);
    } else {
        const double lr = 0.5 * std::log(product);
        const double theta = std::atan2(std::sqrt(-disc), fit.a1);
        c0 = (lr * lr + theta * theta) / (T * T);
    }
    const ZohStep unit = discretize(PlantParameters{1.0, c1, c0}, T);
    const double n_unit = unit.gamma[0] * (1.0 - unit.phi[3]) + unit.phi[1] * unit.gamma[1];
    const double n_fit = fit.c[0] + fit.c[1] + fit.c[2];
    if (!(n_fit > 0.0) || !(n_unit > 0.0)) return std::nullopt;
    PlantEstimate p;
    p.mass = n_unit / n_fit;
    p.damping = p.mass * c1;
    p.stiffness = p.mass * c0;
    p.delay_periods = fit.delay;
    p.offset_force = fit.constant / n_fit;
    if (!std::isfinite(p.mass) || !std::isfinite(p.damping) || !std::isfinite(p.stiffness)) return std::nullopt;
    return p;
}

IdentificationResult identify_plant(const IdentificationData& raw, const IdentificationSettings& s) {
    IdentificationResult out;
    out.period = raw.period;
    const std::size_t N = raw.position.size();
    out.samples = N;
    if (!(raw.period > 0.0) || !std::isfinite(raw.period)) {
        out.message = "period must be finite and > 0";
        return out;
    }
    if (raw.force.size() != N || N < 50) {
        out.message = "need at least 50 samples of force and position of equal length (got " +
                      std::to_string(raw.force.size()) + " and " + std::to_string(N) + ")";
        return out;
    }
    for (std::size_t j = 0; j < N; ++j) {
        if (!std::isfinite(raw.position[j]) || !std::isfinite(raw.force[j])) {
            out.message = "non-finite sample at tick " + std::to_string(j);
            return out;
        }
    }
    // Positions relative to the first sample (conditioning); x0 is shifted back at the end.
    IdentificationData data = raw;
    const double y0 = raw.position.front();
    for (double& y : data.position) y -= y0;

    // 1. ARX start: the integer delay of least equation error.
    std::optional<ArxFit> best_arx;
    std::vector<ArxFit> fits;
    for (int n = 0; n <= s.max_delay_periods; ++n) {
        if (auto f = fit_arx(data, n)) {
            fits.push_back(*f);
            if (!best_arx || f->rss < best_arx->rss) best_arx = f;
        }
    }
    if (!best_arx) {
        out.message = "the excitation does not determine the model (ARX regression is singular)";
        return out;
    }
    std::sort(fits.begin(), fits.end(), [](const ArxFit& a, const ArxFit& b) { return a.rss < b.rss; });
    std::optional<PlantEstimate> start;
    for (const auto& f : fits) {
        if ((start = arx_to_plant(f, data.period))) {
            start->delay_periods = best_arx->delay;
            break;
        }
    }
    if (!start) {
        out.message = "no ARX fit maps to a mass-damper-spring (check the excitation and the force sign)";
        return out;
    }
    out.arx_delay = best_arx->delay;
    start->x0 = 0.0;
    start->v0 = 0.0;

    // 2. Output error, profiled over the delay: grid, then golden section around the best grid point.
    //    The coarse grid (every 0.5 period over 0 .. max_delay + 0.5) does not trust the ARX delay: with
    //    noise the equation error can prefer a wrong n, and R(d) has local minima near other integers.
    //    Pass 1 starts every grid point from the ARX start (damping and stiffness clamped to >= 0: a negative
    //    stiffness start can end in a local minimum with an unstable pole), with few iterations; pass 2
    //    restarts the grid within 2 periods of the best from that best (continuation), fully.
    const double step = s.delay_grid_step;
    start->damping = std::max(0.0, start->damping);
    start->stiffness = std::max(0.0, start->stiffness);
    PlantEstimate pure_mass = *start;
    pure_mass.damping = 0.0;
    pure_mass.stiffness = 0.0;
    OeFit best;
    for (double d = 0.0; d <= s.max_delay_periods + 0.5 + 1e-12; d += 2.0 * step) {
        PlantEstimate p = *start;
        p.delay_periods = d;
        PlantEstimate q = pure_mass;
        q.delay_periods = d;
        OeFit f = fit_output_error(data, p, std::min(10, s.max_iterations));
        if (const OeFit g = fit_output_error(data, q, std::min(10, s.max_iterations)); g.rss < f.rss) f = g;
        if (f.rss < best.rss) best = f;
    }
    {
        const OeFit pass1 = best;
        for (double d = std::max(0.0, pass1.plant.delay_periods - 2.0); d <= pass1.plant.delay_periods + 2.0 + 1e-12;
             d += 2.0 * step) {
            PlantEstimate p = pass1.plant;
            p.delay_periods = d;
            const OeFit f = fit_output_error(data, p, s.max_iterations);
            if (f.rss < best.rss) best = f;
        }
    }
    {
        const OeFit coarse = best;
        for (const double offset : {-step, step}) {
            PlantEstimate p = coarse.plant;
            p.delay_periods = coarse.plant.delay_periods + offset;
            if (p.delay_periods < 0.0) continue;
            const OeFit f = fit_output_error(data, p, s.max_iterations);
            if (f.rss < best.rss) best = f;
        }
    }
    if (!std::isfinite(best.rss)) {
        out.message = "the output-error fit failed (non-finite residual)";
        return out;
    }
    {
        const PlantEstimate warm = best.plant;
        auto profile = [&](double d) {
            PlantEstimate p = warm;
            p.delay_periods = d;
            const OeFit f = fit_output_error(data, p, s.max_iterations);
            if (f.rss < best.rss) best = f;
            return f.rss;
        };
        const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
        double a = std::max(0.0, warm.delay_periods - step);
        double b = warm.delay_periods + step;
        double c = b - phi * (b - a);
        double d = a + phi * (b - a);
        double fc = profile(c);
        double fd = profile(d);
        while (b - a > s.delay_tolerance) {
            if (fc < fd) {
                b = d;
                d = c;
                fd = fc;
                c = b - phi * (b - a);
                fc = profile(c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + phi * (b - a);
                fd = profile(d);
            }
        }
        // Polish the parameters at the chosen delay.
        PlantEstimate p = best.plant;
        const OeFit f = fit_output_error(data, p, s.max_iterations * 2);
        if (f.rss <= best.rss) best = f;
    }

    // 3. Covariance of all seven parameters.
    const Eigen::MatrixXd J = jacobian(data, best.plant, true);
    const auto dof = static_cast<double>(N) - kAllParams;
    const double sigma2 = best.rss / dof;
    Eigen::VectorXd D = J.colwise().norm().transpose();
    for (Eigen::Index i = 0; i < D.size(); ++i) {
        if (!(D(i) > 0.0)) D(i) = 1.0;
    }
    const Eigen::MatrixXd Js = J * D.cwiseInverse().asDiagonal();
    const Eigen::MatrixXd info = Js.transpose() * Js;
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(info);
    if (!lu.isInvertible()) {
        out.message = "the excitation does not determine all parameters (singular information matrix)";
        return out;
    }
    const Eigen::MatrixXd cov = D.cwiseInverse().asDiagonal() * lu.inverse() * D.cwiseInverse().asDiagonal() * sigma2;
    const PlantEstimate& p = best.plant;
    out.ok = true;
    out.mass = p.mass;
    out.damping = p.damping;
    out.stiffness = p.stiffness;
    out.delay_periods = p.delay_periods;
    out.delay_whole = static_cast<long long>(std::floor(p.delay_periods));
    out.delay_fraction = p.delay_periods - static_cast<double>(out.delay_whole);
    out.offset_force = p.offset_force;
    out.x0 = p.x0 + y0;
    out.v0 = p.v0;
    out.mass_stderr = std::sqrt(cov(0, 0));
    out.damping_stderr = std::sqrt(cov(1, 1));
    out.stiffness_stderr = std::sqrt(cov(2, 2));
    out.offset_force_stderr = std::sqrt(cov(5, 5));
    out.delay_stderr = std::sqrt(cov(6, 6));
    const int order[4] = {0, 1, 2, 6};
    for (int i = 0; i < 4; ++i) {
        for (int j = 0; j < 4; ++j) {
            out.covariance[static_cast<std::size_t>(4 * i + j)] = cov(order[i], order[j]);
        }
    }
    out.residual_rms = std::sqrt(best.rss / static_cast<double>(N));
    return out;
}

}  // namespace hapticd
