# SPDX-License-Identifier: Apache-2.0
# Stage timing for the CI scripts (sourced by scripts/build-and-test.sh and scripts/sanitize.sh, not run).
#   stage NAME CMD [ARG...]  runs CMD in the current shell (a function or a program) and appends
#                            "NAME<TAB>wall s<TAB>CPU s<TAB>exit status" to the file $HAPTICD_STAGE_LOG;
#                            returns CMD's exit status.
#   stage_times_owner        called once by the outermost script: creates $HAPTICD_STAGE_LOG when it is not set
#                            and prints the table (and the stage that was running, if any) when the script
#                            exits, whether it passed, failed or was interrupted. A nested script (sanitize.sh
#                            run by build-and-test.sh) appends to the same file and prints nothing.
# Wall time from the monotonic seconds of `date +%s.%N`; CPU time is the user + system time of the stage's
# finished child processes and their waited-for descendants (bash's `times`, read without a subshell, whose
# own counters would start at zero), so a compiler run by ninja run by cmake is counted. On a machine shared
# with other builds the CPU column is the comparable one; the wall column is what a CI run waits.

_stage_now() { date +%s.%N; }

# Sets _stage_cpu to the children's user + system seconds of this shell so far (the second line of `times`, e.g.
# "1m2.5s 0m0.4s"); called directly, never in $(...), whose subshell has no children of its own.
_stage_children_cpu() {
  local file="${HAPTICD_STAGE_LOG}.times.$$"
  times >"$file"
  _stage_cpu="$(awk 'NR == 2 { total = 0
                               for (i = 1; i <= 2; ++i) { split($i, p, "m"); sub("s", "", p[2]); total += p[1] * 60 + p[2] }
                               printf "%.2f\n", total }' "$file")"
  rm -f "$file"
}

stage() {
  local name="$1"
  shift
  printf '\n=== %s (%s) ===\n' "$name" "$(date +%H:%M:%S)"
  _stage_running="$name"
  _stage_started="$(_stage_now)"
  local cpu0 cpu1 end status=0
  _stage_children_cpu
  cpu0="$_stage_cpu"
  "$@" || status=$?
  end="$(_stage_now)"
  _stage_children_cpu
  cpu1="$_stage_cpu"
  printf '%s\t%.1f\t%.1f\t%d\n' "$name" "$(awk -v a="$_stage_started" -v b="$end" 'BEGIN { print b - a }')" \
    "$(awk -v a="$cpu0" -v b="$cpu1" 'BEGIN { print b - a }')" "$status" >>"$HAPTICD_STAGE_LOG"
  _stage_running=""
  return "$status"
}

_stage_print_table() {
  local exit_status=$?
  local running_wall=""
  if [[ -n "${_stage_running:-}" ]]; then
    running_wall="$(awk -v a="$_stage_started" -v b="$(_stage_now)" 'BEGIN { printf "%.1f", b - a }')"
  fi
  printf '\n=== stage times (%s, exit status %d) ===\n' "$(basename "$0")" "$exit_status"
  awk -F '\t' -v running="${_stage_running:-}" -v running_wall="$running_wall" '
    BEGIN { printf "%-58s %9s %9s  %s\n", "stage", "wall s", "CPU s", "status" }
    { printf "%-58s %9.1f %9.1f  %s\n", $1, $2, $3, ($4 == 0 ? "ok" : "FAILED (" $4 ")"); wall += $2; cpu += $3 }
    END {
      if (running != "") { printf "%-58s %9.1f %9s  %s\n", running, running_wall, "-", "interrupted"; wall += running_wall }
      printf "%-58s %9.1f %9.1f\n", "total", wall, cpu
    }' "$HAPTICD_STAGE_LOG"
  rm -f "$HAPTICD_STAGE_LOG"
  return "$exit_status"
}

stage_times_owner() {
  if [[ -z "${HAPTICD_STAGE_LOG:-}" ]]; then
    HAPTICD_STAGE_LOG="$(mktemp "${TMPDIR:-/tmp}/hapticd-stages.XXXXXX")"
    export HAPTICD_STAGE_LOG
    trap _stage_print_table EXIT
  fi
}
