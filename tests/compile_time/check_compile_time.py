#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The README's C++ example, compiled header-only through the umbrella header, against an Eigen baseline.

Compiles, alternating, three times each (CCACHE_DISABLE=1, output to a temporary directory):
  1. the first ```cpp block of README.md (the library in a user's program: <hapticopt/hapticopt.hpp>, optimal_wall);
  2. an Eigen baseline: an 8x8 LU solve (Matrix<double, 8, 8>::lu().solve) and an EigenSolver<MatrixXd>,
with `CXX -std=c++17 -O2 -I include -I EIGEN -c` (what a user's build does; the compiler is the build's
CMAKE_CXX_COMPILER), measures each compilation's CPU time (user + system of the child, os.wait4) and peak
memory, and fails when median(example) / median(baseline) exceeds the threshold.

A ratio of CPU times measured in the same run, not wall time, so that a loaded machine does not make it flake:
both compilations slow down alike (at a load average of 5 the CPU seconds grew by about half, the ratio by a few
per cent). The threshold (docs/building.md, "Compile time of the library"): the ratio measured with g++ 12 on the
2-core build machine was 0.67-0.70; 1.05 is 1.5x the upper end. Each of the two faults it guards against fails it
alone: noise_budget.hpp's band and overshoot search as plain inline functions, instantiated by the umbrella header
in every translation unit (ratio 1.19), or the energy gradient through Eigen's product kernels (ratio 1.81); both
together measured 2.94.

Usage: check_compile_time.py --cxx CXX --source-dir DIR --eigen-include DIR [--threshold R] [--runs N]
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

BASELINE = """#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cstdio>

int main() {
  const Eigen::Matrix<double, 8, 8> a = Eigen::Matrix<double, 8, 8>::Random() + 8 * Eigen::Matrix<double, 8, 8>::Identity();
  const Eigen::Matrix<double, 8, 1> x = a.lu().solve(Eigen::Matrix<double, 8, 1>::Ones());
  const Eigen::EigenSolver<Eigen::MatrixXd> es(Eigen::MatrixXd(a), false);
  std::printf("%g %g\\n", x.sum(), es.eigenvalues().cwiseAbs().maxCoeff());
}
"""


def readme_example(source_dir):
    text = open(os.path.join(source_dir, "README.md"), encoding="utf-8").read()
    blocks = re.findall(r"```cpp\n(.*?)```", text, re.S)
    example = next((b for b in blocks if "hapticopt/hapticopt.hpp" in b and "int main" in b), None)
    if example is None:
        sys.exit("README.md has no ```cpp block with <hapticopt/hapticopt.hpp> and main()")
    return example


def compile_once(command):
    """CPU seconds (user + system) and peak resident memory (MB) of one compilation."""
    child = subprocess.Popen(command)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        sys.exit(f"compilation failed ({child.returncode}): {' '.join(command)}")
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cxx", required=True)
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--eigen-include", required=True, action="append")
    parser.add_argument("--threshold", type=float, default=1.05)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    os.environ["CCACHE_DISABLE"] = "1"
    with tempfile.TemporaryDirectory(prefix="hapticopt-compile-time-") as work:
        sources = {"README example": os.path.join(work, "readme_example.cpp"),
                   "Eigen baseline": os.path.join(work, "eigen_baseline.cpp")}
        with open(sources["README example"], "w", encoding="utf-8") as f:
            f.write(readme_example(args.source_dir))
        with open(sources["Eigen baseline"], "w", encoding="utf-8") as f:
            f.write(BASELINE)
        flags = ["-std=c++17", "-O2", "-I", os.path.join(args.source_dir, "include")]
        for d in args.eigen_include:
            flags += ["-I", d]
        cpu = {name: [] for name in sources}
        rss = {name: [] for name in sources}
        for run in range(args.runs):
            for name, source in sources.items():  # alternating, so both see the same load
                t, m = compile_once([args.cxx, *flags, "-c", source, "-o", os.path.join(work, "out.o")])
                cpu[name].append(t)
                rss[name].append(m)
                print(f"run {run + 1}: {name}: {t:.2f} s CPU, {m:.0f} MB")
    median = {name: statistics.median(v) for name, v in cpu.items()}
    ratio = median["README example"] / median["Eigen baseline"]
    print(f"compiler: {args.cxx}; flags: {' '.join(flags)} -c; load average: {os.getloadavg()[0]:.2f}")
    for name in sources:
        print(f"{name}: median {median[name]:.2f} s CPU, peak {max(rss[name]):.0f} MB")
    print(f"ratio README example / Eigen baseline: {ratio:.2f} (threshold {args.threshold:.2f})")
    if ratio > args.threshold:
        print("FAIL: the README example compiles too slowly against the Eigen baseline; a header probably "
              "instantiates heavy templates in translation units that do not call them (include/hapticopt/"
              "config.hpp: HAPTICOPT_FUNC, HAPTICOPT_DEFERRED), or a function on optimal_wall's path uses "
              "Eigen product expressions (docs/building.md, \"Compile time of the library\")")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
