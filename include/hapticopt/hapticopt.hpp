// hapticopt: stability, step-response criteria and optimal gains of a sampled-data virtual wall
// (Hulin, Gonzalez Camarero, Albu-Schaeffer, IROS 2011), header-only. Include this for everything.
#pragma once

#include "characteristic_polynomial.hpp"
#include "closed_loop.hpp"
#include "criterion.hpp"
#include "energy_costs.hpp"
#include "errors.hpp"
#include "exponential_integrals.hpp"
#include "loop_schur_form.hpp"
#include "optimal_wall.hpp"
#include "optimum.hpp"
#include "overshoot.hpp"
#include "parameters.hpp"
#include "sampled_plant.hpp"
#include "scalar_search.hpp"
#include "schur_cohn.hpp"
#include "stability.hpp"
#include "stability_region.hpp"
#include "stein_equation.hpp"
#include "step_response.hpp"
#include "version.hpp"
