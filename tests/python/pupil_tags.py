"""The AprilTag C library as Python users run it (pupil-apriltags), on pictures read by OpenCV: the reference for
`vservoctl tags` (tests/tests/vservoctl_tags.rs). For each picture it writes its grayscale as a PGM into OUT_DIR
(so that vservo reads the very same pixels) and prints one JSON line: the picture, the PGM, and every tag36h11 tag
found with quads at full resolution (id, corners as the library gives them, which are vservo's pixels: its quad
fit adds the half pixel itself, "adjust for pixel center bias"), with the settings vservo's detector uses (one bit corrected, no quad blur, edge refinement on).

    python pupil_tags.py OUT_DIR IMAGE...
"""

import json
import os
import sys

import cv2
import pupil_apriltags


def main() -> None:
    out_dir, images = sys.argv[1], sys.argv[2:]
    detector = pupil_apriltags.Detector(
        families="tag36h11", nthreads=1, quad_decimate=1.0, quad_sigma=0.0, refine_edges=1
    )
    for path in images:
        gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if gray is None:
            sys.exit(f"pupil_tags: {path}: not a picture OpenCV reads")
        pgm = os.path.join(out_dir, os.path.splitext(os.path.basename(path))[0] + ".pgm")
        cv2.imwrite(pgm, gray)
        tags = [
            {"id": int(t.tag_id), "corners_px": [[float(x), float(y)] for x, y in t.corners]}
            for t in detector.detect(gray)
            if t.hamming <= 1
        ]
        print(json.dumps({"image": path, "pgm": pgm, "width_px": gray.shape[1], "tags": tags}))


if __name__ == "__main__":
    main()
