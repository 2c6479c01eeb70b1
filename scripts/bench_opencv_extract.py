#!/usr/bin/env python3
"""For scale beside `cargo bench -p vservo-vision`: OpenCV's Otsu threshold plus connected components with
statistics on the same kind of image.

    python3 -m venv /tmp/cv && /tmp/cv/bin/pip install opencv-python-headless
    cargo run -q -p vservoctl -- vision render --q 0.03,0.8,-3.1,0,0.75,0.05 --out /tmp/view.png
    /tmp/cv/bin/python scripts/bench_opencv_extract.py /tmp/view.png

Prints the median of 15 × 200 calls of cv2.threshold(THRESH_BINARY_INV | THRESH_OTSU) followed by
cv2.connectedComponentsWithStats (8-connected), and the blobs it finds of a mark's size.
"""

import statistics
import sys
import timeit

import cv2

image = cv2.imread(sys.argv[1], cv2.IMREAD_GRAYSCALE)
if image is None:
    sys.exit(f"cannot read {sys.argv[1]}")


def extract():
    level, dark = cv2.threshold(image, 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
    return level, cv2.connectedComponentsWithStats(dark, connectivity=8)


level, (count, labels, stats, centroids) = extract()
marks = [tuple(round(c, 2) for c in centroids[i]) for i in range(1, count) if 12 <= stats[i, cv2.CC_STAT_AREA] <= 6000]
print(f"image {image.shape[1]}x{image.shape[0]}, Otsu level {level}, {count - 1} components, mark-sized: {marks}")
runs = timeit.repeat(extract, number=200, repeat=15)
print(f"threshold + connectedComponentsWithStats: median {statistics.median(runs) / 200 * 1e3:.3f} ms")
