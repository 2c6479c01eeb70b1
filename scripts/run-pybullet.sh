#!/usr/bin/env bash
# vservod with an external robot and camera: the PyBullet reference driver (clients/python/pybullet_driver.py)
# simulates the arm of a URDF and the board in PyBullet, takes vservo's joint commands and publishes joint states
# and rendered camera frames over the driver contract of docs/DRIVERS.md. Runs the cell of --config (a
# configuration whose arm vservo models from a URDF, with robot.driver = "external" and camera.source =
# "external") for --duration-s seconds (default 20), then stops both and prints the final feature error and the
# settling time; with --json the last line is one JSON object (final_error_px, settling_time_s, …). Logs, the
# scene, the first camera image (first.pgm) and the recorded features are left in target/pybullet-run/NAME-PID/ (`latest` links the last; the summary's run_folder names it).
#
#   scripts/run-pybullet.sh --config FILE [--urdf FILE] [--instance NAME] [--duration-s S] [--held-s S]
#                           [--velocity-lag-s S] [--json]
#
# --held-s S: the cell starts held, as a real arm's does (robot.start = "held"): S seconds of its twists, joint
# commands and joint states are recorded while held, then `vservoctl resume` begins servoing; the summary adds what
# moved while held (held_max_twist, held_max_command_rad_s, held_joint_motion_rad) and whether the resume was taken.
# The summary also says how the rmrc's commands stand against the arm's own limits (scripts/command_limits.py).
#
# --urdf is the URDF PyBullet simulates: by default the configuration's own (robot.arm.urdf), the arm it models
# (its meshes are found beside it and in pybullet_data); give it for a DH arm or another file of the same arm.
# --velocity-lag-s S: the simulated arm's joint speeds follow vservo's velocity commands through a first-order lag
# of S seconds (default 0: at once), as a real velocity-commanded arm's drives do (a UR e-Series' speedj: ~10 ms).
#
# --instance names the run's instance (default "pybullet"), so that runs of several cells can be told apart.
# --config is any configuration of a cell (the lockstep's, e.g. config/arms/xarm6.toml): the run
# uses it through an overlay (pybullet.toml in the run's folder) that only puts the driver in place of vservo's
# simulated arm and camera: robot.driver and camera.source "external", the driver taking joint velocities every
# --period-s seconds (the arm's own period; by default the configuration's robot.period_s, which for the lockstep's
# simulated arm is its timing.control_period_s), the instance --instance, and no frame of pipeline delay
# (PyBullet's frames reach the servo 20–25 ms after capture on average: within the frame).
set -euo pipefail
cd "$(dirname "$0")/.."
duration=20
period=""
json=0
config=""
urdf=""
held=""
velocity_lag="0"
instance_name="pybullet"
usage="expected --config FILE [--urdf FILE] [--instance NAME] [--duration-s S] [--period-s S] [--held-s S] [--velocity-lag-s S] [--json]"
while [ $# -gt 0 ]; do
    case "$1" in
        --duration-s) duration="$2"; shift 2 ;;
        --duration-s=*) duration="${1#*=}"; shift ;;
        --json) json=1; shift ;;
        --config) config="$2"; shift 2 ;;
        --config=*) config="${1#*=}"; shift ;;
        --period-s) period="$2"; shift 2 ;;
        --period-s=*) period="${1#*=}"; shift ;;
        --urdf) urdf="$2"; shift 2 ;;
        --urdf=*) urdf="${1#*=}"; shift ;;
        --held-s) held="$2"; shift 2 ;;
        --held-s=*) held="${1#*=}"; shift ;;
        --velocity-lag-s) velocity_lag="$2"; shift 2 ;;
        --velocity-lag-s=*) velocity_lag="${1#*=}"; shift ;;
        --instance) instance_name="$2"; shift 2 ;;
        --instance=*) instance_name="${1#*=}"; shift ;;
        *) echo "run-pybullet: unknown argument $1 ($usage)" >&2; exit 2 ;;
    esac
done
if [ -z "$config" ]; then
    echo "run-pybullet: $usage" >&2
    exit 2
fi
[ -f "$config" ] || { echo "run-pybullet: $config: no such file" >&2; exit 2; }
config="$(cd "$(dirname "$config")" && pwd)/$(basename "$config")"
python=target/python-venv/bin/python
source scripts/lib/cell-run.sh

scripts/setup.sh >&2
"$python" -c 'import pybullet' 2>/dev/null ||
    { echo "run-pybullet: pybullet is not in $python's venv (scripts/setup.sh installs it)" >&2; exit 1; }
