#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# libFuzzer run of hapticd's parsers and decoders: builds every target of tests/fuzz/ with clang
# (-fsanitize=fuzzer,address,undefined) into build/fuzz and runs each for a bounded time over its seed
# corpus tests/fuzz/corpus/<target>/ (read only; new inputs go to build/fuzz/corpus/<target>/, crashes to
# build/fuzz/artifacts/). Installs clang-14 and libclang-rt-14-dev (which ships libclang_rt.fuzzer) from
# Debian 12 when missing. Exit status non-zero when a target finds a crash, a leak or a sanitizer report.
# Usage: scripts/fuzz.sh [seconds per target, default 20] [target...]
#   targets: config_file falcon_frames ftdi_strip hid_reports server_messages stream_framing recording (default: all)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
seconds="${1:-20}"
shift || true
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(config_file falcon_frames ftdi_strip hid_reports server_messages stream_framing recording)

cxx="${FUZZ_CXX:-clang++-14}"
fuzzer_lib=/usr/lib/llvm-14/lib/clang/14.0.6/lib/linux/libclang_rt.fuzzer-x86_64.a
if ! command -v "$cxx" >/dev/null 2>&1 || { [[ "$cxx" == clang++-14 ]] && [[ ! -f "$fuzzer_lib" ]]; }; then
  echo "fuzz.sh: installing clang-14 and libclang-rt-14-dev" >&2
  SUDO=""; [[ "$(id -u)" -eq 0 ]] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends clang-14 libclang-rt-14-dev >/dev/null
fi

declare -A sources=(
  [config_file]="src/config/config_file.cpp"
  [falcon_frames]="src/devices/falcon_protocol.cpp"
  [ftdi_strip]="src/devices/ftdi_protocol.cpp"
  [hid_reports]="src/devices/hid_ffb_protocol.cpp src/devices/hid_report_descriptor.cpp"
  [stream_framing]="src/server/stream_framing.cpp"
  [server_messages]="src/server/message_decoder.cpp src/server/reply_text.cpp src/server/object_limits.cpp src/client/object_json.cpp src/client/text_limits.cpp src/client/error_code.cpp"
  [recording]="src/daemon/recording_reader.cpp src/mesh/triangle_mesh.cpp src/mesh/mesh_hierarchy.cpp src/mesh/self_intersection.cpp src/mesh/vertex_normals.cpp"
)
# toml++ (Debian's libtomlplusplus-dev) is compiled into the config target header-only, so that its parser is
# instrumented too (linking Debian's uninstrumented libtomlplusplus.so would leave it out of the coverage). Known
# bugs of toml++ 3.3.0 (fixed upstream after it) would stop every run within seconds, so they pass as they pass
# in Debian's release build of the library: its debug assertions are logged, not fatal
# (tests/fuzz/toml_assert_policy.hpp), and UBSan's `unreachable` check is off for this target (toml++ issues
# #190/#295: a code point U+00A1..U+FEFF where it tests for whitespace reaches a __builtin_unreachable()).
declare -A extra_flags=(
  [config_file]="-DTOML_HEADER_ONLY=1 -include tests/fuzz/toml_assert_policy.hpp -fno-sanitize=unreachable"
  [server_messages]="-Iinclude"
  [recording]="-Iinclude -isystem /usr/include/eigen3"
)
out=build/fuzz
mkdir -p "$out/artifacts"
flags=(-std=c++20 -O1 -g -fno-omit-frame-pointer -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
       -Wall -Wextra -Wpedantic -Werror -Isrc)
# Each source is compiled to its own object (through ccache when it is installed: a later run compiles only what
# changed), two at a time, then each target is linked.
launcher=()
command -v ccache >/dev/null 2>&1 && launcher=(ccache)
compile() {  # compile <target> <source>: $out/obj/<target>/<source path with / as _>.o
  local object="$out/obj/$1/${2//\//_}.o"
  mkdir -p "$out/obj/$1"
  "${launcher[@]}" "$cxx" "${flags[@]}" ${extra_flags[$1]:-} -c "$2" -o "$object"
}
jobs_running=0
for t in "${targets[@]}"; do
  [[ -n "${sources[$t]:-}" ]] || { echo "fuzz.sh: unknown target '$t'" >&2; exit 2; }
  echo "fuzz.sh: building $out/fuzz_$t" >&2
  for source in "tests/fuzz/fuzz_$t.cpp" ${sources[$t]}; do
    if [[ $jobs_running -ge 2 ]]; then wait -n; jobs_running=$((jobs_running - 1)); fi
    compile "$t" "$source" &
    jobs_running=$((jobs_running + 1))
  done
done
while [[ $jobs_running -gt 0 ]]; do wait -n; jobs_running=$((jobs_running - 1)); done
for t in "${targets[@]}"; do
  objects=()
  for source in "tests/fuzz/fuzz_$t.cpp" ${sources[$t]}; do objects+=("$out/obj/$t/${source//\//_}.o"); done
  "$cxx" "${flags[@]}" "${objects[@]}" -o "$out/fuzz_$t"
done

status=0
norandom=(setarch "$(uname -m)" -R)
for t in "${targets[@]}"; do
  mkdir -p "$out/corpus/$t"
  echo "fuzz.sh: running fuzz_$t for ${seconds}s" >&2
  if ! ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      "${norandom[@]}" "$out/fuzz_$t" -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$out/artifacts/$t-" \
      "$out/corpus/$t" "tests/fuzz/corpus/$t" 2>"$out/fuzz_$t.log"; then
    echo "fuzz.sh: fuzz_$t FAILED (log: $out/fuzz_$t.log, inputs: $out/artifacts/$t-*)" >&2
    tail -40 "$out/fuzz_$t.log" >&2
    status=1
  fi
  execs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$out/fuzz_$t.log" | grep -o '[0-9]*$' || echo '?')"
  cov="$(grep -o 'cov: [0-9]*' "$out/fuzz_$t.log" | tail -1 || true)"
  echo "fuzz_$t: executions $execs, $cov, corpus $(ls "$out/corpus/$t" | wc -l) new + $(ls "tests/fuzz/corpus/$t" | wc -l) seeds"
done
exit "$status"
