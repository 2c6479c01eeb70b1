"""The side by side of scripts/calibration-effect.sh: for each belief (nominal, calibrated, truth) the servo's
tracking error after the first revolution (t ≥ 12 s at 5 rev/min): per frame the RMS over the marks of the
features the servo got against its ξ_d (`vservoctl gains --json`), then its RMS, mean and largest over the
frames; and with two corners covered from 14 s to 15.5 s, the reacquiring: the error in the first frame that
sees the tag again, how long after the cover is lifted the error is back under 1 px, and the RMS over the
3 s after. Prints one JSON object with these and the calibration's errors against the truth.

usage: calibration-effect.py OUT_DIR
"""

import csv
import json
import math
import sys

FIRST_REVOLUTION_S = 12.0
# scripts/calibration-effect.sh's cover: two corners from 14 s to 15.5 s
UNCOVERED_S = 15.5
AFTER_UNCOVERED_S = 3.0


def errors_px(out, belief, run):
    """(t, RMS error against ξ_d) of every frame that sees all four corners."""
    desired = json.load(open(f"{out}/{belief}-gains.json"))["desired_features_px"]
    errors = []
    for row in csv.DictReader(open(f"{out}/{run}/features.csv")):
        # a mark not seen is written empty
        features = [float(row[f"{axis}{mark}"] or "nan") for mark in range(1, 5) for axis in "xy"]
        if all(math.isfinite(v) for v in features):
            errors.append((float(row["t"]), math.sqrt(sum((f - d) ** 2 for f, d in zip(features, desired)) / 4)))
    return errors


def reacquiring(out, belief):
    after = [(t, e) for t, e in errors_px(out, belief, f"{belief}-covered") if t >= UNCOVERED_S]
    window = [e for t, e in after if t < UNCOVERED_S + AFTER_UNCOVERED_S]
    back = next((t for t, e in after if e < 1.0), math.nan)
    return {
        "seen_again_at_s": after[0][0] if after else math.nan,
        "error_when_seen_again_px": after[0][1] if after else math.nan,
        "under_1px_after_uncovered_s": back - UNCOVERED_S,
        "rms_3s_after_uncovered_px": math.sqrt(sum(e * e for e in window) / len(window)) if window else math.nan,
    }


def tracking(out, belief):
    errors = [e for t, e in errors_px(out, belief, belief) if t >= FIRST_REVOLUTION_S]
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
        "reacquiring_after_two_corners_covered": {b: reacquiring(out, b) for b in ("nominal", "calibrated", "truth")},
    }))


if __name__ == "__main__":
    main()
