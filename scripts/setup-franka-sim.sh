#!/bin/sh
# Installs franka-sim 1.1.7 (a simulated Franka FR3 speaking FCI protocol v10) and franky-sim 1.0.4 (its FR3
# MuJoCo model) into <root>/target/franka-sim-venv, for vservo-franka's tests/franka_sim.rs and its example; and
# franky-sim 1.0.4 again, as a server of its own (a second, independent FCI server), into
# <root>/target/franky-sim-venv, with the pinocchio it starts with (pin 3.4.0 and the urdfdom 4 and tinyxml2 10 its
# library was built against: pip's resolver picks pin 2.7 beside franka-sim's numpy pin, which lacks
# `Frame.parentJoint`, and newer urdfdom/tinyxml2 wheels than pin 3.4's library loads).
#
# Usage: scripts/setup-franka-sim.sh [repository root]     (default: the current directory)
#
# Idempotent: does nothing when the venvs already have exactly these versions. Needs python3 with the venv
# module (Debian: apt-get install python3-venv) and PyPI; all packages are wheels, nothing is compiled.
# The tests find the venv under an ancestor directory of the crate, or at $FRANKA_SIM_VENV.
set -eu
ROOT=${1:-$(pwd)}
VENV="$ROOT/target/franka-sim-venv"
FRANKY_VENV="$ROOT/target/franky-sim-venv"
FRANKA_SIM=1.1.7
FRANKY_SIM=1.0.4
# franky-sim's own server: exactly these (each one's reason above)
FRANKY_PINS="franky-sim==$FRANKY_SIM pin==3.4.0 cmeel-urdfdom==4.0.1 cmeel-tinyxml2==10.0.0 mujoco==4.0.1"

installed() {
    "$VENV/bin/python" - "$FRANKA_SIM" "$FRANKY_SIM" <<'PY' 2>/dev/null
import importlib.metadata as m, sys
sys.exit(0 if (m.version("franka-sim"), m.version("franky-sim")) == (sys.argv[1], sys.argv[2]) else 1)
PY
}

franky_installed() {
    "$FRANKY_VENV/bin/python" - $FRANKY_PINS <<'PY' 2>/dev/null
import importlib.metadata as m, sys
sys.exit(0 if all(m.version(n) == v for n, v in (p.split("==") for p in sys.argv[1:])) else 1)
PY
}

mkdir -p "$ROOT/target"
if installed; then
    echo "franka-sim $FRANKA_SIM and franky-sim $FRANKY_SIM already installed in $VENV"
else
    [ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
    "$VENV/bin/python" -m pip install --disable-pip-version-check --quiet \
        "franka-sim==$FRANKA_SIM" "franky-sim==$FRANKY_SIM"
    installed || { echo "setup-franka-sim.sh: install into $VENV did not give the pinned versions" >&2; exit 1; }
    "$VENV/bin/python" -c 'import franka_sim.run_server, franky_sim, mujoco' # the server and its model import
    echo "installed franka-sim $FRANKA_SIM and franky-sim $FRANKY_SIM in $VENV"
fi
if franky_installed; then
    echo "franky-sim's server already installed in $FRANKY_VENV"
else
    [ -x "$FRANKY_VENV/bin/python" ] || python3 -m venv "$FRANKY_VENV"
    # shellcheck disable=SC2086 # the pins are words
    "$FRANKY_VENV/bin/python" -m pip install --disable-pip-version-check --quiet $FRANKY_PINS
    franky_installed || { echo "setup-franka-sim.sh: install into $FRANKY_VENV did not give the pins" >&2; exit 1; }
    "$FRANKY_VENV/bin/python" -c 'import franky_sim.run_server, pinocchio' # the server starts with this pinocchio
    echo "installed franky-sim $FRANKY_SIM's server in $FRANKY_VENV"
fi
