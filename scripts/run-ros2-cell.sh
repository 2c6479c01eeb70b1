#!/usr/bin/env bash
# The loop closed through ROS 2: vservod on config/vservo-ros2-cell.toml ([robot] driver = "ros2", [camera]
# source = "ros2") starts `vservo-ros2-driver`, which reads the arm's /joint_states and the camera's
# /camera/image_raw and commands /forward_velocity_controller/commands over DDS; the arm and the camera are
# clients/python/ros2_control_arm.py, a Cyclone DDS node that plays a ros2_control arm (joint_state_broadcaster
# and a forward velocity controller around MuJoCo's PUMA 560) and a ROS camera (MuJoCo's render). Runs the
# paper's translation step for --duration-s seconds (default 20), then stops both and prints the final feature
# error, the settling time and the capture→command latency; with --json the last line is one JSON object
# (final_error_px, settling_time_s, …). Logs and the recorded features are left in target/ros2-cell-run/[TAG-]PID
# (`latest` links the last; the summary's run_folder names it).
#
#   scripts/run-ros2-cell.sh [--netns] [--position] [--duration-s S] [--json] [--domain D] [--fault held-takeover]
#
# --netns: vservod in one network namespace and the arm and camera node in another, joined by a veth pair:
# the two PCs of a real cell (root; `ip netns`). --position: the arm's forward position controller
# (/forward_position_controller/commands) in place of the velocity one. --domain: the ROS domain (default: one from this process's id,
# so that runs side by side do not meet). --fault held-takeover: the cell starts held (as a real arm's does) and,
# before any resume, a process of the same user SIGKILLs the rmrc, takes its joint_command slot and answers each joint
# state with 0.3 rad/s on joint 1, unsealed, for 3 s (tests/python/takeover_attack.py; its JSON is the summary's
# `attack`, with `rogue_named`: whether vservod's log names the attacker's pid); nothing is recorded. Each run has an
# instance of its own and removes what it leaves.
set -euo pipefail
cd "$(dirname "$0")/.."
duration=20
json=0
netns=0
controller=velocity
domain=$((1 + $$ % 200))
fault=""
while [ $# -gt 0 ]; do
    case "$1" in
        --duration-s) duration="$2"; shift 2 ;;
        --duration-s=*) duration="${1#*=}"; shift ;;
        --json) json=1; shift ;;
        --netns) netns=1; shift ;;
        --position) controller=position; shift ;;
        --domain) domain="$2"; shift 2 ;;
        --domain=*) domain="${1#*=}"; shift ;;
        --fault) fault="$2"; shift 2 ;;
        --fault=*) fault="${1#*=}"; shift ;;
        *) echo "run-ros2-cell: unknown argument $1 (expected --netns, --position, --duration-s S, --json, --domain D, --fault held-takeover)" >&2
           exit 2 ;;
    esac
done
case "$fault" in ""|held-takeover) ;; *) echo "run-ros2-cell: --fault is held-takeover" >&2; exit 2 ;; esac
root="$(pwd)"
python="$root/target/python-venv/bin/python"
source scripts/lib/cell-run.sh

scripts/setup.sh >&2
scripts/setup-mujoco.sh >&2
cell_binaries vservo-ros2
tag=""
[ "$netns" = 1 ] && tag="netns"
[ "$controller" = position ] && tag="${tag:+$tag-}position"
run_folder ros2-cell "$tag"
out="$root/$out"
vservoctl="$bin/vservoctl"
instance="ros2-cell-$$"
# this run's instance, domain and runtime directory (removed at the end, shared memory included)
export VSERVO_RUNTIME_DIR="/tmp/vsc-$$"  # short: iceoryx2's socket paths must fit in 107 bytes
cat > "$out/cell.toml" <<EOF
extends = "$root/config/vservo-ros2-cell.toml"

[instance]
name = "$instance"

[robot]
command = "$controller"
start = "$([ "$fault" = held-takeover ] && echo held || echo servoing)"

