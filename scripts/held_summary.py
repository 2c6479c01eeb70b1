#!/usr/bin/env python3
"""What a held cell did before its resume (scripts/lib/cell-run.sh's hold_then_resume): from OUT/held-camera_twist,
held-joint_command and held-joint_state .jsonl (`vservoctl echo`), the largest twist component and commanded joint
speed while held, how far the measured joints moved, and how many of each were recorded.

    held_summary.py OUT RESUMED

Prints one JSON object with those, `resumed` (the resume was accepted) and the resume's reply.
"""

import json
import os
import sys


def read(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def main():
    out, resumed = sys.argv[1], sys.argv[2] == "1"
    twists = read(os.path.join(out, "held-camera_twist.jsonl"))
    commands = read(os.path.join(out, "held-joint_command.jsonl"))
    states = read(os.path.join(out, "held-joint_state.jsonl"))
    largest = lambda rows, key: max((abs(v) for r in rows for v in r[key]), default=0.0)
    moved = 0.0
    if states:
        first = states[0]["q_rad"]
        moved = max(abs(a - b) for s in states for a, b in zip(s["q_rad"], first))
    with open(os.path.join(out, "resume.txt")) as f:
        reply = f.read().strip()
    print(json.dumps({
        "held_twists": len(twists),
        "held_commands": len(commands),
        "held_states": len(states),
        "held_max_twist": largest(twists, "twist"),
        "held_max_command_rad_s": largest(commands, "qd_ref_rad_s"),
        "held_joint_motion_rad": moved,
        "resumed": resumed,
        "resume_reply": reply,
    }))


if __name__ == "__main__":
    main()
