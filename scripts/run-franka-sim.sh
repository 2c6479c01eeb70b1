#!/usr/bin/env bash
# vservo's loop closed on a simulated FR3 over the Franka's own protocol: franka-sim 1.1.7 (a third party's FCI
# server, protocol version 10, on MuJoCo, with the FCI's motion-limit checker and communication-constraint
# emulation both turned on: --enforce-motion-limits --enforce-comm-constraints) as the robot, vservod on
# config/franka-sim.toml (or --config) with its Franka driver (vservo-franka) and vservo's simulated camera
# rendering the board from the arm's measured joints.
#
#   scripts/run-franka-sim.sh [--config FILE] [--start default|medium] [--duration-s S] [--no-jerk-limit]
#                             [--fault driver-stopped|daemon-killed|server-restarted|server-silent|held-takeover|
#                                      udp-spoof]
#                             [--address HOST[:PORT]] [--reference] [--json]
#
# The run as a user's first motion would go: the cell starts held; `vservoctl resume`; `vservoctl move-joints` to
# the start (the configuration's scenario start, or with --start medium one 8–10 cm and 8–12° away in each axis);
# `vservoctl servo`; DURATION seconds of features and joint commands recorded; vservod stopped (the driver brings
# the arm to rest and finishes the motion). --no-jerk-limit turns vservo's jerk limiting off (the arm's jerk limits
# raised to 1e6 rad/s³, the driver's guard off), to show what the robot's checker says of that.
# --fault, 1 s into servoing: driver-stopped SIGSTOPs the Franka driver for 100 ms (the robot stops itself, the cell
# stops safely; the status then is `fault_status`), then `vservoctl resume` (the robot's error recovery, a new
# motion) and the recording; daemon-killed SIGKILLs vservod while the arm moves (its driver brings the arm to rest
# and finishes the motion; `driver_finished`), and nothing is recorded. server-restarted SIGKILLs franka-sim itself
# (the robot gone): the cell stops safely, a `vservoctl resume` while it is gone is refused (`refused_while_gone`: the
# refusal), franka-sim starts again on the same port (its arm at its own start), and `vservoctl resume` (retried
# until taken: the driver connects again every second) starts a new motion, servoed and recorded
# (`resumed_after_restart`, `fault_status`). server-silent SIGSTOPs franka-sim (a robot gone without a word, its
# connection still open, as when a cable is pulled): the cell stops safely (`fault_status`); a resume is taken and
# the driver asks the robot for its error recovery, which no one answers, so after 2 s it gives the connection up
# (`silent_status`: robot_connection_lost) and a resume is refused naming it (`refused_while_silent`); franka-sim
# is SIGCONTed (the cable back), and `vservoctl resume` (retried until taken) starts a new motion on a new
# connection, servoed and recorded (`resumed_after_return`). held-takeover is issue 46's attack on the
# held cell, before any resume: a process of the same user SIGKILLs the rmrc, takes its joint_command slot and answers
# each joint state with 0.3 rad/s on joint 1, unsealed, for 3 s (tests/python/takeover_attack.py); the summary's
# `attack` says how far joint 1 moved (the robot's measured angle), and `rogue_named` whether vservod's log names the
# attacker's pid; nothing is recorded. udp-spoof, 1 s into servoing: a local process finds the driver's UDP port and
# sends it a 10-byte datagram and 200 states numbered ahead of the robot's (tests/python/udp_spoof.py, its JSON in
# the summary's `spoof`); the run goes on and is recorded, and the driver's `datagrams_dropped` counts them.
# --address HOST[:PORT] runs the same sequence against an FCI server or robot already running there (port 1337 if
# none is given): no franka-sim is installed or started (nor is --fault server-restarted or --reference taken), and
# the configuration's [franka] address and port are those given (its `simulator` stays the configuration's: true
# in config/franka-sim.toml, whose simulated camera renders the board from the robot's joints; give your own
# --config with your camera for a robot). tests/tests/franka_sim.rs runs it against franky-sim, a second FCI server.
# --reference runs no vservo at all: a bare FCI client (crates/vservo-franka/examples/fci_smoke.rs, SCHED_FIFO 50
# where permitted: a slow 0.02 rad/s bump on joint 1 for DURATION seconds) against the same franka-sim, the
# reference for what the simulator's own timing on this machine leaves of the success rate (its JSON:
# min/mean_control_command_success_rate, state_to_command_p50/p99/max_us).
# With --json the last line is one JSON object: final_error_px, settling_time_s, reflex_errors (the Franka's errors
# that stopped a motion, empty when none), min_control_command_success_rate, max_joint_jerk_rad_s3 (of the
# velocities the driver sent), state_to_command_p50_us / _p99_us, moved_to_start, and the feature summary's fields. Logs, the
# scene and the recordings are left in a folder of the run's own, target/franka-sim-run/PID (`latest` links the
# last; the summary's run_folder names it), so that runs at once never share one.
set -euo pipefail
cd "$(dirname "$0")/.."
duration=10
json=0
config=config/franka-sim.toml
start=default
jerk_limit=1
fault=""
reference=0
address=""
usage="expected [--config FILE] [--start default|medium] [--duration-s S] [--no-jerk-limit] [--fault KIND] [--address HOST[:PORT]] [--reference] [--json]"
while [ $# -gt 0 ]; do
    case "$1" in
        --duration-s) duration="$2"; shift 2 ;;
        --duration-s=*) duration="${1#*=}"; shift ;;
        --config) config="$2"; shift 2 ;;
        --config=*) config="${1#*=}"; shift ;;
        --start) start="$2"; shift 2 ;;
        --start=*) start="${1#*=}"; shift ;;
        --no-jerk-limit) jerk_limit=0; shift ;;
        --fault) fault="$2"; shift 2 ;;
        --fault=*) fault="${1#*=}"; shift ;;
        --json) json=1; shift ;;
        --reference) reference=1; shift ;;
        --address) address="$2"; shift 2 ;;
        --address=*) address="${1#*=}"; shift ;;
        *) echo "run-franka-sim: unknown argument $1 ($usage)" >&2; exit 2 ;;
    esac
