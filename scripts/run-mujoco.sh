#!/usr/bin/env bash
# vservod with an external robot and camera: the MuJoCo reference driver (clients/python/mujoco_driver.py)
# simulates the PUMA 560 and the board in MuJoCo, takes vservo's joint velocity commands and publishes joint
# states and rendered camera frames over the driver contract of docs/DRIVERS.md. Runs the paper's
# translation step (config/mujoco.toml) for --duration-s seconds (default 20), then stops both and prints the
# final feature error and the settling time; with --json the last line is one JSON object
# (final_error_px, settling_time_s, …). Logs and the recorded features are left in target/mujoco-run/PID
# (`latest` links the last; the summary's run_folder names it).
#
#   scripts/run-mujoco.sh [--config FILE] [--instance NAME] [--duration-s S] [--json] [--compare] [--calibrate]
#
# --instance runs the cell under that instance name (default: the configuration's), its logs in
# target/mujoco-run/NAME-PID/, so that runs of several cells side by side can be told apart.
# --config runs another external cell (default config/mujoco.toml; config/mujoco-apriltag.toml is the AprilTag
# through a distorting lens): the driver renders what `vservoctl scene` says of it (lens and target included).
# --compare also runs the built-in simulation of the same cell in the lockstep simulator (vservoctl sim on
# config/vservo.toml with the MuJoCo cell's pipeline delay: none, as MuJoCo's frames reach the servo within a
# frame) and adds its settling time and the RMS difference of the two feature trajectories.
# --calibrate (with config/mujoco-calibration.toml: the calibration board, and a camera whose truth is apart
# from what is believed) servos for --duration-s, then runs `vservoctl calibrate` against the running cell
# (the driver renders the camera's truth and its noise) and prints its report; with --json its last line.
set -euo pipefail
cd "$(dirname "$0")/.."
duration=20
json=0
compare=0
calibrate=0
config=config/mujoco.toml
instance_name=""
while [ $# -gt 0 ]; do
    case "$1" in
        --duration-s) duration="$2"; shift 2 ;;
        --duration-s=*) duration="${1#*=}"; shift ;;
        --json) json=1; shift ;;
        --compare) compare=1; shift ;;
        --calibrate) calibrate=1; shift ;;
        --config) config="$2"; shift 2 ;;
        --config=*) config="${1#*=}"; shift ;;
        --instance) instance_name="$2"; shift 2 ;;
        --instance=*) instance_name="${1#*=}"; shift ;;
        *) echo "run-mujoco: unknown argument $1 (expected --config FILE, --instance NAME, --duration-s S, --json, --compare, --calibrate)" >&2
           exit 2 ;;
    esac
done
python=target/python-venv/bin/python
source scripts/lib/cell-run.sh

scripts/setup.sh >&2
scripts/setup-mujoco.sh >&2
cell_binaries
run_folder mujoco "$instance_name"
vservoctl="$bin/vservoctl"
# the file as given (its keys read below), and the file run: the same, or it under --instance
given_config="$config"
config="$(with_instance "$config" "$instance_name" "$out")"

"$vservoctl" scene --config "$config" > "$out/scene.json"
instance="$("$python" -c 'import json,sys; print(json.load(sys.stdin)["instance"])' < "$out/scene.json")"
desired="$("$python" -c 'import json,sys; print(",".join(str(v) for v in json.load(sys.stdin)["desired_features_px"]))' < "$out/scene.json")"

pids=()
cleanup() { stop_processes ${pids[@]+"${pids[@]}"}; }
trap cleanup EXIT

"$bin/vservod" --config "$config" > "$out/vservod.log" 2>&1 &
pids+=($!)
noise=()
[ "$calibrate" = 1 ] && noise=(--camera-noise)
"$python" clients/python/mujoco_driver.py --scene "$out/scene.json" --instance "$instance" --fifo-priority 50 \
    ${noise[@]+"${noise[@]}"} > "$out/driver.log" 2>&1 &
driver=$!
pids+=("$driver")
say "run-mujoco: vservod and the MuJoCo driver run; recording $duration s of features (logs in $out/)"
record_run "$instance" "$duration" "$out" commands
if [ "$calibrate" = 1 ]; then
    say "run-mujoco: calibrating the running cell (vservoctl calibrate)"
    calibrated=0
    "$vservoctl" calibrate --config "$config" --json --out "$out/calibration.yaml" --python "$python" \
        > "$out/calibration.json" 2> "$out/calibration.log" || calibrated=$?
    "$vservoctl" status --instance "$instance" > "$out/status.txt" 2>&1 || true
    cleanup
    trap - EXIT
    if [ "$calibrated" != 0 ]; then
        cat "$out/calibration.log" >&2
        exit "$calibrated"
    fi
    say "$(cat "$out/calibration.log")"
    tail -n 1 "$out/calibration.json"
    exit 0
fi
cleanup
trap - EXIT

summary="$("$python" scripts/feature_summary.py "$out/features.jsonl" --desired "$desired")"
if [ "$compare" = 1 ]; then
    delay="$(sed -n 's/^pipeline_delay_frames = //p' "$given_config")"
    sed "s/^pipeline_delay_frames = .*/pipeline_delay_frames = ${delay}/" config/vservo.toml > "$out/lockstep.toml"
    "$vservoctl" sim --config "$out/lockstep.toml" --duration "$duration" --out "$out/lockstep" >&2
    summary="$("$python" scripts/feature_summary.py "$out/features.jsonl" --desired "$desired" \
        --compare "$out/lockstep/features.csv" \
        --compare-settling "$("$python" -c 'import json,sys; print(json.load(sys.stdin)["settling_time_s"])' \
            < "$out/lockstep/summary.json")")"
fi
latency="$("$python" scripts/capture_to_command.py "$out/features.jsonl" "$out/commands.jsonl")"
summary="$(merge_json "$summary" "$latency")"
say "$(cat "$out/status.txt" 2>/dev/null | head -3)"
say_summary run-mujoco "$summary"
summary="$(with_run_folder "$summary")"
[ "$json" = 1 ] && echo "$summary"
exit 0
