#!/usr/bin/env bash
# Measures, in one run on this machine: the plant's 1 ms loop lateness, the plant → rmrc → plant round trip
# (a joint state published → the rmrc's answer in the plant's queue), and — as the floor — a bare 1 ms
# clock_nanosleep(TIMER_ABSTIME) loop with the plant's real-time settings, running at the same time.
# Prints p50/p99/p99.9/max and the ratios to the floor.
#
#   scripts/latency.sh [SECONDS=30] [CONFIG=config/vservo.toml] [viewer|ros2]
#
# With `viewer`, vservod also serves the cell to Foxglove ([viewer] enabled) and a Foxglove WebSocket client
# (tests/python/foxglove_client.py, given the URL with the view's token by `vservoctl view --url`) takes every
# image, annotation, transform, joint state and status during the measurement.
# With `ros2`, vservod also runs the ROS 2 bridge ([ros2] enabled, on ROS domain 42) and a Cyclone DDS node
# (tests/python/check_ros2_graph.py) takes every topic during the measurement (docs/ROS2.md).
# The config's instance must not be running already. Release builds; the figures go in docs/BENCHMARKS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
config="${2:-config/vservo.toml}"
viewer="${3:-}"
scripts/setup.sh
cargo build --release --locked -q -p vservod -p vservoctl -p vservo-ros2
cargo build --release --locked -q -p vservo-runtime --example bare_loop
log="$(mktemp)"
floor="$(mktemp)"
with_viewer="$(mktemp --suffix=.toml)"
trap 'rm -f "$log" "$floor" "$with_viewer"' EXIT
# the section's own `enabled` only (each section runs to the next header)
if [ "${viewer}" = viewer ]; then
    sed '/^\[viewer\]/,/^\[/ s/^enabled = false/enabled = true/' "${config}" >"${with_viewer}"
    config="${with_viewer}"
elif [ "${viewer}" = ros2 ]; then
    sed '/^\[ros2\]/,/^\[/ { s/^enabled = false/enabled = true/; s/^domain_id = 0/domain_id = 42/ }' "${config}" >"${with_viewer}"
    config="${with_viewer}"
fi

./target/release/vservod --config "$config" --status-every-s 0 2>"$log" &
daemon=$!
# let the nodes start before both loops are measured side by side
sleep 1
client=""
if [ "${viewer}" = viewer ]; then
    instance="$(sed -n 's/^name = "\(.*\)"/\1/p' "${config}" | head -1)"
    # the URL with the view's token, once the viewer has written it
    url=""
    for _ in $(seq 50); do
        url="$(./target/release/vservoctl view --url --instance "${instance}" 2>/dev/null)" && break
        sleep 0.2
    done
    target/python-venv/bin/python tests/python/foxglove_client.py "${url}" "${instance}" "${seconds}" &
    client=$!
elif [ "${viewer}" = ros2 ]; then
    target/python-venv/bin/python tests/python/check_ros2_graph.py --domain 42 --seconds "${seconds}" >/dev/null &
    client=$!
fi
./target/release/examples/bare_loop "$seconds" "$config" >"$floor"
[ -n "${client}" ] && { wait "${client}" || echo "latency: the ${viewer} client failed" >&2; }
kill -TERM "$daemon"
wait "$daemon"

python3 - "$log" "$floor" "$seconds" <<'PY'
import json, re, sys
log, floor_file, seconds = sys.argv[1], sys.argv[2], sys.argv[3]
plant = None
for line in open(log, encoding="utf-8"):
    if 'node="plant"' in line or "node=plant" in line:
        m = re.search(r"loop totals (\{.*\})", line)
        if m:
            plant = json.loads(m.group(1))
if plant is None:
    sys.exit("latency: the plant's loop totals are not in the daemon's log")
floor = json.loads(open(floor_file, encoding="utf-8").read())["wake_latency"]
rows = [("bare clock_nanosleep loop (floor)", floor), ("plant loop lateness", plant["wake_latency"]),
        ("plant -> rmrc -> plant round trip", plant["round_trip"])]
print(f"1 ms loops over {seconds} s, in one run (µs):")
print(f"  {'':36} {'count':>7} {'p50':>8} {'p99':>8} {'p99.9':>8} {'max':>9}")
for name, t in rows:
    print(f"  {name:36} {t['count']:>7} " + " ".join(f"{t[k] / 1e3:>8.1f}" for k in ("p50", "p99", "p999")) + f" {t['max'] / 1e3:>9.1f}")
print("ratios to the floor:")
for name, t in rows[1:]:
    ratios = [t[k] / floor[k] if floor[k] else float("nan") for k in ("p50", "p99", "p999", "max")]
    print(f"  {name:36} " + "  ".join(f"{k} {r:.2f}" for k, r in zip(("p50", "p99", "p99.9", "max"), ratios)))
PY