done
case "$start" in default|medium) ;; *) echo "run-franka-sim: --start is default or medium" >&2; exit 2 ;; esac
case "$fault" in ""|driver-stopped|daemon-killed|server-restarted|server-silent|held-takeover|udp-spoof) ;;
    *) echo "run-franka-sim: --fault is driver-stopped, daemon-killed, server-restarted, server-silent, held-takeover or udp-spoof" >&2
       exit 2 ;; esac
if [ -n "$address" ] && { [ "$fault" = server-restarted ] || [ "$fault" = server-silent ] || [ "$reference" = 1 ]; }; then
    echo "run-franka-sim: --address runs against a server of yours: --fault server-restarted, server-silent and --reference need the script's own franka-sim" >&2
    exit 2
fi
[ -f "$config" ] || { echo "run-franka-sim: $config: no such file" >&2; exit 2; }
config="$(cd "$(dirname "$config")" && pwd)/$(basename "$config")"
python=target/python-venv/bin/python
source scripts/lib/cell-run.sh

scripts/setup.sh >&2
venv=target/franka-sim-venv
cell_binaries vservo-franka-driver
run_folder franka-sim
vservoctl="$bin/vservoctl"

if [ -n "$address" ]; then
    host="${address%:*}"
    port="${address##*:}"
    [ "$host" != "$address" ] || port=1337
    simulator_line=""
else
    # franka-sim's FR3 from franky-sim: its fr3.xml wants its meshes in assets/ beside it, the wheel has them in meshes/
    site="$("$venv/bin/python" -c 'import franky_sim, os; print(os.path.dirname(franky_sim.__file__))')"
    mjcf="$out/fr3-mjcf"
    mkdir -p "$mjcf"
    ln -sf "$site/assets/fr3.xml" "$mjcf/fr3.xml"
    ln -sfn "$site/assets/meshes" "$mjcf/assets"
    host=127.0.0.1
    port="$("$python" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
    simulator_line="simulator = true"
fi

instance="franka-sim-$$"
case "$start" in
    default) start_offsets="" ;;
    medium) start_offsets=$'initial_camera_translation_m = [0.08, -0.1, 0.09]\ninitial_camera_rotation_deg = [10.0, -8.0, 12.0]' ;;
esac
jerk_overlay=""
if [ "$jerk_limit" = 0 ]; then
    jerk_overlay=$'[robot.arm]\njerk_limits_rad_s3 = [1e6, 1e6, 1e6, 1e6, 1e6, 1e6, 1e6]\n'
