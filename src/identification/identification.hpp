// SPDX-License-Identifier: Apache-2.0
// Identification of the device's plant from a recorded excitation (pure estimation, no device).
//
// Model (eq. 1 of the paper, per axis):  m x'' + b x' + k x = u(t - tau) + F0,  tau = d T = (n + f) T,
// n = floor(d), 0 <= f < 1, u the force written by the loop (zero-order hold: u(t) = u_j on [jT, (j+1)T)),
// F0 an unknown constant force (a resting hand, gravity), T the period. Data: y_j = x(jT) + e_j, the
// position read at tick j (before u_j is written; e_j measurement noise and quantisation), u_j written at
// tick j, u_j = 0 for j < 0.
//
// Exact sampled model (the device's own physics, no approximation): over period j the plant sees
// F0 + u_{j-n-1} during [jT, jT + fT) and F0 + u_{j-n} during [jT + fT, (j+1)T), so with
//   [Phi_h Gamma_h; 0 1] = expm([A B; 0 0] h),  A = [0 1; -k/m -b/m],  B = [0; 1/m]   (zoh_plant.hpp)
//   s_{j+1} = Phi_{(1-f)T} (Phi_{fT} s_j + Gamma_{fT} (F0 + u_{j-n-1})) + Gamma_{(1-f)T} (F0 + u_{j-n}),
//   x_j = [1 0] s_j,   s_0 = (x0, v0).
// For f = 0 this is the one-step ZOH discretisation; the response is continuous in d across integers.
//
// Estimator (output error = maximum likelihood for white Gaussian measurement noise):
//  1. ARX start (the same model as a difference equation, exact without noise): for every n in
//     0..max_delay, least squares (then two instrumental-variable passes against the noise bias) of
//        y_{j+1} = a1 y_j + a2 y_{j-1} + c0 u_{j-n} + c1 u_{j-n-1} + c2 u_{j-n-2} + c
//     (three input taps hold any f in [0, 1)); the n of least residual and the exact map back:
//     the discrete poles are z_i = exp(s_i T) (ZOH), so z1 z2 = -a2 gives b/m = -ln(-a2)/T and
//     k/m = s1 s2 (real or complex pair); the input gain: the numerator sum c0+c1+c2 = N(1) of the
//     unit-mass model divided by m, N_unit(1) = Gamma_x (1 - Phi_vv) + Phi_xv Gamma_v (any f), so
//     m = N_unit(1) / (c0+c1+c2), F0 = c / (c0+c1+c2). The instruments are the noise-free simulated
//     output of the previous pass; the fit only starts step 2, which is also started from the pure
//     mass (b = k = 0) with the ARX mass.
//  2. Output error: for a delay d, Levenberg-Marquardt on theta = (m, b, k, x0, v0, F0) minimising
//     R(d) = sum_j (y_j - x_j(theta, d))^2 (Jacobian by central differences for m, b, k, exact columns
//     for the linear x0, v0, F0). R(d) is profiled on a grid of d (every 0.5 period over
//     0 .. max_delay + 0.5, then +-0.25 around the best), then minimised in d by golden section over
//     +-0.25 period (tolerance 1e-4 periods).
//  3. Uncertainty: sigma^2 = R / (N - 7), Cov(m, b, k, d, x0, v0, F0) = sigma^2 (J^T J)^{-1} with J the
//     Jacobian of the model output in all seven parameters at the optimum (d column by central
//     differences of 1e-3 periods; at an integer d the model has a kink in d and this is the mean of the
//     two one-sided slopes). The standard errors are the square roots of the diagonal: this is the
//     asymptotic least-squares covariance in (m, b, k, d) directly, so no further delta step is needed
//     for them; the gains K, B get theirs by the delta method (identification_run.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace hapticd {

struct PlantEstimate {
    double mass = 1.0;           // kg (kg m^2)
    double damping = 0.0;        // N s/m
    double stiffness = 0.0;      // N/m
    double delay_periods = 0.0;  // d = tau / T
    double x0 = 0.0;             // position at tick 0, m
    double v0 = 0.0;             // velocity at tick 0, m/s
    double offset_force = 0.0;   // F0, N
};

struct IdentificationData {
    double period = 1e-3;          // s
    std::vector<double> force;     // u_j, written at tick j
    std::vector<double> position;  // y_j, read at tick j before u_j was written
};

struct IdentificationSettings {
    int max_delay_periods = 20;     // integer delays tried by the ARX start
    double delay_grid_step = 0.25;  // periods
    double delay_tolerance = 1e-4;  // periods, golden section
    int max_iterations = 60;        // Levenberg-Marquardt
};

struct IdentificationResult {
    bool ok = false;
    std::string message;  // why not ok
    double mass = 0.0, mass_stderr = 0.0;
    double damping = 0.0, damping_stderr = 0.0;
    double stiffness = 0.0, stiffness_stderr = 0.0;
    double delay_periods = 0.0, delay_stderr = 0.0;  // periods
    long long delay_whole = 0;                       // floor(delay_periods)
    double delay_fraction = 0.0;                     // delay_periods - delay_whole
    double offset_force = 0.0, offset_force_stderr = 0.0;
    double x0 = 0.0, v0 = 0.0;
    double residual_rms = 0.0;  // m, sqrt(R / N)
    std::size_t samples = 0;
    int arx_delay = -1;                   // integer delay chosen by the ARX start
    double period = 0.0;                  // s
    std::array<double, 16> covariance{};  // row-major 4x4 of (m, b, k, d)
};

// The exact sampled response x_j, j = 0..force.size()-1, of the model above.
std::vector<double> simulate_sampled_plant(const PlantEstimate& plant, double period, const std::vector<double>& force);

struct ArxFit {
    int delay = 0;
    double a1 = 0.0, a2 = 0.0;
    std::array<double, 3> c{};  // input taps at lags n, n+1, n+2
    double constant = 0.0;
    double rss = 0.0;
};

// Least-squares ARX fit for the integer delay n (nullopt when the data are too short or singular).
std::optional<ArxFit> fit_arx(const IdentificationData& data, int n);
// The exact map of an ARX fit to (m, b, k, F0) (delay = n); nullopt when the poles are not those of a
// sampled mass-damper-spring (z1 z2 <= 0, a non-positive real pole, or a non-positive gain).
std::optional<PlantEstimate> arx_to_plant(const ArxFit& fit, double period);

IdentificationResult identify_plant(const IdentificationData& data, const IdentificationSettings& settings = {});

}  // namespace hapticd
