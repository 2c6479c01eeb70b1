#!/usr/bin/env python3
"""Summarises a run from `vservoctl echo features` JSON lines: the final feature error and the settling time.

    feature_summary.py FEATURES.jsonl --desired x1,y1,...,x4,y4 [--compare TRAJECTORY.csv]

Per frame the error is the largest distance of a mark from its desired position (px; a missing mark counts
as not settled). The settling time is the capture time, from the first frame's, of the frame after the last
one whose error is 1 px or more. Mark 1's error along its initial direction gives the overshoot (how far it
passes the target, % of its start, as the lockstep's summary.json measures a step) and the second swing (how
far it then comes back past the target the other way, %). --compare takes a lockstep features.csv (`vservoctl sim --out DIR`:
t_s, x1, y1, …) and adds the RMS difference of the two trajectories, frame by frame in time.
Prints one JSON object.
"""

import argparse
import csv
import json
import math
import sys


def read_frames(path):
    frames = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            m = json.loads(line)
            xi = [math.nan if v is None else v for v in m["features_px"]]
            frames.append((m["capture_stamp_ns"], xi))
    frames.sort()
    return frames


def frame_error(xi, desired):
    worst = 0.0
    for k in range(4):
        dx, dy = xi[2 * k] - desired[2 * k], xi[2 * k + 1] - desired[2 * k + 1]
        d = math.hypot(dx, dy)
        if math.isnan(d):
            return math.nan
        worst = max(worst, d)
    return worst


def swing(frames, desired):
    """Mark 1's error along its initial direction, as the lockstep's summary measures a step: how far it passes
    the target (% of its start), and after that deepest point how far it comes back past the target the other
    way (% of its start: a second swing). (None, None) when mark 1 is missing at the start."""
    along = []
    for _, xi in frames:
        along.append((xi[0] - desired[0], xi[1] - desired[1]))
    x0, y0 = along[0]
    size = x0 * x0 + y0 * y0
    if math.isnan(size) or size == 0.0:
        return None, None
    shares = [(x * x0 + y * y0) / size for x, y in along if not (math.isnan(x) or math.isnan(y))]
    deepest = min(range(len(shares)), key=lambda i: shares[i])
    return 100.0 * max(0.0, -shares[deepest]), 100.0 * max(0.0, max(shares[deepest:]))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("features")
    parser.add_argument("--desired", required=True)
    parser.add_argument("--compare")
    parser.add_argument("--compare-settling", type=float, help="the compared run's settling time (s), echoed")
    args = parser.parse_args()
    desired = [float(v) for v in args.desired.split(",")]
    frames = read_frames(args.features)
    if not frames:
        print(json.dumps({"error": "no features recorded"}))
        return 1
    t0 = frames[0][0]
    times = [(stamp - t0) / 1e9 for stamp, _ in frames]
    errors = [frame_error(xi, desired) for _, xi in frames]
    last_bad = max((i for i, e in enumerate(errors) if math.isnan(e) or e >= 1.0), default=None)
    if last_bad is None:
        settling = 0.0
    elif last_bad + 1 < len(frames):
        settling = times[last_bad + 1]
    else:
        settling = None
    summary = {
        "frames": len(frames),
        "duration_s": times[-1],
        # a mark missing in the first or last frame: null (JSON has no NaN)
        "initial_error_px": None if math.isnan(errors[0]) else errors[0],
        "final_error_px": None if math.isnan(errors[-1]) else errors[-1],
        "settling_time_s": settling,
    }
    summary["overshoot_percent"], summary["second_swing_percent"] = swing(frames, desired)
    if args.compare:
        with open(args.compare) as f:
            rows = [[float(v) if v else math.nan for v in row] for row in list(csv.reader(f))[1:]]
        reference_times = [row[0] for row in rows]
        diffs = []
        for t, (_, xi) in zip(times, frames):
            j = min(range(len(rows)), key=lambda j: abs(reference_times[j] - t))
            if abs(reference_times[j] - t) > 0.05 or any(math.isnan(v) for v in xi):
                continue
            diffs.extend((a - b) ** 2 for a, b in zip(xi, rows[j][1:9]))
        summary["rms_difference_px"] = math.sqrt(sum(diffs) / len(diffs)) if diffs else None
        summary["compared_settling_time_s"] = args.compare_settling
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