fi
root="$(pwd)"
cat > "$out/franka-sim.toml" <<TOML
extends = "$config"

[instance]
name = "$instance"

[franka]
address = "$host"
port = $port
$simulator_line
limit_rate = $([ "$jerk_limit" = 1 ] && echo true || echo false)

[scenario]
$start_offsets

$jerk_overlay
TOML
config="$root/$out/franka-sim.toml"
"$vservoctl" scene --config "$config" > "$out/scene.json"
start_q="$("$python" -c 'import json,sys; print(",".join(repr(v) for v in json.load(sys.stdin)["start_joints_rad"]))' < "$out/scene.json")"
desired="$("$python" -c 'import json,sys; print(",".join(str(v) for v in json.load(sys.stdin)["desired_features_px"]))' < "$out/scene.json")"

# this run's runtime directory (removed at the end, shared memory included); short: iceoryx2's socket paths must
# fit in 107 bytes
export VSERVO_RUNTIME_DIR="/tmp/vfs-$$"
pids=()
cleanup() {
    stop_processes ${pids[@]+"${pids[@]}"}
    pids=()
    remove_runtime_dir "$instance"
}
trap cleanup EXIT

# start_server: franka-sim on the run's port, its log appended to franka-sim.log, its pid in $server; waits until it
# answers as an FCI server
start_server() {
    FR3_MJCF="$(pwd)/$mjcf/fr3.xml" "$venv/bin/run-franka-sim-server" --no-gripper --port "$port" \
        --enforce-motion-limits --enforce-comm-constraints >> "$out/franka-sim.log" 2>&1 &
    server=$!
    pids+=("$server")
    "$venv/bin/franka-sim-check" --host 127.0.0.1 --port "$port" --timeout 30 >> "$out/franka-sim-check.log" 2>&1 ||
        { echo "run-franka-sim: franka-sim did not come up (see $out/franka-sim.log)" >&2; exit 1; }
}
[ -n "$address" ] || start_server

if [ "$reference" = 1 ]; then
    smoke="$bin/examples/fci_smoke"
    if [ ! -x "$smoke" ]; then
        cargo build --release --locked -q -p vservo-franka --example fci_smoke >&2
        smoke=target/release/examples/fci_smoke
    fi
    fifo=(chrt -f 50)
    chrt -f 50 true 2>/dev/null || fifo=()
    ${fifo[@]+"${fifo[@]}"} "$smoke" "127.0.0.1:$port" --duration "$duration" --peak 0.02 --every 0 > "$out/reference.log" 2>&1 ||
        { echo "run-franka-sim: the reference client failed (see $out/reference.log)" >&2; exit 1; }
    summary="$("$python" - "$out/reference.log" <<'PY'
import json, re, sys
text = open(sys.argv[1]).read()
rate = re.search(r"success_rate \(from 100 ms on\): min ([0-9.]+) mean ([0-9.]+)", text)
latency = re.search(r"p50 ([0-9.]+)µs p99 ([0-9.]+)µs max ([0-9.]+)µs", text)
errors = re.search(r"errors \[(.*?)\]", text)
print(json.dumps({
    "reference_client": True,
    "min_control_command_success_rate": float(rate.group(1)),
    "mean_control_command_success_rate": float(rate.group(2)),
    "state_to_command_p50_us": float(latency.group(1)),
    "state_to_command_p99_us": float(latency.group(2)),
    "state_to_command_max_us": float(latency.group(3)),
    "reflex_errors": [e.strip() for e in errors.group(1).split(",") if e.strip()] if errors else [],
}))
PY
)"
    say_summary run-franka-sim "$summary"
    summary="$(with_run_folder "$summary")"
[ "$json" = 1 ] && echo "$summary"
    exit 0
fi
"$bin/vservod" --config "$config" > "$out/vservod.log" 2>&1 &
vservod=$!
pids+=("$vservod")
say "run-franka-sim: franka-sim on port $port, vservod and its Franka driver run (logs in $out/)"
wait_for_cell "$instance" "$out"

# driver_summary: the Franka driver's JSON line from the log (the run's last, once it has ended)
driver_summary() {
    local line
    line="$(grep -h 'franka-summary: ' "$out/vservod.log" | tail -1 | sed 's/.*franka-summary: //')"
    if [ -n "$line" ]; then
        echo "$line"
    else
        echo '{"reflex_errors": ["the driver wrote no summary (see vservod.log)"]}'
    fi
}

