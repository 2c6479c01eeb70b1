#!/usr/bin/env python3
"""Checks the PyBullet driver's camera (clients/python/pybullet_driver.py) without vservod: a scene made by hand
(an arm from a URDF, default pybullet_data's xArm6; a board 0.5 m in front of the hand camera, tilted; four marks),
one frame rendered through the driver's camera path, and the four dark blobs found where a pinhole projection of
the mark centres, computed here in numpy from the same poses, says they are. Prints one JSON object; exit code 1
if a blob is more than --tolerance-px from its projection or the gray levels are not flat.

    pybullet-render-check.py [--urdf FILE --base-link L --tip-link L --joint-names j1,…] [--joints q1,…]
                             [--save-image FILE.pgm] [--scene-out scene.json]
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np
import pybullet_data

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "clients", "python"))
import pybullet_driver as driver  # noqa: E402


def rotation(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    t = np.eye(4)
    t[:3, :3] = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
    return t


def translation(x, y, z):
    t = np.eye(4)
    t[:3, 3] = [x, y, z]
    return t


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--urdf", default=os.path.join(pybullet_data.getDataPath(), "xarm/xarm6_robot.urdf"))
    parser.add_argument("--joint-names", default="joint1,joint2,joint3,joint4,joint5,joint6")
    parser.add_argument("--base-link", default="link_base")
    parser.add_argument("--tip-link", default="link6")
    parser.add_argument("--joints", default="0.3,-0.4,-0.9,0.2,1.1,0.4")
    parser.add_argument("--distance-m", type=float, default=0.5)
    parser.add_argument("--tolerance-px", type=float, default=1.0)
    parser.add_argument("--save-image")
    parser.add_argument("--scene-out", help="also write the scene made here (JSON), to run the driver on it")
    options = parser.parse_args()
    q = [float(v) for v in options.joints.split(",")]
    names = options.joint_names.split(",")
    marks = [[-0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05]]
    tool_from_camera = translation(0.0, 0.06, 0.03) @ rotation([0, 0, 1], 0.2)  # a camera beside the flange
    scene = {
        "arm": {"urdf": options.urdf, "base_link": options.base_link, "tip_link": options.tip_link,
                "joint_names": names},
        "start_joints_rad": q,
        "tool_from_camera": tool_from_camera.tolist(),
        "camera": {"fx_px": 800.0, "fy_px": 800.0, "principal_point_px": [320.0, 240.0], "width_px": 640,
                   "height_px": 480, "distortion": [0.0] * 5},
        "board": {"mark_diameter_m": 0.02, "marks_in_board_m": marks, "extent_m": [[-0.3, -0.25], [0.3, 0.25]]},
        "timing": {"vision_period_s": 0.085},
        "robot": {"command": "velocity", "period_s": 0.001},
    }
    # the board 0.5 m along the camera's axis, tilted 15° about an oblique axis and turned 25° in its plane
    probe = driver.Cell(scene, options.urdf)
    world_from_camera = probe.world_from_tip() @ tool_from_camera
    world_from_board = (world_from_camera @ translation(0.01, -0.02, options.distance_m)
                        @ rotation([1, 1, 0], math.radians(15)) @ rotation([0, 0, 1], math.radians(25)))
    scene["base_from_board"] = (np.linalg.inv(probe.world_from_base) @ world_from_board).tolist()
    if options.scene_out:
        with open(options.scene_out, "w") as file:
            json.dump(scene, file, indent=1)

    renderer = driver.Renderer(scene, options.urdf)
    image = renderer.image(q)
    times = []
    for _ in range(10):
        started = time.perf_counter()
        renderer.image(q)
        times.append(1e3 * (time.perf_counter() - started))
    if options.save_image:
        driver.write_pgm(options.save_image, image)

    # the marks' centres projected by the pinhole, from the camera pose the renderer used
    camera_from_world = np.linalg.inv(renderer.world_from_camera(q))
    k = np.array([[800.0, 0, 320.0], [0, 800.0, 240.0], [0, 0, 1]])
    dark = image < (driver.BOARD_GRAY + driver.MARK_GRAY) / 2
    results, counted, ok = [], 0, True
    for x, y in marks:
        p = camera_from_world @ world_from_board @ np.array([x, y, 0.0, 1.0])
        u, v = (k @ p[:3])[:2] / p[2]
        r0, c0 = int(v) - 25, int(u) - 25
        rows, cols = np.nonzero(dark[r0:r0 + 51, c0:c0 + 51])
        counted += len(rows)
        blob = (c0 + cols.mean() + 0.5, r0 + rows.mean() + 0.5) if len(rows) else (math.nan, math.nan)
        error = math.hypot(blob[0] - u, blob[1] - v)
        ok &= error <= options.tolerance_px
        results.append({"projected_px": [round(u, 3), round(v, 3)], "blob_px": [round(blob[0], 3), round(blob[1], 3)],
                        "error_px": round(error, 3), "pixels": int(len(rows))})
    levels, counts = np.unique(image, return_counts=True)
    common = {int(level): int(count) for level, count in zip(levels, counts) if count > 50}
    stray = int(dark.sum()) - counted
    ok &= stray == 0 and driver.MARK_GRAY in common and driver.BOARD_GRAY in common
    print(json.dumps({"marks": results, "stray_dark_pixels": stray, "gray_levels": common,
                      "render_ms_mean_max": [round(float(np.mean(times)), 1), round(float(np.max(times)), 1)],
                      "ok": bool(ok)}))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
