"""The solver of `vservoctl calibrate` (docs/CALIBRATION.md): the camera's intrinsics and lens, and the hand-eye
transform, from images of a grid of tag36h11 AprilTags taken at known arm poses.

OpenCV (opencv-python-headless 4.14) does the work it is the reference for: its ArucoDetector with the
DICT_APRILTAG_36h11 dictionary finds the tags (corners refined as the AprilTag library does), `calibrateCamera` (Zhang's method) gives the intrinsics and the
board's pose in each view, `calibrateHandEye` (Tsai–Lenz, and Park–Martin to compare) solves AX = XB. SciPy's
`least_squares` then refines everything jointly on the images: the intrinsics, the lens, `tool_from_camera` and
the board's one pose in the arm's base, so that every corner of every view is reprojected through the arm's
measured pose. Nothing is solved by hand here.

A camera fixed in the world (the dataset's "mount": "world", the board on the tool) is the same problem with the
arm's poses inverted: camera_from_board = (tool_from_base · base_from_camera)⁻¹ · tool_from_board, against
(base_from_tool · tool_from_camera)⁻¹ · base_from_board on the hand; OpenCV's documentation of
calibrateHandEye gives this recipe for eye-to-hand. The solution is then base_from_camera and tool_from_board.

Pixels: vservo's pixel (u, v) covers [u, u+1) × [v, v+1) (its centre at u + ½); OpenCV puts a pixel's centre at
u, but its AprilTag corner refinement, like the AprilTag library, adds the half pixel itself (`fit_quad`'s
"adjust for pixel center bias"): its corners are in vservo's pixels as they come (measured: +0.53 / +0.46 px
against the same corners refined by CORNER_REFINE_SUBPIX, which are in OpenCV's). Every number in and out is
vservo's; a test checks the detected corners against the true projections of the simulated cell.

usage: vservo_calibrate.py DATASET_DIR            (reads DATASET_DIR/dataset.json, prints one JSON object)
       vservo_calibrate.py --locate DATASET_DIR   (where the board is in the first view, through the camera as
                                                  the dataset believes it: OpenCV's solvePnP on every corner
                                                  found; what `vservoctl calibrate` plans a running cell's
                                                  poses around)
Exit 2 with the reason on stderr when the views cannot determine the calibration (or the board is not found).
"""

import json
import math
import sys
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

# a view is used when it finds at least this many tags (each gives four corners)
MIN_TAGS_PER_VIEW = 4
# and the calibration needs at least this many such views
MIN_VIEWS = 6
# what is added to the detector's corners to make them vservo's pixels: nothing, with the AprilTag refinement
CORNERS_TO_VSERVO_PX = 0.0
# a solution whose reprojection is worse than this does not fit the views: it is refused, not written
MAX_RMS_PX = 1.0
# the rotations between the views used must turn about axes spread this far (as `vservoctl calibrate` checks
# its plan: rotations of 5° or more, axes 15° apart or more)
MIN_ROTATION_DEG = 5.0
MIN_AXIS_SPREAD_DEG = 15.0


class Refused(Exception):
    """The views cannot determine the calibration; the message says why."""


def detector():
    parameters = cv2.aruco.DetectorParameters()
    # corners refined as the AprilTag library does (edges fitted on the image's gradients): on the simulated
    # cell's views 0.17 px RMS reprojection against 0.27 px with CORNER_REFINE_SUBPIX and 0.70 with CONTOUR
    parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_APRILTAG
    return cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11), parameters)


def tag_corners_opencv_order(tag_size_m, centre):
    """A tag's corners in the board frame in the order OpenCV's detector gives them. OpenCV's DICT_APRILTAG_36h11
    holds each code turned by a half turn from the AprilTag library's layout (which `vservoctl board` prints): its
    first corner, the "top left" of its upright marker, is the printed tag's bottom right (+x, +y in the board
    frame, x right and y down as an upright camera sees it), then clockwise in the image. A test pins it: the
    views of the simulated cell reproject to a tenth of a pixel only in this order."""
    h = 0.5 * tag_size_m
    cx, cy = centre
    return np.array([[cx + h, cy + h, 0.0], [cx - h, cy + h, 0.0], [cx - h, cy - h, 0.0], [cx + h, cy - h, 0.0]])


def board_corners(board):
    """Tag id → its four corners in the board frame (m), in OpenCV's order."""
    corners = {}
    for tag in board["tags"]:
        points = np.array(tag["corners_in_board_m"])
        centre = points[:, :2].mean(axis=0)
        corners[tag["id"]] = tag_corners_opencv_order(board["tag_size_m"], centre)
    return corners


