#!/usr/bin/env bash
# Install dependencies, build the `release` preset and start the daemon for a
# short demo run.  Extra arguments are passed on to hapticd.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/install-deps.sh

cmake --preset release
cmake --build --preset release -j"$(nproc)"

hapticd=build/release/apps/hapticd/hapticd
cli=build/release/apps/hapticopt/hapticopt
if [[ -x "$hapticd" ]]; then
  exec "$hapticd" --criterion CE2 --duration 3 "$@"
elif [[ -x "$cli" ]]; then
  echo "run-hapticd: $hapticd not built; running the hapticopt CLI instead" >&2
  # Falcon with a hand on it (Table II: 0.30 kg), 1 kHz, 1 ms loop delay.
  exec "$cli" optimum --criterion CE2 --mass 0.30 --period 0.001 --time-delay 0.001
else
  echo "run-hapticd: neither $hapticd nor $cli was built" >&2
  exit 1
fi