cell_binaries
run_folder pybullet "$instance_name"
vservoctl="$bin/vservoctl"

if [ -z "$urdf" ]; then
    # the arm the configuration models, from its own URDF
    urdf="$("$vservoctl" scene --config "$config" | "$python" -c 'import json,sys; print(json.load(sys.stdin)["arm"]["urdf"] or "")')"
    [ -n "$urdf" ] || { echo "run-pybullet: $config models its arm without a URDF (robot.arm.preset): give --urdf FILE" >&2; exit 2; }
fi
[ -f "$urdf" ] || { echo "run-pybullet: $urdf: no such file" >&2; exit 2; }
urdf="$(cd "$(dirname "$urdf")" && pwd)/$(basename "$urdf")"

# the configuration's own dynamics override: its simulated arm's full limits unless it gives one (the overlay
# below makes the driver external, whose default is a real arm's 0.25)
speed_scale="$("$vservoctl" scene --config "$config" | "$python" -c 'import json,sys; print(json.load(sys.stdin)["robot"]["speed_scale"])')"
if [ -z "$period" ]; then
    # the arm's own period as the configuration gives it
    period="$("$vservoctl" scene --config "$config" | "$python" -c 'import json,sys; print(json.load(sys.stdin)["robot"]["period_s"])')"
fi

cat > "$out/pybullet.toml" <<TOML
# written by scripts/run-pybullet.sh: the cell of the file below with the PyBullet driver as its arm and camera
extends = "$config"

[instance]
name = "$instance_name"

[timing]
pipeline_delay_frames = 0

[camera]
source = "external"

[robot]
driver = "external"
command = "velocity"
period_s = $period
# a simulated arm servos at once unless --held-s: then it starts held, as a real arm's cell does, until
# \`vservoctl resume\`
start = "$([ -n "$held" ] && echo held || echo servoing)"
speed_scale = $speed_scale
TOML
config="$out/pybullet.toml"
"$vservoctl" scene --config "$config" > "$out/scene.json"
instance="$("$python" -c 'import json,sys; print(json.load(sys.stdin)["instance"])' < "$out/scene.json")"
desired="$("$python" -c 'import json,sys; print(",".join(str(v) for v in json.load(sys.stdin)["desired_features_px"]))' < "$out/scene.json")"

# this run's runtime directory (removed at the end, shared memory included); short: iceoryx2's socket paths must
# fit in 107 bytes
export VSERVO_RUNTIME_DIR="/tmp/vpb-$$"
pids=()
# the driver ends its camera process itself (on SIGTERM, and on its own death: PR_SET_PDEATHSIG)
cleanup() {
    stop_processes ${pids[@]+"${pids[@]}"}
    pids=()
    remove_runtime_dir "$instance"
}
trap cleanup EXIT

"$bin/vservod" --config "$config" > "$out/vservod.log" 2>&1 &
pids+=($!)
"$python" clients/python/pybullet_driver.py --scene "$out/scene.json" --urdf "$urdf" --instance "$instance" \
    --fifo-priority 50 --velocity-lag-s "$velocity_lag" --save-image "$out/first.pgm" > "$out/driver.log" 2>&1 &
driver=$!
pids+=("$driver")
say "run-pybullet: vservod and the PyBullet driver run; recording $duration s of features (logs in $out/)"
if [ -n "$held" ]; then
    say "run-pybullet: the cell starts held; recording $held s of it, then \`vservoctl resume\`"
    hold_then_resume "$instance" "$held" "$out"
fi
record_run "$instance" "$duration" "$out" commands
cleanup
trap - EXIT

summary="$("$python" scripts/feature_summary.py "$out/features.jsonl" --desired "$desired")"
# the rmrc's commands against the arm's own speed, acceleration and jerk limits, as its controller would see them
limits="$("$python" scripts/command_limits.py "$out/commands.jsonl" "$out/scene.json")"
summary="$(merge_json "$summary" "$limits")"
[ -n "$held" ] && summary="$(merge_json "$summary" "$(cat "$out/held.json")")"
say "$(cat "$out/status.txt" 2>/dev/null | head -3)"
say "$(grep '^pybullet_driver: ' "$out/driver.log" 2>/dev/null | grep -v 'waiting for it' || true)"
say_summary run-pybullet "$summary"
summary="$(with_run_folder "$summary")"
[ "$json" = 1 ] && echo "$summary"
exit 0