if [ "$fault" = held-takeover ]; then
    "$vservoctl" status --instance "$instance" --json > "$out/status-held.json" 2>&1 || true
    attack="$("$python" tests/python/takeover_attack.py "$instance" 1 0.3 3 2> "$out/attack.log")" ||
        { echo "run-franka-sim: the attack did not run (see $out/attack.log)" >&2; exit 1; }
    "$vservoctl" status --instance "$instance" --json > "$out/status-attack.json" 2>&1 || true
    stop_processes "$vservod"
    wait "$vservod" 2>/dev/null || true
    cleanup
    trap - EXIT
    attacker="$("$python" -c 'import json,sys; print(json.loads(sys.argv[1])["attacker_pid"])' "$attack")"
    named=false
    grep "stream taken" "$out/vservod.log" | grep -q "pid=$attacker" && named=true
    summary="$(merge_json "$(driver_summary)" "{\"attack\": $attack, \"rogue_named\": $named}")"
    say_summary run-franka-sim "$summary"
    summary="$(with_run_folder "$summary")"
    [ "$json" = 1 ] && echo "$summary"
    exit 0
fi

# the cell starts held: resume once the driver's states arrive, then move to the start and servo from there
for _ in $(seq 100); do
    "$vservoctl" resume --instance "$instance" > "$out/resume.txt" 2>&1 && break
    sleep 0.2
done
# the move refused: with vservo's limiting on, a failure that says why; with it off (--no-jerk-limit) the robot may
# already have stopped the motion the resume began (its reflex then is in the summary) and the run records that
moved=1
if ! "$vservoctl" move-joints --instance "$instance" --q "$start_q" --speed-fraction 0.3 > "$out/move.txt" 2>&1; then
    moved=0
    if [ "$jerk_limit" = 1 ]; then
        echo "run-franka-sim: the move to the start was refused: $(cat "$out/move.txt")" >&2
        exit 1
    fi
    say "run-franka-sim: the move to the start was refused: $(cat "$out/move.txt")"
fi
# arrived: the rmrc's reference on the goal (the arm itself stops a few hundredths of a radian short in franka-sim,
# its joint impedance against gravity; the servo then starts from where it is)
for _ in $(seq 300); do
    [ "$moved" = 1 ] || break
    "$vservoctl" echo joint_command --instance "$instance" --duration-s 0.02 2>/dev/null | tail -1 > "$out/at.json" || true
    "$python" - "$out/at.json" "$start_q" <<'PY' && break
import json, sys
try:
    q = json.load(open(sys.argv[1]))["q_ref_rad"]
except Exception:
    sys.exit(1)
goal = [float(v) for v in sys.argv[2].split(",")]
sys.exit(0 if max(abs(a - b) for a, b in zip(q, goal)) < 1e-4 else 1)
PY
    sleep 0.1
