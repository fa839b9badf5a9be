#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# CPU seconds (user + system) and maximum resident set size of compiling, one after the other:
#   1. the README example through the umbrella header, header-only;
#   2. the same example through hapticopt/optimal_wall.hpp alone, header-only;
#   3. the same example through the umbrella header in compiled mode (-DHAPTICOPT_COMPILED), then
#      linked against the compiled library to prove it complete (needs BUILD_DIR, below);
#   4. the compiled library's own translation unit (src/hapticopt/compiled.cpp), built once;
#   5. Eigen baselines: an 8x8 LU solve plus an EigenSolver (Eigen/Dense + Eigen/Eigenvalues), and
#      Eigen/Dense with a 3x3 inverse.
# Every TU is compiled as `$CXX -std=c++17 -O2 -c` (ccache is not involved), measured with
# /usr/bin/time. Prints a Markdown table (docs/building.md, "Compile time of the library").
# Usage: scripts/measure-compile-time.sh [--base REVISION] [BUILD_DIR]   (default build/release; CXX defaults to g++)
# With --base, the table starts with rows 1 and 2 compiled against include/ of REVISION (git archive), so
# that the figures before and after a change come from the same run.
#
#        scripts/measure-compile-time.sh --project-sample BASE_REVISION [BUILD_DIR]
# compiles instead a sample of the project's own translation units (the list below, or $SAMPLE), each with its
# command from BUILD_DIR/compile_commands.json, ccache disabled, once against include/ of BASE_REVISION
# (git archive), once against the working tree's include/ and once more with -DHAPTICOPT_COMPILED (compile
# only: what a TU would cost if its target linked hapticopt::compiled), and prints CPU seconds of each.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if [[ "${1:-}" == --project-sample ]]; then
  base=${2:?"--project-sample needs a base revision"}
  build_dir=${3:-build/release}
  old=$(mktemp -d)
  trap 'rm -rf "$old"' EXIT
  git archive "$base" include | tar -x -C "$old"
  sample=(src/tuning/tuning.cpp tests/core/test_stability.cpp tests/core/test_paper_tables.cpp
          tests/daemon/test_robust.cpp "$build_dir/tests/packaging/generated/two_tu_a.cpp"
          "$build_dir/tests/packaging/generated/selfcontained_hapticopt_robust_optimum_hpp.cpp")
  if [[ -n "${SAMPLE:-}" ]]; then read -ra sample <<< "$SAMPLE"; fi  # another list, space-separated
  CCACHE_DISABLE=1 python3 - "$build_dir" "$PWD/include" "$old/include" "$base" "${sample[@]}" <<'PY'
