// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_measure.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "devices/zoh_plant.hpp"

namespace hapticd::experiment {

namespace {

// 8-point Gauss-Legendre nodes and weights on [-1, 1].
constexpr std::array<double, 8> kNodes{-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                       -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                       0.7966664774136267,  0.9602898564975363};
constexpr std::array<double, 8> kWeights{0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                         0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                         0.2223810344533745, 0.1012285362903763};

// A constant-force piece of a period: its length and the ZOH maps at its Gauss nodes and its end.
struct Piece {
    double length = 0.0;
    ZohStep end;
    std::array<ZohStep, 8> nodes;
};

Piece make_piece(const PlantParameters& plant, double length) {
    Piece p;
    p.length = length;
    p.end = discretize(plant, length);
    for (std::size_t i = 0; i < kNodes.size(); ++i) p.nodes[i] = discretize(plant, length * (1.0 + kNodes[i]) / 2.0);
    return p;
}

struct State {
    double x = 0.0, v = 0.0;
};

State advance(const ZohStep& s, State st, double u) {
    s.apply(st.x, st.v, u);
    return st;
}

}  // namespace

double parabola_vertex(double x0, double y0, double x1, double y1, double x2, double y2) {
    const double d01 = (y1 - y0) / (x1 - x0), d12 = (y2 - y1) / (x2 - x1);
    const double curvature = (d12 - d01) / (x2 - x0);
    if (!(curvature > 0.0) || !std::isfinite(curvature)) return x1;
    // y = y1 + d (x - x1) + c (x - x1)^2 with c = curvature and d the slope at x1.
    const double slope = d01 + curvature * (x1 - x0);
    return std::clamp(x1 - slope / (2.0 * curvature), x0, x2);
}

MeasuredCosts measure_costs(const TrialRecord& r, const TrialSettings& trial, const CostModel& model) {
    const double T = model.period;
    const double d = model.inherent_delay / T;
    const double nearest = std::round(d);  // as the simulated device: within 1e-9 of an integer is that integer
    const bool fractional = std::abs(d - nearest) >= 1e-9;
    const double whole = fractional ? std::floor(d) : nearest;
    const auto n = static_cast<std::size_t>(whole);
    const double phi = d - whole;
    if (r.samples < n + 3)
        throw std::invalid_argument("measure_costs: the record is shorter than the delay + 3 samples");

    const PlantParameters plant{model.mass, model.damping, model.stiffness};
    const double total_stiffness = trial.K + model.stiffness;
    const double F = trial.step_force;
    const double x_inf = F / total_stiffness;
    const double e0 = F * F / (2.0 * total_stiffness);
    const double sign = F >= 0.0 ? 1.0 : -1.0;
    auto energy = [&](State s) {
        return 0.5 * total_stiffness * (s.x - x_inf) * (s.x - x_inf) + 0.5 * model.mass * s.v * s.v;
    };
    auto force = [&](std::ptrdiff_t k) { return k < 0 ? 0.0 : r.u[static_cast<std::size_t>(k)]; };

    // Pieces: fractional delay: [0, phi T) with u_{j-n-1}, [phi T, T) with u_{j-n}; else one piece.
    std::vector<Piece> pieces;
    if (fractional) {
        pieces.push_back(make_piece(plant, phi * T));
        pieces.push_back(make_piece(plant, (1.0 - phi) * T));
    } else {
        pieces.push_back(make_piece(plant, T));
    }
    const double t0 = d * T;  // the step reaches the plant

    double i0 = 0.0, i1 = 0.0, i2 = 0.0;
    double peak = sign * r.x[r.samples - 1];
    std::vector<double> period_energy;  // E at the start of each period from the arrival on
    period_energy.reserve(r.samples);
    for (std::size_t j = n; j + 1 < r.samples; ++j) {
        const auto jj = static_cast<std::ptrdiff_t>(j), nn = static_cast<std::ptrdiff_t>(n);
        const std::array<double, 2> u{fractional ? force(jj - nn - 1) : force(jj - nn), force(jj - nn)};
        // The velocity at the period's start from x_j, x_{j+1} and the forces (see the header).
        State unit_v{0.0, 1.0}, from_x{r.x[j], 0.0};
        for (std::size_t p = 0; p < pieces.size(); ++p) {
            unit_v = advance(pieces[p].end, unit_v, 0.0);
            from_x = advance(pieces[p].end, from_x, u[p]);
        }
        State s{r.x[j], (r.x[j + 1] - from_x.x) / unit_v.x};
        peak = std::max(peak, sign * s.x);
        double t_start = static_cast<double>(j) * T;
        if (j > n || !fractional) period_energy.push_back(energy(s));
        for (std::size_t p = 0; p < pieces.size(); ++p) {
            const Piece& piece = pieces[p];
            if (t_start >= t0 - 1e-12 * T) {
                const double half = piece.length / 2.0;
                for (std::size_t i = 0; i < kNodes.size(); ++i) {
                    const State at = advance(piece.nodes[i], s, u[p]);
                    const double t = t_start + half * (1.0 + kNodes[i]) - t0;
                    const double e = kWeights[i] * half * energy(at);
                    i0 += e;
                    i1 += e * t;
                    i2 += e * t * t;
                }
                const State end = advance(piece.end, s, u[p]);
                if (sign * s.v > 0.0 && sign * end.v < 0.0) {  // a maximum inside: bisect x' = 0
                    double lo = 0.0, hi = piece.length;
                    for (int it = 0; it < 60 && hi - lo > 1e-15 * T; ++it) {
                        const double mid = (lo + hi) / 2.0;
                        const State m = advance(discretize(plant, mid), s, u[p]);
                        (sign * m.v > 0.0 ? lo : hi) = mid;
                    }
                    peak = std::max(peak, sign * advance(discretize(plant, (lo + hi) / 2.0), s, u[p]).x);
                }
            }
            s = advance(piece.end, s, u[p]);
            t_start += piece.length;
        }
    }

    MeasuredCosts c;
    c.ce0 = i0 / (T * e0);
    c.ce1 = i1 / (T * T * e0);
    c.ce2 = i2 / (T * T * T * e0);
    c.overshoot = std::max(0.0, (peak - sign * x_inf) / (sign * x_inf));
    // Tail beyond the record: E(t) ~ E_L exp(-(t - L) / tau) with tau from the last two 100-period windows.
    constexpr std::size_t kWindow = 100;
    const std::size_t m = period_energy.size();
    if (m >= 2 * kWindow) {
        double last = 0.0, before = 0.0;
        for (std::size_t i = 0; i < kWindow; ++i) {
            last += period_energy[m - 1 - i];
            before += period_energy[m - 1 - kWindow - i];
        }
        const double e_end = last / static_cast<double>(kWindow);  // mean energy of the last window
        const double L = static_cast<double>(m) * T;
        // Decaying: tau from the two windows; not decaying (a slow mode): tau = the record length, a pessimistic
        // bound. Energies at or below 1e-24 of E_0 (positions within 1e-12 of x_inf) take tau = L as well: there
        // the windows' ratio approaches the rounding noise (1e-32 of E_0) and can be 1 + 1e-16, i.e. any tau,
        // while with tau = L the tail is below 5 (L/T)^3 1e-24 of the costs' scale.
        const bool rounding_level = e_end <= 1e-24 * e0;
        const double tau =
            !rounding_level && last < before ? static_cast<double>(kWindow) * T / std::log(before / last) : L;
        const double tail0 = e_end * tau, tail1 = e_end * (L * tau + tau * tau),
                     tail2 = e_end * (L * L * tau + 2 * L * tau * tau + 2 * tau * tau * tau);
        c.tail_estimate = last == 0.0 ? 0.0 : std::max({tail0 / i0, tail1 / i1, tail2 / i2});
    } else {
        c.tail_estimate = std::numeric_limits<double>::infinity();
    }
    return c;
}

}  // namespace hapticd::experiment
