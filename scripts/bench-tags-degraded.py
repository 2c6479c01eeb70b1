"""vservo's tag detector against the AprilTag C library (pupil-apriltags) on renders degraded one way at a time:
the detection rate, the false detections and the corner error against the truth per condition and level, and the
time per image, both detectors in the same run on the same pixels (docs/BENCHMARKS.md, docs/VISION.md).

    cargo run --release -p vservo-vision --example degraded_tags -- DIR
    target/python-venv/bin/python scripts/bench-tags-degraded.py DIR [VSERVOCTL]

The C library runs with vservo's settings (one bit corrected, no quad blur, edge refinement on) at full resolution
(`quad_decimate` 1) and at the decimation of 2 vservo's servo starts with; vservo is `vservoctl tags --json` (every
tag at full resolution, refined). A tag counts as found when its id is the truth's (3); the corner error is the
RMS over its four corners of the distance to the true ones (vservo's pixels, which the library's corners are in
as they come: its quad fit adds the half pixel itself). Each row
prints found/images and the median corner RMS (px) for each detector.
"""

import json
import math
import os
import statistics
import subprocess
import sys
import time

import cv2
import pupil_apriltags


def rms(corners, truth):
    return math.sqrt(sum((x - t) ** 2 for x, t in zip(corners, truth)) / 4.0)


def flat(corners):
    return [v for point in corners for v in point]


def c_library(images, decimate):
    """For each image: (found corners or None, other ids found, seconds)."""
    detector = pupil_apriltags.Detector(
        families="tag36h11", nthreads=1, quad_decimate=decimate, quad_sigma=0.0, refine_edges=1
    )
    results = {}
    for name, path in images:
        gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        started = time.perf_counter()
        tags = [t for t in detector.detect(gray) if t.hamming <= 1]
        seconds = time.perf_counter() - started
        found = [flat([[x, y] for x, y in t.corners]) for t in tags if t.tag_id == 3]
        others = [int(t.tag_id) for t in tags if t.tag_id != 3]
        results[name] = (found[0] if found else None, others, seconds)
    return results


def vservo(images, vservoctl):
    results = {}
    for start in range(0, len(images), 40):
        batch = images[start:start + 40]
        out = subprocess.run([vservoctl, "tags", "--json"] + [p for _, p in batch], check=True,
                             capture_output=True, text=True).stdout
        by_path = {}
        for line in out.splitlines():
            picture = json.loads(line)
            by_path[picture["image"]] = picture
        for name, path in batch:
            picture = by_path[path]
            found = [flat(t["corners_px"]) for t in picture["tags"] if t["id"] == 3]
            others = [t["id"] for t in picture["tags"] if t["id"] != 3]
            results[name] = (found[0] if found else None, others, picture["detect_ms"] / 1e3)
    return results


def main() -> None:
    folder = sys.argv[1]
    vservoctl = sys.argv[2] if len(sys.argv) > 2 else "target/release/vservoctl"
    truth = json.load(open(os.path.join(folder, "truth.json")))
    images = [(name, os.path.join(folder, name + ".pgm")) for name in truth]
    detectors = {
        "vservo": vservo(images, vservoctl),
        "C full res": c_library(images, 1.0),
        "C decimate 2": c_library(images, 2.0),
    }
    rows = {}
    for name, entry in truth.items():
        rows.setdefault((entry["condition"], entry["level"]), []).append(name)
    print(f"{'condition':<18} {'level':>6} {'edge':>5} | " +
          " | ".join(f"{d:>12} found, RMS px" for d in detectors))
    worse = []
    for (condition, level), names in rows.items():
        cells = []
        summary = {}
        for detector, results in detectors.items():
            errors = [rms(results[n][0], truth[n]["corners_px"]) for n in names if results[n][0] is not None]
            median = statistics.median(errors) if errors else float("nan")
            summary[detector] = (len(errors), median)
            cells.append(f"{len(errors)}/{len(names):<2} {median:>12.3f}")
        edge = truth[names[0]]["edge_px"]
        print(f"{condition:<18} {level:>6} {edge:>5} | " + " | ".join(f"{c:>27}" for c in cells))
        v_found, v_rms = summary["vservo"]
        c_found, c_rms = summary["C full res"]
        if v_found < c_found or (v_found and c_found and v_rms > c_rms):
            worse.append(f"{condition} {level}: vservo {v_found} found, {v_rms:.3f} px; C {c_found}, {c_rms:.3f} px")
    false = {d: sum(len(r[n][1]) for n in truth) for d, r in detectors.items()}
    print("false detections (another id):", ", ".join(f"{d} {n}" for d, n in false.items()))
    for detector, results in detectors.items():
        times = sorted(r[2] * 1e3 for r in results.values())
        vga = sorted(results[n][2] * 1e3 for n in truth if truth[n]["condition"] != "tag_edge_px")
        large = sorted(results[n][2] * 1e3 for n in truth if truth[n]["condition"] == "tag_edge_px")
        print(f"time per image, {detector}: median {statistics.median(vga):.1f} ms at 640 × 480, "
              f"{statistics.median(large):.1f} ms at 1280 × 1024 (max {times[-1]:.1f} ms)")
    print("where vservo finds fewer or is less accurate than the C library at full resolution:")
    for line in worse or ["nowhere"]:
        print("  " + line)


if __name__ == "__main__":
    main()
