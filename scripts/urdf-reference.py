#!/usr/bin/env python3
"""Writes the URDF kinematics' PyBullet references (run by hand after a change of PyBullet; the output is
checked in): crates/vservo-arm/tests/data/pybullet_kinematics.json.

For arms of pybullet_data (the xArm6 and the Franka Panda, loaded from their URDFs by PyBullet 3.2.7), at
random joint vectors inside the limits: the tool link's pose in the base frame (PyBullet's link frame, not its
inertial frame) and the geometric Jacobian of the tool link's origin (p.calculateJacobian, rows [v; ω]).

Usage: target/python-venv/bin/python scripts/urdf-reference.py
"""
import json
import pathlib

import numpy as np
import pybullet as p
import pybullet_data

ROOT = pathlib.Path(__file__).resolve().parent.parent
# (name, URDF under pybullet_data, tool link)
ARMS = [
    ("xarm6", "xarm/xarm6_robot.urdf", "link6"),
    ("panda", "franka_panda/panda.urdf", "panda_link8"),
]
SAMPLES = 20


def reference(urdf, tip_link, rng):
    client = p.connect(p.DIRECT)
    body = p.loadURDF(str(pathlib.Path(pybullet_data.getDataPath()) / urdf), useFixedBase=True,
                      physicsClientId=client)
    moving, names, limits, tip = [], [], [], None
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        info = p.getJointInfo(body, j, physicsClientId=client)
        if info[12].decode() == tip_link:
            tip = j
        if info[2] != p.JOINT_FIXED:
            moving.append(j)
            names.append(info[1].decode())
            limits.append((info[8], info[9]))
    # the chain's joints: those on the way from the base to the tool (PyBullet numbers a link like its joint)
    chain, link = [], tip
    while link >= 0:
        if link in moving:
            chain.insert(0, link)
        link = p.getJointInfo(body, link, physicsClientId=client)[16]
    samples = []
    for _ in range(SAMPLES):
        q = [rng.uniform(lo + min(0.05, (hi - lo) / 4), hi - min(0.05, (hi - lo) / 4)) if hi > lo
             else rng.uniform(-3, 3) for lo, hi in limits]
        for j, angle in zip(moving, q):
            p.resetJointState(body, j, angle, physicsClientId=client)
        state = p.getLinkState(body, tip, computeForwardKinematics=True, physicsClientId=client)
        position, orientation = state[4], state[5]
        rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        # the link frame's origin: [0, 0, 0] (checked against central differences of getLinkState's link
        # frame position, to PyBullet's single precision; the inertial frame's offset is not to be added)
        link_origin = [0.0, 0.0, 0.0]
        zeros = [0.0] * len(moving)
        linear, angular = p.calculateJacobian(body, tip, link_origin, [float(v) for v in q], zeros, zeros,
                                              physicsClientId=client)
        columns = [moving.index(j) for j in chain]
        jacobian = np.vstack([np.array(linear)[:, columns], np.array(angular)[:, columns]])
        samples.append({
            "q_rad": [q[moving.index(j)] for j in chain],
            "base_from_tool_translation_m": list(position),
            "base_from_tool_rotation": rotation.tolist(),
            "jacobian_base": jacobian.tolist(),
        })
    p.disconnect(client)
    return {"urdf": urdf, "tip_link": tip_link, "joints": [names[moving.index(j)] for j in chain],
            "samples": samples}


def main():
    rng = np.random.default_rng(23)
    out = {"pybullet": p.getAPIVersion(), "arms": {name: reference(urdf, tip, rng) for name, urdf, tip in ARMS}}
    path = ROOT / "crates/vservo-arm/tests/data/pybullet_kinematics.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
