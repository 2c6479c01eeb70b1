#!/usr/bin/env bash
# The README's main command. Until the real-time daemon exists (vservod, next on the issue list), it runs the
# simulated cell of the default configuration — PUMA 560 dynamics, rendered camera images, the paper's LQ
# servo — in the lockstep simulator, and writes its summary, data and figures to sim-out/.
# Extra arguments go to `vservoctl sim` (for example --controller delay-aware, or --config another file).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo build --release --locked -q -p vservoctl
exec ./target/release/vservoctl sim --config config/vservo.toml --out sim-out "$@"
