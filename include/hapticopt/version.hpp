// SPDX-License-Identifier: Apache-2.0
// hapticopt: optimal virtual-wall tuning for sampled-data haptic rendering.
#pragma once

#define HAPTICOPT_VERSION_MAJOR 0
#define HAPTICOPT_VERSION_MINOR 1
#define HAPTICOPT_VERSION_PATCH 0
#define HAPTICOPT_VERSION_STRING "0.1.0"
