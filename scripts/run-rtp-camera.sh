#!/usr/bin/env bash
# The loop closed over a network camera: vservod with config/rtp-camera.toml (external robot and camera), the
# MuJoCo reference driver (clients/python/mujoco_driver.py --rtp-port) as the robot, streaming its rendered
# frames as RTP raw video over UDP on loopback, and vservo's GStreamer camera driver (vservo-gst-camera)
# receiving them and publishing them on camera_image. Runs the translation step for --duration-s seconds
# (default 20), stops all three and prints the final feature error, the settling time and the servo's
# capture→twist latency; with --json the last line is one JSON object (final_error_px, settling_time_s,
# capture_to_twist_ms, …). Logs and the recorded features are left in target/rtp-camera-run/PID
# (`latest` links the last; the summary's run_folder names it).
#
#   scripts/run-rtp-camera.sh [--instance NAME] [--duration-s S] [--json]
#
# --instance runs the cell under that instance name (default rtp-camera), its logs in target/rtp-camera-run/NAME-PID/
# (the RTP port stays the configuration's: two such runs at once need a copy of it with another port).
set -euo pipefail
cd "$(dirname "$0")/.."
duration=20
json=0
instance_name=""
while [ $# -gt 0 ]; do
    case "$1" in
        --duration-s) duration="$2"; shift 2 ;;
        --duration-s=*) duration="${1#*=}"; shift ;;
        --json) json=1; shift ;;
        --instance) instance_name="$2"; shift 2 ;;
        --instance=*) instance_name="${1#*=}"; shift ;;
        *) echo "run-rtp-camera: unknown argument $1 (expected --instance NAME, --duration-s S, --json)" >&2; exit 2 ;;
    esac
done
python=target/python-venv/bin/python
source scripts/lib/cell-run.sh

scripts/setup.sh >&2
scripts/setup-mujoco.sh >&2
cell_binaries vservo-camera-gst
config=config/rtp-camera.toml
instance="${instance_name:-rtp-camera}"
port="$(sed -n 's/^pipeline = "udpsrc port=\([0-9]*\) .*/\1/p' "$config")"
run_folder rtp-camera "$instance_name"
vservoctl="$bin/vservoctl"
config="$(with_instance "$config" "$instance_name" "$out")"

"$vservoctl" scene --config "$config" > "$out/scene.json"
desired="$("$python" -c 'import json,sys; print(",".join(str(v) for v in json.load(sys.stdin)["desired_features_px"]))' < "$out/scene.json")"

pids=()
cleanup() { stop_processes ${pids[@]+"${pids[@]}"}; }
trap cleanup EXIT

"$bin/vservod" --config "$config" > "$out/vservod.log" 2>&1 &
pids+=($!)
"$bin/vservo-gst-camera" --config "$config" --stats-every-s 5 > "$out/camera.log" 2>&1 &
pids+=($!)
"$python" clients/python/mujoco_driver.py --scene "$out/scene.json" --instance "$instance" --fifo-priority 50 \
    --rtp-port "$port" > "$out/driver.log" 2>&1 &
pids+=($!)
say "run-rtp-camera: vservod, the GStreamer camera (RTP on 127.0.0.1:$port) and the MuJoCo driver run; recording $duration s of features (logs in $out/)"
record_run "$instance" "$duration" "$out"
"$vservoctl" status --json --instance "$instance" > "$out/status.json" 2>/dev/null || true
cleanup
trap - EXIT

summary="$("$python" scripts/feature_summary.py "$out/features.jsonl" --desired "$desired")"
# the servo's capture→twist latency (p50/p99/max over its telemetry window) joins the summary
summary="$("$python" -c '
import json, sys
summary = json.loads(sys.argv[1])
try:
    latency = json.load(open(sys.argv[2]))["nodes"]["servo"]["capture_latency_us"]
    summary["capture_to_twist_ms"] = {k: latency[k] / 1e3 for k in ("p50", "p99", "max")}
except (OSError, ValueError, KeyError, TypeError):
    summary["capture_to_twist_ms"] = None
print(json.dumps(summary))' "$summary" "$out/status.json")"
say "$(head -3 "$out/status.txt" 2>/dev/null)"
say "$(grep -h "frames .* lost" "$out/camera.log" | tail -1)"
say_summary run-rtp-camera "$summary"
summary="$(with_run_folder "$summary")"
[ "$json" = 1 ] && echo "$summary"
exit 0