done
"$vservoctl" servo --instance "$instance" > "$out/servo.txt" 2>&1 || true
say "run-franka-sim: at the $start start; servoing, recording $duration s"
extra='{}'
driver_pid="$(pgrep -P "$vservod" -x vservo-franka || true)"
# wait_for_fault: the status, once it shows an active fault (at most 5 s), in status-fault.json
wait_for_fault() {
    for _ in $(seq 50); do
        "$vservoctl" status --instance "$instance" --json > "$out/status-fault.json" 2>/dev/null &&
            grep -q '"active": true' "$out/status-fault.json" && break
        sleep 0.1
    done
}
# wait_for_status TEXT FILE: the status, once its JSON holds TEXT (at most 8 s), in FILE
wait_for_status() {
    for _ in $(seq 80); do
        "$vservoctl" status --instance "$instance" --json > "$2" 2>/dev/null && grep -q "$1" "$2" && break
        sleep 0.1
    done
}
# resume_until_taken TRIES: `vservoctl resume` every 0.2 s until taken; `resumed` says whether it was
resume_until_taken() {
    resumed=false
    for _ in $(seq "$1"); do
        "$vservoctl" resume --instance "$instance" > "$out/resume-fault.txt" 2>&1 && { resumed=true; break; }
        sleep 0.2
    done
}
case "$fault" in
    driver-stopped)
        sleep 1
        kill -STOP "$driver_pid"
        sleep 0.1
        kill -CONT "$driver_pid"
        wait_for_fault
        sleep 1
        resume_until_taken 50
        extra="$("$python" -c 'import json,sys; s=json.load(open(sys.argv[1])); print(json.dumps({"fault_status": s.get("fault"), "resumed_after_fault": sys.argv[2] == "true"}))' "$out/status-fault.json" "$resumed")"
        ;;
    server-restarted)
        sleep 1
        kill -KILL "$server"
        wait "$server" 2>/dev/null || true
        wait_for_fault
        sleep 1
        "$vservoctl" resume --instance "$instance" > "$out/resume-gone.txt" 2>&1 || true
        start_server
        resume_until_taken 100
        extra="$("$python" -c 'import json,sys; s=json.load(open(sys.argv[1])); print(json.dumps({"fault_status": s.get("fault"), "refused_while_gone": open(sys.argv[2]).read().strip(), "resumed_after_restart": sys.argv[3] == "true"}))' "$out/status-fault.json" "$out/resume-gone.txt" "$resumed")"
        ;;
    server-silent)
        sleep 1
        kill -STOP "$server"
        wait_for_fault
        sleep 1
        resume_until_taken 50
        wait_for_status robot_connection_lost "$out/status-silent.json"
        "$vservoctl" resume --instance "$instance" > "$out/resume-silent.txt" 2>&1 || true
        kill -CONT "$server"
        resume_until_taken 100
        extra="$("$python" -c 'import json,sys; f=lambda p: json.load(open(p)).get("fault"); print(json.dumps({"fault_status": f(sys.argv[1]), "silent_status": f(sys.argv[2]), "refused_while_silent": open(sys.argv[3]).read().strip(), "resumed_after_return": sys.argv[4] == "true"}))' "$out/status-fault.json" "$out/status-silent.json" "$out/resume-silent.txt" "$resumed")"
        ;;
    udp-spoof)
        sleep 1
        spoof="$("$python" tests/python/udp_spoof.py "$driver_pid" 2> "$out/spoof.log")" ||
            { echo "run-franka-sim: the spoofing did not run (see $out/spoof.log)" >&2; exit 1; }
        extra="{\"spoof\": $spoof}"
        ;;
    daemon-killed)
        sleep 1
        kill -KILL "$vservod"
        for _ in $(seq 100); do kill -0 "$driver_pid" 2>/dev/null || break; sleep 0.05; done
        finished=false
        grep -q "the arm is at rest and the motion finished" "$out/vservod.log" && finished=true
        extra="{\"driver_finished\": $finished}"
        ;;
esac
if [ "$fault" != daemon-killed ]; then
    record_run "$instance" "$duration" "$out" commands
else
    : > "$out/features.jsonl"; : > "$out/commands.jsonl"
fi
stop_processes "$vservod"
wait "$vservod" 2>/dev/null || true
cleanup
trap - EXIT

summary='{}'
limits='{}'
if [ "$fault" != daemon-killed ]; then
    # no features recorded (the robot stopped before the camera saw the board): the summary says so
    summary="$("$python" scripts/feature_summary.py "$out/features.jsonl" --desired "$desired")" || true
    limits="$("$python" scripts/command_limits.py "$out/commands.jsonl" "$out/scene.json" |
        "$python" -c 'import json,sys; d=json.load(sys.stdin); print(json.dumps({"rmrc_max_jerk_ratio": d["max_jerk_ratio"], "rmrc_max_acceleration_ratio": d["max_acceleration_ratio"]}))')"
fi
driver="$(driver_summary)"
summary="$(merge_json "$(merge_json "$(merge_json "$summary" "$limits")" "$driver")" "$extra")"
violations="$(grep -c 'communication_constraints_violation' "$out/franka-sim.log" || true)"
summary="$(merge_json "$summary" "{\"sim_log_communication_violations\": ${violations:-0}, \"moved_to_start\": $([ "$moved" = 1 ] && echo true || echo false)}")"
say "$(grep -h 'franka' "$out/vservod.log" | grep -E 'ERROR|WARN' | head -5 || true)"
say_summary run-franka-sim "$summary"
summary="$(with_run_folder "$summary")"
[ "$json" = 1 ] && echo "$summary"
exit 0
