// SPDX-License-Identifier: Apache-2.0
// The compiled mode of the hapticopt library (include/hapticopt/config.hpp): this translation unit
// defines, once, every function the headers declare through HAPTICOPT_FUNC. Programs that link the
// CMake target hapticopt::compiled get HAPTICOPT_COMPILED defined and see only their declarations.
#ifndef HAPTICOPT_BUILDING_LIBRARY
#error "src/hapticopt/compiled.cpp is compiled with HAPTICOPT_BUILDING_LIBRARY defined (target hapticopt_compiled)"
#endif

#include <hapticopt/hapticopt.hpp>
