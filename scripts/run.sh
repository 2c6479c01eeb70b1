#!/usr/bin/env bash
# The README's main command. Until the daemon exists it shows the arm model at the nominal pose qn
# (the desired pose of the paper's experiments). Extra arguments go to `vservoctl model`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
if [ "$#" -eq 0 ]; then set -- --q qn; fi
exec cargo run --release --locked -q -p vservoctl -- model "$@"