def detect(dataset_dir, dataset, layout):
    """Per view: the board points and their detected image points (vservo's pixels), and the tags found."""
    found_views = []
    tag_detector = detector()
    for index, view in enumerate(dataset["views"]):
        image = cv2.imread(str(dataset_dir / view["image"]), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise Refused(f"view {index}: cannot read {view['image']}")
        corners, ids, _ = tag_detector.detectMarkers(image)
        object_points, image_points, tags = [], [], []
        for tag_id, tag_corners in zip([] if ids is None else ids.ravel(), corners):
            tag_id = int(tag_id)
            if tag_id not in layout:
                continue
            tags.append(tag_id)
            object_points.append(layout[tag_id])
            image_points.append(tag_corners.reshape(4, 2) + CORNERS_TO_VSERVO_PX)
        found_views.append({
            "tags": sorted(tags),
            "object": np.concatenate(object_points).astype(np.float32) if tags else None,
            "image": np.concatenate(image_points).astype(np.float32) if tags else None,
        })
    return found_views


def matrix(rows):
    m = np.array(rows, dtype=float)
    if m.shape != (4, 4):
        raise Refused(f"a pose is not a 4 × 4 matrix: {rows}")
    return m


def pose(rotation, translation):
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = np.ravel(translation)
    return m


def from_vector(v):
    return pose(cv2.Rodrigues(np.asarray(v[:3], dtype=float))[0], v[3:6])


def to_vector(m):
    return np.concatenate([cv2.Rodrigues(m[:3, :3])[0].ravel(), m[:3, 3]])


def rotation_deg(m):
    return math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(m[:3, :3]) - 1.0) / 2.0))))


def quaternion_xyzw(m):
    return [float(v) for v in Rotation.from_matrix(m[:3, :3]).as_quat()]


def check_spread(base_from_tool):
    """The views used must rotate about two axes at least (AX = XB), as `vservoctl calibrate`'s plan did."""
    axes = []
    for i, a in enumerate(base_from_tool):
        for b in base_from_tool[i + 1:]:
            rotvec = Rotation.from_matrix(a[:3, :3].T @ b[:3, :3]).as_rotvec()
            if np.degrees(np.linalg.norm(rotvec)) >= MIN_ROTATION_DEG:
                axes.append(rotvec / np.linalg.norm(rotvec))
    spread = max((math.degrees(math.acos(min(1.0, abs(float(a @ b))))) for i, a in enumerate(axes)
                  for b in axes[i + 1:]), default=0.0)
    if spread < MIN_AXIS_SPREAD_DEG:
        raise Refused(f"the rotations between the views used turn about axes within {spread:.1f}° of each other; "
                      f"AX = XB needs {MIN_AXIS_SPREAD_DEG:.0f}° or more")


def intrinsics_matrix(fx, fy, cx, cy):
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def zhang(views, image_size, nominal):
    """OpenCV's calibrateCamera from the nominal camera: intrinsics, lens (k1, k2, p1, p2; k3 held at 0) and the
    board's pose in each view (camera_from_board)."""
    k0 = intrinsics_matrix(nominal["fx"], nominal["fy"], nominal["cx"], nominal["cy"])
    d0 = np.array(nominal["distortion"], dtype=float)
    d0[4] = 0.0
    flags = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_K3
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    rms, k, d, rvecs, tvecs = cv2.calibrateCamera(
        [v["object"] for v in views], [v["image"] for v in views], image_size, k0, d0,
        flags=flags, criteria=criteria)
    camera_from_board = [pose(cv2.Rodrigues(r)[0], t) for r, t in zip(rvecs, tvecs)]
    return rms, k, d.ravel(), camera_from_board


def hand_eye(base_from_tool, camera_from_board, method):
    """OpenCV's calibrateHandEye (eye in hand): tool_from_camera."""
    rotation, translation = cv2.calibrateHandEye(
        [m[:3, :3] for m in base_from_tool], [m[:3, 3] for m in base_from_tool],
        [m[:3, :3] for m in camera_from_board], [m[:3, 3] for m in camera_from_board], method=method)
    return pose(rotation, translation)


def unpack(x):
    k = intrinsics_matrix(*x[0:4])
    d = np.array([x[4], x[5], x[6], x[7], 0.0])
    return k, d, from_vector(x[8:14]), from_vector(x[14:20])


def reprojection(x, views, base_from_tool):
    """Residuals (px) of every corner, each view seen through the arm's pose: camera_from_board =
    (base_from_tool · tool_from_camera)⁻¹ · base_from_board."""
    k, d, tool_from_camera, base_from_board = unpack(x)
    residuals = []
    for view, tool in zip(views, base_from_tool):
        camera_from_board = np.linalg.inv(tool @ tool_from_camera) @ base_from_board
        rvec = cv2.Rodrigues(camera_from_board[:3, :3])[0]
        projected, _ = cv2.projectPoints(view["object"].astype(float), rvec, camera_from_board[:3, 3], k, d)
        residuals.append((projected.reshape(-1, 2) - view["image"]).ravel())
    return np.concatenate(residuals)


