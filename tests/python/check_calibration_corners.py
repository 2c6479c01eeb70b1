"""Checks the calibration solver's corners (clients/python/vservo_calibrate.py: OpenCV's detector, in vservo's
pixels) against the true projections of the board's corners in the simulated cell's views: the camera as
`[camera.truth]` says it is, at the arm's pose of each view (`vservoctl calibrate --lockstep --json` reports the
truth). The truth is projected with OpenCV's projectPoints and moved by + ½ px into vservo's pixels (OpenCV's
pixel centres are at integers). A half-pixel mix-up of the conventions shows as a mean offset of 0.5 px.
Prints one JSON object: corners compared, mean offset (px, x and y), RMS distance (px).

usage: check_calibration_corners.py VIEWS_DIR REPORT_JSON
"""

import json
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "clients/python"))
import vservo_calibrate  # noqa: E402


def main():
    views_dir, report = Path(sys.argv[1]), json.loads(Path(sys.argv[2]).read_text())
    truth = report["truth"]
    camera = truth["camera"]
    k = np.array([[camera["fx"], 0.0, camera["cx"] - 0.5], [0.0, camera["fy"], camera["cy"] - 0.5], [0, 0, 1.0]])
    d = np.array(camera["distortion"], dtype=float)
    tool_from_camera = np.array(truth["tool_from_camera"])
    base_from_board = np.array(truth["base_from_board"])
    dataset = json.loads((views_dir / "dataset.json").read_text())
    layout = vservo_calibrate.board_corners(dataset["board"])
    found = vservo_calibrate.detect(views_dir, dataset, layout)
    offsets = []
    for view, detected in zip(dataset["views"], found):
        if detected["object"] is None:
            continue
        camera_from_board = np.linalg.inv(np.array(view["base_from_tool"]) @ tool_from_camera) @ base_from_board
        rvec = cv2.Rodrigues(camera_from_board[:3, :3])[0]
        projected, _ = cv2.projectPoints(detected["object"].astype(float), rvec, camera_from_board[:3, 3], k, d)
        offsets.append(detected["image"] - (projected.reshape(-1, 2) + 0.5))
    offsets = np.concatenate(offsets)
    mean = offsets.mean(axis=0)
    rms = float(np.sqrt(np.mean(np.sum(offsets ** 2, axis=1))))
    print(json.dumps({"corners": len(offsets), "mean_offset_px": mean.tolist(), "rms_px": rms}))
    if np.abs(mean).max() > 0.1 or rms > 0.5:
        print(f"check_calibration_corners: the corners are off the truth by {mean} px on average, {rms} px RMS",
              file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
