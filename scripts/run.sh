#!/usr/bin/env bash
# The README's main command: the vservo daemon on the default configuration — the simulated cell (PUMA 560
# dynamics, rendered camera images, the paper's LQ servo on the translation step) as four real-time processes
# over iceoryx2 shared memory. It prints a one-line status every second; Ctrl-C (SIGINT) or SIGTERM ramps the
# arm to rest and stops. Extra arguments go to vservod; `--config FILE` (or --config=FILE) takes the place of the
# default configuration (for example --config config/scenarios/rotation-step.toml).
# The lockstep simulator of the same configuration: ./target/release/vservoctl sim --out sim-out
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# the binaries VSERVO_BIN_DIR names (already built: the README test passes its own), else a release build
bin="${VSERVO_BIN_DIR:-}"
if [ -z "$bin" ]; then
    cargo build --release --locked -q -p vservod -p vservoctl
    bin=./target/release
fi
# the default configuration unless the arguments name one
config=(--config config/vservo.toml)
for arg in "$@"; do
    case "$arg" in --config|--config=*) config=() ;; esac
done
exec "$bin/vservod" ${config[@]+"${config[@]}"} "$@"
