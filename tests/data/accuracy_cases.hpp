// The loops of the run-time-against-error benchmarks (accuracy_benchmarks.cpp) and of their reference
// values (make_accuracy_reference.cpp -> accuracy_reference.csv): gamma = delta = 0 (the paper's
// tables' first rows), one stable gain pair per delay d = 0, 1, 6.
//   d = 0: the C_E0 optimum of Table III (0.3220, 0.9800);  d = 1: the C_E2 optimum of Table IV
//   (0.0582, 0.3796);  d = 6: the d = 1 point scaled like the stable region, alpha (2/7)^2, beta 2/7.
#pragma once

namespace hapticopt::accuracy {

struct Case {
    double d, gamma, delta, alpha, beta;
};

inline constexpr Case kCases[] = {
    {0.0, 0.0, 0.0, 0.3220, 0.9800},
    {1.0, 0.0, 0.0, 0.0582, 0.3796},
    {6.0, 0.0, 0.0, 0.0582 * 4.0 / 49.0, 0.3796 * 2.0 / 7.0},
};

}  // namespace hapticopt::accuracy