[ros2]
domain_id = $domain

[ros2.driver]
command_topic = "/forward_${controller}_controller/commands"
EOF
config="$out/cell.toml"
"$vservoctl" scene --config "$config" > "$out/scene.json"
desired="$("$python" -c 'import json,sys; print(",".join(str(v) for v in json.load(sys.stdin)["desired_features_px"]))' < "$out/scene.json")"

# --netns: two network namespaces joined by a veth pair, 10.N.M.1 (vservod) and 10.N.M.2 (the arm and camera)
in_cell=()
in_arm=()
hosts=()
if [ "$netns" = 1 ]; then
    a="vsc$$a"; b="vsc$$b"
    subnet="10.$((100 + ($$ / 256) % 100)).$(($$ % 256))"
    ip netns add "$a"; hosts+=("$a")
    ip netns add "$b"; hosts+=("$b")
    ip link add "${a}v" type veth peer name "${b}v"
    ip link set "${a}v" netns "$a"
    ip link set "${b}v" netns "$b"
    ip -n "$a" addr add "$subnet.1/24" dev "${a}v"
    ip -n "$b" addr add "$subnet.2/24" dev "${b}v"
    for ns in "$a" "$b"; do
        ip -n "$ns" link set lo up
    done
    ip -n "$a" link set "${a}v" up
    ip -n "$b" link set "${b}v" up
    in_cell=(ip netns exec "$a")
    in_arm=(ip netns exec "$b")
    say "run-ros2-cell: vservod in network namespace $a ($subnet.1), the arm and camera in $b ($subnet.2)"
fi

pids=()
cleanup() {
    stop_processes ${pids[@]+"${pids[@]}"}
    pids=()
    for ns in ${hosts[@]+"${hosts[@]}"}; do ip netns del "$ns" 2>/dev/null || true; done
    hosts=()
    remove_runtime_dir "$instance"
}
trap cleanup EXIT

${in_cell[@]+"${in_cell[@]}"} "$bin/vservod" --config "$config" > "$out/vservod.log" 2>&1 &
pids+=($!)
${in_arm[@]+"${in_arm[@]}"} "$python" clients/python/ros2_control_arm.py --scene "$out/scene.json" \
    --domain "$domain" --controller "$controller" --summary "$out/arm.json" > "$out/arm.log" 2>&1 &
pids+=($!)
if [ "$fault" = held-takeover ]; then
    wait_for_cell "$instance" "$out"
    attack="$("$python" tests/python/takeover_attack.py "$instance" 1 0.3 3 2> "$out/attack.log")" ||
        { echo "run-ros2-cell: the attack did not run (see $out/attack.log)" >&2; exit 1; }
    cleanup
    trap - EXIT
    attacker="$("$python" -c 'import json,sys; print(json.loads(sys.argv[1])["attacker_pid"])' "$attack")"
    named=false
    grep "stream taken" "$out/vservod.log" | grep -q "pid=$attacker" && named=true
    summary="{\"attack\": $attack, \"rogue_named\": $named}"
    say_summary run-ros2-cell "$summary"
    summary="$(with_run_folder "$summary")"
    [ "$json" = 1 ] && echo "$summary"
    exit 0
fi
say "run-ros2-cell: vservod and the ROS 2 arm and camera run on domain $domain; recording $duration s of features (logs in $out/)"
record_run "$instance" "$duration" "$out" commands
cleanup
trap - EXIT

summary="$("$python" scripts/feature_summary.py "$out/features.jsonl" --desired "$desired")"
latency="$("$python" scripts/capture_to_command.py "$out/features.jsonl" "$out/commands.jsonl" --arm "$out/arm.json")"
summary="$(merge_json "$summary" "$latency")"
say "$(head -3 "$out/status.txt" 2>/dev/null)"
say_summary run-ros2-cell "$summary"
summary="$(with_run_folder "$summary")"
[ "$json" = 1 ] && echo "$summary"
exit 0
