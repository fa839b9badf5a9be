// SPDX-License-Identifier: Apache-2.0
// The step-response criteria (Hulin et al., IROS 2011, eqs. 4-9) measured from a recorded trial.
//
// Between two samples the motion is reconstructed from the samples themselves and the force known to act
// in that period: with the profile's plant m x'' + b x' + k x = u (eq. 1) and u piecewise constant (the
// force written n periods earlier, two pieces when the device's inherent delay n + phi is fractional),
// the position at both ends of the period, x_j and x_{j+1}, fixes the velocity at its start,
//     x_{j+1} = [Phi_T]_00 x_j + [Phi_T]_01 v_j + c_j   =>   v_j = (x_{j+1} - [Phi_T]_00 x_j - c_j) / [Phi_T]_01,
// and the exact ZOH solution inside the period follows (zoh_plant.hpp). The measured samples anchor every
// period; the model only shapes the curve between them (on the simulated device the reconstruction is
// exact). The integrals of eqs. 6-8,
//     C_Ep = (1 / (T^(p+1) E(0))) \int_0^L E(t) t^p dt,  E = 1/2 (K + k) (x - x_inf)^2 + 1/2 m x'^2,
//     x_inf = F / (K + k),  E(0) = F^2 / (2 (K + k)),
// the same normalisation as hapticopt/energy_costs.hpp, are summed with 8-point Gauss-Legendre per piece
// (exact to rounding for these smooth pieces), with t = 0 when the step reaches the plant (the device's
// inherent delay after tick 0; the step is written directly, the wall force goes through the delay buffer).
// C_OV = (max_t x(t) - x_inf) / x_inf (eq. 9, clamped at 0) uses the continuous maximum: where the
// velocity changes sign towards the equilibrium inside a piece, the zero is bisected (1e-15 T).
// The recording is finite: tail_estimate bounds the part of the integrals beyond it from the energy's
// decay over the last two windows of 100 periods (relative to each integral; +inf when not decaying).
#pragma once

#include <cstddef>

#include "experiment/experiment_trial.hpp"

namespace hapticd::experiment {

struct CostModel {
    double mass = 0.3;            // kg
    double damping = 0.0;         // b, N s/m
    double stiffness = 0.0;       // k, N/m
    double period = 1e-3;         // T, s
    double inherent_delay = 0.0;  // the device's own delay, s (the step's arrival; the buffer is not in it)
};

struct MeasuredCosts {
    double ce0 = 0.0, ce1 = 0.0, ce2 = 0.0;  // eqs. 6-8
    double overshoot = 0.0;                  // eq. 9, >= 0
    double tail_estimate = 0.0;              // relative truncation of the integrals (largest of the three)
};

// Throws std::invalid_argument when the record is too short (fewer than n + 3 samples).
MeasuredCosts measure_costs(const TrialRecord& record, const TrialSettings& trial, const CostModel& model);

// Vertex of the parabola through (x0, y0), (x1, y1), (x2, y2) with x0 < x1 < x2 and y1 <= y0, y2; the
// refinement of a grid minimum (returns x1 when the three points are collinear).
double parabola_vertex(double x0, double y0, double x1, double y1, double x2, double y2);

}  // namespace hapticd::experiment
