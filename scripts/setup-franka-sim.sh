#!/bin/sh
# Installs franka-sim 1.1.7 (a simulated Franka FR3 speaking FCI protocol v10) and franky-sim 1.0.4 (its FR3
# MuJoCo model) into <root>/target/franka-sim-venv, for vservo-franka's tests/franka_sim.rs and its example.
#
# Usage: scripts/setup-franka-sim.sh [repository root]     (default: the current directory)
#
# Idempotent: does nothing when the venv already has exactly these versions. Needs python3 with the venv
# module (Debian: apt-get install python3-venv) and PyPI; all packages are wheels, nothing is compiled.
# The tests find the venv under an ancestor directory of the crate, or at $FRANKA_SIM_VENV.
set -eu
ROOT=${1:-$(pwd)}
VENV="$ROOT/target/franka-sim-venv"
FRANKA_SIM=1.1.7
FRANKY_SIM=1.0.4

installed() {
    "$VENV/bin/python" - "$FRANKA_SIM" "$FRANKY_SIM" <<'PY' 2>/dev/null
import importlib.metadata as m, sys
sys.exit(0 if (m.version("franka-sim"), m.version("franky-sim")) == (sys.argv[1], sys.argv[2]) else 1)
PY
}

if installed; then
    echo "franka-sim $FRANKA_SIM and franky-sim $FRANKY_SIM already installed in $VENV"
    exit 0
fi
mkdir -p "$ROOT/target"
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --disable-pip-version-check --quiet \
    "franka-sim==$FRANKA_SIM" "franky-sim==$FRANKY_SIM"
installed || { echo "setup-franka-sim.sh: install into $VENV did not give the pinned versions" >&2; exit 1; }
"$VENV/bin/python" -c 'import franka_sim.run_server, franky_sim, mujoco' # the server and its model import
echo "installed franka-sim $FRANKA_SIM and franky-sim $FRANKY_SIM in $VENV"
