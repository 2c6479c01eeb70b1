"""Checks `vservoctl board`'s SVG with OpenCV's AprilTag 36h11 detector (an implementation apart from
vservo's): the SVG's rectangles are rasterised at PX_PER_MM, every tag of the layout must be found with its
id, and each found corner must lie on the layout's corner of that tag (board frame, m) to within half a
pixel. Prints one JSON object: tags found, worst corner distance (mm), the SVG's size (mm).

usage: check_board_svg.py BOARD.svg LAYOUT.json
"""

import json
import re
import sys
import xml.etree.ElementTree as ElementTree

import cv2
import numpy as np

PX_PER_MM = 4.0


def fail(message):
    print(f"check_board_svg: {message}", file=sys.stderr)
    sys.exit(1)


def rasterise(path):
    """The SVG's black rectangles on white, PX_PER_MM pixels per millimetre; and its size in mm."""
    root = ElementTree.parse(path).getroot()
    width_mm = float(re.sub("mm$", "", root.attrib["width"]))
    height_mm = float(re.sub("mm$", "", root.attrib["height"]))
    if root.attrib["viewBox"].split()[2:] != [root.attrib["width"][:-2], root.attrib["height"][:-2]]:
        fail(f"the viewBox {root.attrib['viewBox']} is not the size in mm")
    image = np.full((round(height_mm * PX_PER_MM), round(width_mm * PX_PER_MM)), 255, np.uint8)
    for rect in root.iter("{http://www.w3.org/2000/svg}rect"):
        if rect.attrib.get("fill") != "black":
            continue
        x, y, w, h = (float(rect.attrib[k]) * PX_PER_MM for k in ("x", "y", "width", "height"))
        image[round(y):round(y + h), round(x):round(x + w)] = 0
    return image, (width_mm, height_mm)


def main():
    if len(sys.argv) != 3:
        fail(__doc__)
    image, size_mm = rasterise(sys.argv[1])
    layout = json.load(open(sys.argv[2]))
    (low_x, low_y), _ = layout["extent_in_board_m"]
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    parameters = cv2.aruco.DetectorParameters()
    # corners refined to sub-pixel on the image's gradients (without, they are the contour polygon's)
    parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(dictionary, parameters)
    corners, ids, _ = detector.detectMarkers(image)
    found = {} if ids is None else {int(i): c.reshape(4, 2) for i, c in zip(ids.ravel(), corners)}
    expected = {tag["id"]: np.array(tag["corners_in_board_m"])[:, :2] for tag in layout["tags"]}
    if set(found) != set(expected):
        fail(f"ids found {sorted(found)}, the layout's {sorted(expected)}")
    worst_mm = 0.0
    # each tag's sides as measured on the picture (mm at PX_PER_MM), apart from the layout
    sides_mm = {tag_id: [float(np.linalg.norm(pixels[k] - pixels[(k + 1) % 4])) / PX_PER_MM for k in range(4)]
                for tag_id, pixels in found.items()}
    for tag_id, pixels in found.items():
        # OpenCV's pixel centres are at integers: a pixel's corner is at −0.5
        board_m = np.stack([(pixels[:, 0] + 0.5) / PX_PER_MM / 1e3 + low_x,
                            (pixels[:, 1] + 0.5) / PX_PER_MM / 1e3 + low_y], axis=1)
        for corner in expected[tag_id]:
            worst_mm = max(worst_mm, float(np.min(np.linalg.norm(board_m - corner, axis=1))) * 1e3)
    if worst_mm > 0.5 / PX_PER_MM:
        fail(f"a corner is {worst_mm:.3f} mm from the layout's (half a pixel is {0.5 / PX_PER_MM} mm)")
    print(json.dumps({"tags_found": len(found), "worst_corner_mm": worst_mm, "size_mm": size_mm,
                      "ids": sorted(found), "sides_mm": {str(k): v for k, v in sides_mm.items()}}))


if __name__ == "__main__":
    main()
