#!/usr/bin/env python3
"""Capture → command latency of a run, from `vservoctl echo features` and `vservoctl echo joint_command` JSON
lines: for each twist the rmrc took in, the time from the exposure of the image it was computed from
(`capture_stamp_ns` of the features whose `capture_tick` is the command's `twist_capture_tick`) to the first
command that follows it (`stamp_ns` of the first command with that `twist_applied_tick`: when the rmrc sent it
to the driver). The same measure for any driver: the iceoryx2 path (scripts/run-mujoco.sh) and the ROS 2 path
(scripts/run-ros2-cell.sh, whose images cross DDS before their capture and whose commands cross it after).

    capture_to_command.py FEATURES.jsonl COMMANDS.jsonl [--arm ARM_SUMMARY.json]

--arm adds what the arm measured of its commands (clients/python/ros2_control_arm.py's summary: the time
from a joint state's stamp to the arrival of the next command, which covers both DDS hops and the rmrc; how
many commands it took and refused).
Prints one JSON object (ms).
"""

import argparse
import json
import sys


def read_lines(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def percentile(values, q):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("features")
    parser.add_argument("commands")
    parser.add_argument("--arm")
    args = parser.parse_args()
    captured_ns = {m["capture_tick"]: m["capture_stamp_ns"] for m in read_lines(args.features)}
    first_command_ns = {}
    for c in read_lines(args.commands):
        applied = c["twist_applied_tick"]
        if c["twist_capture_tick"] in captured_ns and applied not in first_command_ns:
            first_command_ns[applied] = (c["stamp_ns"], captured_ns[c["twist_capture_tick"]])
    latencies_ms = [(sent - captured) / 1e6 for sent, captured in first_command_ns.values() if sent >= captured]
    summary = {"twists": len(latencies_ms)}
    if latencies_ms:
        summary.update({
            "capture_to_command_ms_p50": round(percentile(latencies_ms, 50), 2),
            "capture_to_command_ms_p99": round(percentile(latencies_ms, 99), 2),
            "capture_to_command_ms_max": round(max(latencies_ms), 2),
        })
    if args.arm:
        with open(args.arm) as f:
            arm = json.load(f)
        for key in ("state_to_command_ms_p50", "state_to_command_ms_p99", "commands_taken", "commands_refused"):
            if key in arm:
                summary[key if key.startswith("state") else f"arm_{key}"] = arm[key]
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