def refine(views, base_from_tool, k, d, tool_from_camera, base_from_board):
    x0 = np.concatenate([[k[0, 0], k[1, 1], k[0, 2], k[1, 2]], d[:4], to_vector(tool_from_camera),
                         to_vector(base_from_board)])
    result = least_squares(reprojection, x0, args=(views, base_from_tool), method="lm", x_scale="jac",
                           xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=20000)
    if result.status <= 0 or not np.all(np.isfinite(result.x)):
        raise Refused(f"the joint refinement did not converge ({result.message})")
    return unpack(result.x)


def board_in_base(base_from_tool, tool_from_camera, camera_from_board):
    """The board's pose in the base from each view; their mean (rotation by the chordal mean)."""
    each = [t @ tool_from_camera @ c for t, c in zip(base_from_tool, camera_from_board)]
    u, _, vt = np.linalg.svd(sum(m[:3, :3] for m in each))
    rotation = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return pose(rotation, np.mean([m[:3, 3] for m in each], axis=0))


def ax_xb(base_from_tool, camera_from_board, tool_from_camera):
    """AX = XB over every pair of views (A the tool's motion, B the camera's from each view's board pose): the
    RMS rotation (deg) and translation (mm) of (AX)⁻¹ XB."""
    rotations, translations = [], []
    for i in range(len(base_from_tool)):
        for j in range(i + 1, len(base_from_tool)):
            a = np.linalg.inv(base_from_tool[i]) @ base_from_tool[j]
            b = camera_from_board[i] @ np.linalg.inv(camera_from_board[j])
            e = np.linalg.inv(a @ tool_from_camera) @ (tool_from_camera @ b)
            rotations.append(rotation_deg(e))
            translations.append(np.linalg.norm(e[:3, 3]) * 1e3)
    rms = lambda values: float(math.sqrt(np.mean(np.square(values)))) if values else 0.0
    return rms(rotations), rms(translations)


def per_view(views, base_from_tool, k, d, tool_from_camera, base_from_board, names):
    """Each view's reprojection RMS (px) and how far its own board pose (PnP with the final intrinsics)
    puts the board from the joint one (deg, mm): a view whose arm pose or image is off shows here."""
    report, camera_from_board = [], []
    for view, tool, name in zip(views, base_from_tool, names):
        ok, rvec, tvec = cv2.solvePnP(view["object"].astype(float), view["image"].astype(float), k, d,
                                      flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok:
            raise Refused(f"{name}: the board's pose cannot be found from its corners")
        own = pose(cv2.Rodrigues(rvec)[0], tvec)
        camera_from_board.append(own)
        joint = np.linalg.inv(tool @ tool_from_camera) @ base_from_board
        rvec_joint = cv2.Rodrigues(joint[:3, :3])[0]
        projected, _ = cv2.projectPoints(view["object"].astype(float), rvec_joint, joint[:3, 3], k, d)
        rms = float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - view["image"]) ** 2, axis=1))))
        off = np.linalg.inv(tool @ tool_from_camera @ own) @ base_from_board
        report.append({"image": name, "tags_found": len(view["tags"]), "rms_px": rms,
                       "hand_eye_rotation_deg": rotation_deg(off),
                       "hand_eye_translation_mm": float(np.linalg.norm(off[:3, 3]) * 1e3)})
    return report, camera_from_board


def transform_json(m):
    return {"matrix": m.tolist(), "translation_m": m[:3, 3].tolist(), "quaternion_xyzw": quaternion_xyzw(m)}


