// SPDX-License-Identifier: Apache-2.0
// How the library's non-template functions are provided: header-only (the default) or compiled.
//
// Header-only: every function is defined in the headers. The functions whose bodies use heavy
// templates (Eigen decompositions, the cost and optimum searches) are declared through
// HAPTICOPT_FUNC as `template <typename = void> inline`: a call looks the same, but a body, and every
// template it uses, is instantiated only in a translation unit that calls the function. Including
// the umbrella header therefore costs only what a translation unit calls.
//
// Compiled: with HAPTICOPT_COMPILED defined (linking the CMake target hapticopt::compiled does it) the
// headers only declare those functions; the static library libhapticopt_compiled, built once from
// src/hapticopt/compiled.cpp with HAPTICOPT_BUILDING_LIBRARY defined, defines them as ordinary
// functions. The templates and the optimiser classes' members stay in the headers in both modes.
// Results are identical in both modes (the same source; tests/packaging compares them). Every
// translation unit of a program uses the same mode.
// Measured compile times of both modes: docs/building.md ("Compile time of the library").
#pragma once

#if defined(HAPTICOPT_BUILDING_LIBRARY)
#define HAPTICOPT_FUNC
#define HAPTICOPT_DEFINITIONS 1
#elif defined(HAPTICOPT_COMPILED)
#define HAPTICOPT_FUNC
#define HAPTICOPT_DEFINITIONS 0
#else
#define HAPTICOPT_FUNC                           \
    template <typename HapticoptDeferred = void> \
    inline
#define HAPTICOPT_DEFINITIONS 1
#endif

// Member functions (and constructors) of the optimiser classes whose bodies use heavy templates: deferred the
// same way in every mode (they are defined in the headers, instantiated where they are called). A plain `inline`
// function, or a member function defined in its class, whose body reaches a cost, an optimum search or an Eigen
// decomposition is instantiated in every translation unit that includes its header: the ctest test
// compile_time.readme_example_vs_eigen (tests/compile_time/) fails when the README example's compile time grows.
#define HAPTICOPT_DEFERRED template <typename HapticoptDeferred = void>
