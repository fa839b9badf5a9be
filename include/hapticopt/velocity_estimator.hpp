// SPDX-License-Identifier: Apache-2.0
// The wall's velocity estimator and everything the library computes with it, in one include: the estimator's types
// (estimator_types.hpp), the loop with it (estimator_loop.hpp), its stability (estimator_stability.hpp), costs
// (estimator_costs.hpp), their gradient (estimator_gradient.hpp), the quantisation force noise (estimator_noise.hpp),
// the main stable region (estimator_region.hpp) and the optimum (estimator_optimum.hpp). Each of those includes only
// what it uses; include one of them for less compile time.
#pragma once

#include "estimator_costs.hpp"
#include "estimator_gradient.hpp"
#include "estimator_loop.hpp"
#include "estimator_noise.hpp"
#include "estimator_optimum.hpp"
#include "estimator_region.hpp"
#include "estimator_stability.hpp"
#include "estimator_types.hpp"
