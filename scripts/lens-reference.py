#!/usr/bin/env python3
"""Writes the lens model's OpenCV references (run by hand after a change of OpenCV; the outputs are checked in).

- crates/vservo-scene/tests/data/opencv_lens.json: for a few lenses, points in the camera frame and where
  cv2.projectPoints images them, and observed pixels over the image and where cv2.undistortPointsIter (P = K,
  iterated to convergence: at most 1000 steps, ε = 1e-15) puts them;
- crates/vservo-config/tests/data/opencv_calibration.yaml: a calibration written by cv2.FileStorage.

Usage: target/python-venv/bin/python scripts/lens-reference.py
"""
import json
import pathlib

import cv2
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent

# (name, fx, fy, cx, cy, width, height, [k1, k2, p1, p2, k3])
LENSES = [
    ("demo", 600.0, 606.0, 322.0, 237.0, 640, 480, [-0.25, 0.08, 0.0, 0.0, 0.0]),
    ("usb_cam", 438.783367, 437.302876, 305.593336, 243.738352, 640, 480, [-0.361976, 0.110510, 0.001014, 0.000505, 0.0]),
    ("tangential_k3", 1200.0, 1180.0, 650.0, 500.0, 1280, 1024, [0.12, -0.2, 0.002, -0.0015, 0.05]),
]


def lens_reference(name, fx, fy, cx, cy, width, height, coefficients, rng):
    k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dtype=np.float64)
    d = np.array(coefficients, dtype=np.float64)
    # points whose pinhole images lie over the image (and a little beyond), at depths 0.3–2 m
    n = 200
    pinhole = np.column_stack([rng.uniform(-0.05 * width, 1.05 * width, n), rng.uniform(-0.05 * height, 1.05 * height, n)])
    depth = rng.uniform(0.3, 2.0, n)
    points = np.column_stack([(pinhole[:, 0] - cx) / fx * depth, (pinhole[:, 1] - cy) / fy * depth, depth])
    projected, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), k, d)
    # observed pixels on a grid over the whole image, corners included
    us, vs = np.meshgrid(np.linspace(0, width, 17), np.linspace(0, height, 13))
    observed = np.column_stack([us.ravel(), vs.ravel()])
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, 1e-15)
    undistorted = cv2.undistortPointsIter(observed.reshape(-1, 1, 2), k, d, None, k, criteria)
    return {
        "name": name,
        "fx_px": fx, "fy_px": fy, "cx_px": cx, "cy_px": cy, "width_px": width, "height_px": height,
        "distortion": coefficients,
        "points_in_camera_m": points.tolist(),
        "projected_px": projected.reshape(-1, 2).tolist(),
        "observed_px": observed.tolist(),
        "undistorted_px": undistorted.reshape(-1, 2).tolist(),
    }


def main():
    rng = np.random.default_rng(24)
    lenses = [lens_reference(*lens, rng) for lens in LENSES]
    out = ROOT / "crates/vservo-scene/tests/data/opencv_lens.json"
    out.write_text(json.dumps({"opencv": cv2.__version__, "lenses": lenses}) + "\n")
    name, fx, fy, cx, cy, width, height, coefficients = LENSES[0]
    storage_path = ROOT / "crates/vservo-config/tests/data/opencv_calibration.yaml"
    storage = cv2.FileStorage(str(storage_path), cv2.FILE_STORAGE_WRITE)
    storage.write("image_width", width)
    storage.write("image_height", height)
    storage.write("camera_matrix", np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dtype=np.float64))
    storage.write("distortion_coefficients", np.array([coefficients], dtype=np.float64).T)
    storage.write("avg_reprojection_error", 0.21)
    storage.release()
    print(f"wrote {out} and {storage_path} with OpenCV {cv2.__version__}")


if __name__ == "__main__":
    main()
