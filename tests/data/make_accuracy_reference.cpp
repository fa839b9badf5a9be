// Writes tests/data/accuracy_reference.csv: the reference values of the run-time-against-error
// benchmarks (tests/benchmarks/accuracy_benchmarks.cpp), computed once in long double (64-bit
// mantissa, ~1e-19) with the library's public templates: energy_costs<long double> (closed form) and
// overshoot<long double> (exact continuous maximum). Double-precision methods are then measured
// against values ~1000 times more precise than themselves. (The closed form itself is checked against
// independent time-stepping in tests/core and tests/stress.)
// Build: target hapticopt_accuracy_reference (tests/benchmarks/CMakeLists.txt); run:
//   <build>/tests/benchmarks/hapticopt_accuracy_reference > tests/data/accuracy_reference.csv
#include <cstdio>

#include <hapticopt/hapticopt.hpp>

#include "accuracy_cases.hpp"

int main() {
    using LD = long double;
    std::printf(
        "# Reference values for tests/benchmarks/accuracy_benchmarks.cpp, long double, made by\n"
        "# tests/data/make_accuracy_reference.cpp (see there). overshoot = C_OV (relative to x_inf).\n"
        "d,gamma,delta,alpha,beta,ce0,ce1,ce2,overshoot\n");
    for (const auto& c : hapticopt::accuracy::kCases) {
        const hapticopt::NormalizedPlant plant{c.gamma, c.delta, c.d};
        const hapticopt::SampledPlant<LD> sampled(plant);
        if (!hapticopt::loop_is_stable(sampled, LD(c.alpha), LD(c.beta))) return 1;
        const auto e = hapticopt::energy_costs<LD>(sampled, LD(c.alpha), LD(c.beta));
        hapticopt::OvershootOptions opt;
        opt.tolerance = 1e-300;
        const auto ov = hapticopt::overshoot<LD>(sampled, LD(c.alpha), LD(c.beta), opt);
        if (!ov.converged) return 1;
        std::printf("%.17g,%.17g,%.17g,%.17g,%.17g,%.21Lg,%.21Lg,%.21Lg,%.21Lg\n", c.d, c.gamma, c.delta, c.alpha,
                    c.beta, e.ce0, e.ce1, e.ce2, ov.value);
    }
    return 0;
}
