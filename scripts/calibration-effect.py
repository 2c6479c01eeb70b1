"""The side by side of scripts/calibration-effect.sh: for each belief (nominal, calibrated, truth) the servo's
tracking error after the first revolution (t ≥ 12 s at 5 rev/min): per frame the RMS over the marks of the
features the servo got against its ξ_d (`vservoctl gains --json`), then its RMS, mean and largest over the
frames. Prints one JSON object with these and the calibration's errors against the truth.

usage: calibration-effect.py OUT_DIR
"""

import csv
import json
import math
import sys

FIRST_REVOLUTION_S = 12.0


def tracking(out, belief):
    desired = json.load(open(f"{out}/{belief}-gains.json"))["desired_features_px"]
    errors = []
    for row in csv.DictReader(open(f"{out}/{belief}/features.csv")):
        if float(row["t"]) < FIRST_REVOLUTION_S:
            continue
        features = [float(row[f"{axis}{mark}"]) for mark in range(1, 5) for axis in "xy"]
        if all(math.isfinite(v) for v in features):
            errors.append(math.sqrt(sum((f - d) ** 2 for f, d in zip(features, desired)) / 4))
    summary = json.load(open(f"{out}/{belief}/summary.json"))
    return {
        "frames": len(errors),
        "rms_px": math.sqrt(sum(e * e for e in errors) / len(errors)),
        "mean_px": sum(errors) / len(errors),
        "largest_px": max(errors),
        "final_error_px": summary["final_error_px"],
    }


def main():
    out = sys.argv[1]
    calibration = json.load(open(f"{out}/calibration.json"))
    print(json.dumps({
        "calibration_error_against_truth": calibration["error_against_truth"],
        "configured_error_against_truth": calibration["configured_error_against_truth"],
        "tracking_after_first_revolution": {b: tracking(out, b) for b in ("nominal", "calibrated", "truth")},
    }))


if __name__ == "__main__":
    main()