import json, os, resource, shlex, subprocess, sys
build, new_inc, old_inc, base, files = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5:]
commands = {os.path.relpath(c["file"], os.path.dirname(new_inc)): c for c in json.load(open(os.path.join(build, "compile_commands.json")))}
def cpu(cmd, cwd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, cwd=cwd, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
print(f"| translation unit | CPU s with include/ of {base} | CPU s now, header-only | CPU s now, -DHAPTICOPT_COMPILED |")
print("|---|---|---|---|")
total = [0.0, 0.0, 0.0]
for f in files:
    c = commands[f]
    args = shlex.split(c["command"])
    args = [a for a in args if a not in ("ccache", "/usr/bin/ccache")]
    out = ["-o", "/dev/null"]
    i = args.index("-o"); args[i:i + 2] = out
    row = []
    for k, (inc, extra) in enumerate(((old_inc, []), (new_inc, []), (new_inc, ["-DHAPTICOPT_COMPILED"]))):
        # The base revision's headers come first; the current include/ stays behind them, for the
        # headers the base revision does not have (the generated TUs include every current header).
        a = [args[0], "-I" + inc] + extra + args[1:]
        t = cpu(a, c["directory"]); total[k] += t; row.append(t)
    print(f"| {f} | {row[0]:.1f} | {row[1]:.1f} | {row[2]:.1f} |")
print(f"| total of the sample | {total[0]:.1f} | {total[1]:.1f} | {total[2]:.1f} |")
PY
  exit 0
fi
base=""
if [[ "${1:-}" == --base ]]; then
  base=${2:?"--base needs a revision"}
  shift 2
fi
build_dir=${1:-build/release}
cxx=${CXX:-g++}
eigen_include=$(pkg-config --cflags-only-I eigen3 2>/dev/null || echo -I/usr/include/eigen3)
flags=(-std=c++17 -O2 -Iinclude ${eigen_include})
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

readme_body='#include <cstdio>

int main() {
  const hapticopt::PhysicalPlant plant{/*mass*/ 0.30, /*damping*/ 0.0, /*stiffness*/ 0.0,
                                       /*period*/ 0.001, /*time_delay*/ 0.001};
  const auto wall = hapticopt::optimal_wall(hapticopt::Criterion::CE2, plant);
  std::printf("K = %.1f N/m, B = %.2f N s/m, K/K_max = %.3f\n", wall.K, wall.B, wall.stability_margin());
}'
printf '#include <hapticopt/hapticopt.hpp>\n%s\n' "$readme_body" > "$work/readme_umbrella.cpp"
printf '#include <hapticopt/optimal_wall.hpp>\n%s\n' "$readme_body" > "$work/readme_optimal_wall.cpp"
cat > "$work/eigen_lu_eigensolver.cpp" <<'CPP'
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cstdio>

int main() {
  const Eigen::Matrix<double, 8, 8> a = Eigen::Matrix<double, 8, 8>::Random() + 8 * Eigen::Matrix<double, 8, 8>::Identity();
  const Eigen::Matrix<double, 8, 1> x = a.partialPivLu().solve(Eigen::Matrix<double, 8, 1>::Ones());
  const Eigen::EigenSolver<Eigen::MatrixXd> es(Eigen::MatrixXd(a), false);
  std::printf("%g %g\n", x.sum(), es.eigenvalues().cwiseAbs().maxCoeff());
}
CPP
cat > "$work/eigen_inverse3.cpp" <<'CPP'
#include <Eigen/Dense>
#include <cstdio>

int main() {
  const Eigen::Matrix3d a = Eigen::Matrix3d::Random() + 3 * Eigen::Matrix3d::Identity();
  std::printf("%g\n", a.inverse().sum());
}
CPP

# measure NAME FILE [extra flags...]: one compile, prints a table row
measure() {
  local name=$1 file=$2
  shift 2
  /usr/bin/time -f '%U %S %M' -o "$work/time" "$cxx" "${flags[@]}" "$@" -c "$file" -o "$work/out.o"
  read -r user sys rss < "$work/time"
  awk -v n="$name" -v u="$user" -v s="$sys" -v r="$rss" \
    'BEGIN { printf "| %s | %.1f | %.0f |\n", n, u + s, r / 1024 }'
}

echo "Compiler: $($cxx --version | head -n1); flags: ${flags[*]} -c; $(nproc) cores; load before: $(cut -d' ' -f1 /proc/loadavg)"
echo
echo "| translation unit | CPU s (user + sys) | max RSS MB |"
echo "|---|---|---|"
if [[ -n "$base" ]]; then
  mkdir "$work/base"
  git archive "$base" include | tar -x -C "$work/base"
  # measure_base NAME FILE: as measure, with the base revision's include/ in place of the working tree's
  measure_base() {
    /usr/bin/time -f '%U %S %M' -o "$work/time" "$cxx" -std=c++17 -O2 -I"$work/base/include" ${eigen_include} -c "$2" -o "$work/out.o"
    read -r user sys rss < "$work/time"
    awk -v n="$1" -v u="$user" -v s="$sys" -v r="$rss" 'BEGIN { printf "| %s | %.1f | %.0f |\n", n, u + s, r / 1024 }'
  }
  measure_base "README example, umbrella hapticopt.hpp, header-only, include/ of $base" "$work/readme_umbrella.cpp"
  measure_base "README example, optimal_wall.hpp only, header-only, include/ of $base" "$work/readme_optimal_wall.cpp"
fi
measure "README example, umbrella hapticopt.hpp, header-only" "$work/readme_umbrella.cpp"
measure "README example, optimal_wall.hpp only, header-only" "$work/readme_optimal_wall.cpp"
measure "README example, umbrella, compiled mode (-DHAPTICOPT_COMPILED)" "$work/readme_umbrella.cpp" -DHAPTICOPT_COMPILED
cp "$work/out.o" "$work/readme_compiled.o"
measure "the compiled library itself (src/hapticopt/compiled.cpp, once)" src/hapticopt/compiled.cpp -DHAPTICOPT_BUILDING_LIBRARY
measure "Eigen baseline: 8x8 LU + EigenSolver" "$work/eigen_lu_eigensolver.cpp"
measure "Eigen baseline: Eigen/Dense, 3x3 inverse" "$work/eigen_inverse3.cpp"

library="$build_dir/libhapticopt_compiled.a"
if [[ -f "$library" ]]; then
  "$cxx" "$work/readme_compiled.o" "$library" -o "$work/readme_compiled"
  echo
  echo "compiled-mode example linked against $library and run: $("$work/readme_compiled")"
else
  echo
  echo "($library not built: the compiled-mode example was compiled but not linked;"
  echo " cmake --build --preset release --target hapticopt_compiled)"
fi