def solve(dataset_dir):
    if not cv2.__version__.startswith("4."):
        # OpenCV 5 changes the AprilTag dictionaries' orientation and corner order
        raise Refused(f"OpenCV {cv2.__version__}: the solver is written for OpenCV 4 (4.7 or later)")
    dataset = json.loads((dataset_dir / "dataset.json").read_text())
    layout = board_corners(dataset["board"])
    image_size = tuple(dataset["image_size"])
    found = detect(dataset_dir, dataset, layout)
    used = [i for i, v in enumerate(found) if len(v["tags"]) >= MIN_TAGS_PER_VIEW]
    if len(used) < MIN_VIEWS:
        counts = ", ".join(str(len(v["tags"])) for v in found)
        raise Refused(f"only {len(used)} views found the board ({MIN_TAGS_PER_VIEW} tags or more; tags found per "
                      f"view: {counts}); at least {MIN_VIEWS} are needed")
    views = [found[i] for i in used]
    names = [dataset["views"][i]["image"] for i in used]
    base_from_tool = [matrix(dataset["views"][i]["base_from_tool"]) for i in used]
    fixed = dataset.get("mount", "hand") == "world"
    if fixed:  # eye-to-hand: the hand-eye problem on the inverted poses (above)
        base_from_tool = [np.linalg.inv(m) for m in base_from_tool]
    check_spread(base_from_tool)
    zhang_rms, k, d, camera_from_board = zhang(views, image_size, dataset["camera"])
    tsai = hand_eye(base_from_tool, camera_from_board, cv2.CALIB_HAND_EYE_TSAI)
    park = hand_eye(base_from_tool, camera_from_board, cv2.CALIB_HAND_EYE_PARK)
    base_from_board = board_in_base(base_from_tool, tsai, camera_from_board)
    k, d, tool_from_camera, base_from_board = refine(views, base_from_tool, k, d, tsai, base_from_board)
    report, own_poses = per_view(views, base_from_tool, k, d, tool_from_camera, base_from_board, names)
    rotation_rms, translation_rms = ax_xb(base_from_tool, own_poses, tool_from_camera)
    residuals = reprojection(
        np.concatenate([[k[0, 0], k[1, 1], k[0, 2], k[1, 2]], d[:4], to_vector(tool_from_camera),
                        to_vector(base_from_board)]), views, base_from_tool).reshape(-1, 2)
    rms_px = float(np.sqrt(np.mean(np.sum(residuals ** 2, axis=1))))
    if not rms_px <= MAX_RMS_PX:
        raise Refused(f"the solution does not fit the views: reprojection {rms_px:.2f} px RMS (more than "
                      f"{MAX_RMS_PX} px; per view: " + ", ".join(f"{v['rms_px']:.2f}" for v in report) + ")")
    return {
        "fx": float(k[0, 0]), "fy": float(k[1, 1]), "cx": float(k[0, 2]), "cy": float(k[1, 2]),
        "k1": float(d[0]), "distortion": [float(v) for v in d],
        ("base_from_camera" if fixed else "tool_from_camera"): transform_json(tool_from_camera),
        ("tool_from_board" if fixed else "base_from_board"): transform_json(base_from_board),
        "rms_px": rms_px,
        "ax_xb_rotation_deg": rotation_rms,
        "ax_xb_translation_mm": translation_rms,
        "views": report,
        "views_unused": [dataset["views"][i]["image"] for i in range(len(found)) if i not in used],
        "initial": {"zhang_rms_px": float(zhang_rms), "tsai": transform_json(tsai), "park": transform_json(park)},
        "solver": f"OpenCV {cv2.__version__} (ArucoDetector DICT_APRILTAG_36h11, calibrateCamera, "
                  f"calibrateHandEye Tsai), SciPy least_squares (Levenberg-Marquardt) joint refinement",
    }


def locate(dataset_dir):
    """The board's pose in the first view's camera (camera_from_board), through the believed camera."""
    dataset = json.loads((dataset_dir / "dataset.json").read_text())
    layout = board_corners(dataset["board"])
    found = detect(dataset_dir, {"views": dataset["views"][:1]}, layout)[0]
    if len(found["tags"]) < MIN_TAGS_PER_VIEW:
        raise Refused(f"the board is not in view: {len(found['tags'])} of its tags found ({MIN_TAGS_PER_VIEW} "
                      f"needed); bring the camera over the board (as for servoing) and try again")
    nominal = dataset["camera"]
    k = intrinsics_matrix(nominal["fx"], nominal["fy"], nominal["cx"], nominal["cy"])
    d = np.array(nominal["distortion"], dtype=float)
    ok, rvec, tvec = cv2.solvePnP(found["object"], found["image"], k, d, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise Refused("OpenCV's solvePnP found no pose of the board in the view")
    projected, _ = cv2.projectPoints(found["object"], rvec, tvec, k, d)
    rms_px = float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - found["image"]) ** 2, axis=1))))
    return {"camera_from_board": transform_json(pose(cv2.Rodrigues(rvec)[0], tvec)),
            "tags_found": len(found["tags"]), "rms_px": rms_px}


def main():
    arguments = sys.argv[1:]
    locating = arguments[:1] == ["--locate"]
    if locating:
        arguments = arguments[1:]
    if len(arguments) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        result = locate(Path(arguments[0])) if locating else solve(Path(arguments[0]))
    except Refused as refused:
        print(f"vservo_calibrate: {refused}", file=sys.stderr)
        return 2
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
