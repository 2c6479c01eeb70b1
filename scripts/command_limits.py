#!/usr/bin/env python3
"""What a robot controller sees of vservo's joint commands, against the arm's own limits: from
`vservoctl echo joint_command` JSON lines (`answers_tick`, `qd_ref_rad_s`), each joint's largest commanded speed,
acceleration (the change of the commanded velocity over one period) and jerk (the change of that), the way the
Franka's controller measures them before it aborts a motion. Only runs of consecutive ticks count (a command the
recording missed breaks the differences, it is not bridged).

    command_limits.py COMMANDS.jsonl SCENE.json

SCENE.json is `vservoctl scene --config …`: the arm's speed, acceleration and jerk limits and the driver's period.
Prints one JSON object: per joint and overall, the largest value and its share of the limit (`max_*_ratio`; no
jerk limit: the jerk's share is null), and how many commands and consecutive triples were read.
"""

import argparse
import json


def read_commands(path):
    with open(path) as f:
        lines = [json.loads(line) for line in f if line.strip()]
    by_tick = {}
    for c in lines:
        by_tick[c["answers_tick"]] = c["qd_ref_rad_s"]
    return [(tick, by_tick[tick]) for tick in sorted(by_tick)]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("commands")
    parser.add_argument("scene")
    args = parser.parse_args()
    with open(args.scene) as f:
        scene = json.load(f)
    arm = scene["arm"]
    dt = scene["robot"]["period_s"]
    velocity = arm["velocity_limits_rad_s"]
    acceleration = arm["acceleration_limits_rad_s2"]
    jerk = arm["jerk_limits_rad_s3"]
    joints = len(velocity)
    commands = read_commands(args.commands)
    most_v = [0.0] * joints
    most_a = [0.0] * joints
    most_j = [0.0] * joints
    triples = 0
    for (t0, v0), (t1, v1), (t2, v2) in zip(commands, commands[1:], commands[2:]):
        for j in range(joints):
            most_v[j] = max(most_v[j], abs(v2[j]))
        if t1 != t0 + 1 or t2 != t1 + 1:
            continue
        triples += 1
        for j in range(joints):
            a1 = (v1[j] - v0[j]) / dt
            a2 = (v2[j] - v1[j]) / dt
            most_a[j] = max(most_a[j], abs(a2))
            most_j[j] = max(most_j[j], abs(a2 - a1) / dt)
    ratio = lambda values, limits: [v / l for v, l in zip(values, limits)]
    summary = {
        "commands": len(commands),
        "consecutive_triples": triples,
        "max_joint_velocity_rad_s": most_v,
        "max_joint_acceleration_rad_s2": most_a,
        "max_joint_jerk_rad_s3": max(most_j) if most_j else 0.0,
        "joint_jerk_rad_s3": most_j,
        "max_velocity_ratio": max(ratio(most_v, velocity)),
        "max_acceleration_ratio": max(ratio(most_a, acceleration)),
        "max_jerk_ratio": max(ratio(most_j, jerk)) if jerk else None,
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
