"""Reads a `vservoctl record` file with the `mcap` package from PyPI and checks that the arm it draws is the
arm configured: each `base → linkN` transform on /tf equals the forward kinematics at the joint angles of the
joint state with the same stamp, computed apart from vservo:
- of a standard-DH table (ARM is its JSON), with numpy from the DH convention alone (frame i = frame i−1 ·
  Rz(q_i + offset) · Tz(d) · Tx(a) · Rx(α)); to 1e-9;
- of a URDF (ARM is `urdf=PATH#TIP_LINK`), by PyBullet: link N is the link the chain's joint N moves, the last
  the tip link; to 1e-6 (PyBullet reports link poses in single precision).
Prints one JSON line of figures; exits 1 with the reason on the first failure.
Usage: check_arm_drawing.py FILE INSTANCE ARM"""

import json
import sys

import numpy as np
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def fail(why: str) -> None:
    print(f"check_arm_drawing: {why}", file=sys.stderr)
    sys.exit(1)


def dh_frames(dh, q):
    """The base → link i transforms (4×4) of a standard-DH arm at joint angles q."""
    frame, frames = np.eye(4), []
    for (a, alpha, d, offset), qi in zip(dh, q):
        theta = qi + offset
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        link = np.array([[ct, -st * ca, st * sa, a * ct],
                         [st, ct * ca, -ct * sa, a * st],
                         [0.0, sa, ca, d],
                         [0.0, 0.0, 0.0, 1.0]])
        frame = frame @ link
        frames.append(frame)
    return frames


class UrdfArm:
    """The chain from the URDF's root to `tip` in PyBullet: frames of the links its moving joints move."""

    def __init__(self, path, tip):
        import pybullet
        self.p = pybullet
        self.client = pybullet.connect(pybullet.DIRECT)
        self.body = pybullet.loadURDF(path, useFixedBase=True, physicsClientId=self.client)
        info = [pybullet.getJointInfo(self.body, j, physicsClientId=self.client)
                for j in range(pybullet.getNumJoints(self.body, physicsClientId=self.client))]
        by_link = {i[12].decode(): i for i in info}
        if tip not in by_link:
            fail(f"{path}: no link {tip!r}")
        self.tip, self.joints = by_link[tip][0], []
        index = self.tip
        while index >= 0:  # up the tree to the root, keeping the moving joints
            if info[index][2] != pybullet.JOINT_FIXED:
                self.joints.insert(0, index)
            index = info[index][16]

    def frames(self, q):
        p, c = self.p, self.client
        for joint, angle in zip(self.joints, q):
            p.resetJointState(self.body, joint, angle, physicsClientId=c)
        out = []
        for link in self.joints[:-1] + [self.tip]:
            state = p.getLinkState(self.body, link, computeForwardKinematics=True, physicsClientId=c)
            frame = np.eye(4)
            frame[:3, :3] = np.array(p.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            frame[:3, 3] = state[4]
            out.append(frame)
        return out


def rotation_of(quaternion):
    x, y, z, w = quaternion.x, quaternion.y, quaternion.z, quaternion.w
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def main() -> int:
    path, instance, arm = sys.argv[1], sys.argv[2], sys.argv[3]
    if arm.startswith("urdf="):
        urdf = UrdfArm(*arm[len("urdf="):].split("#"))
        expected_frames, count, tolerance = urdf.frames, len(urdf.joints), 1e-6
    else:
        dh = json.loads(arm)
        expected_frames, count, tolerance = (lambda q: dh_frames(dh, q)), len(dh), 1e-9
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        joints = {}  # stamp → q
        for _, _, message in reader.iter_messages(topics=[f"vservo/{instance}/joint_state"]):
            data = json.loads(message.data)
            joints[data["stamp_ns"]] = data["q_rad"]
        checked, worst_m, worst_rad, hands = 0, 0.0, 0.0, set()
        for _, _, _, decoded in reader.iter_decoded_messages(topics=["/tf"]):
            links = [t for t in decoded.transforms if t.child_frame_id.startswith("link")]
            if not links:
                continue
            stamp = links[0].timestamp.seconds * 10**9 + links[0].timestamp.nanos
            if stamp not in joints:
                fail(f"transforms at {stamp} ns match no joint state")
            expected = expected_frames(joints[stamp])
            if len(links) != count:
                fail(f"{len(links)} links drawn, the arm has {count}")
            for t in links:
                index = int(t.child_frame_id[len("link"):]) - 1
                position = np.array([t.translation.x, t.translation.y, t.translation.z])
                worst_m = max(worst_m, float(np.abs(position - expected[index][:3, 3]).max()))
                worst_rad = max(worst_rad, float(np.abs(rotation_of(t.rotation) - expected[index][:3, :3]).max()))
            hands.update(t.parent_frame_id for t in decoded.transforms if t.child_frame_id == "camera")
            checked += 1
    if checked == 0:
        fail("no arm transforms")
    if worst_m > tolerance or worst_rad > tolerance:
        fail(f"the drawn links are up to {worst_m} m and {worst_rad} off the configured arm's")
    print(json.dumps({"transforms_checked": checked, "worst_m": worst_m, "worst_rotation": worst_rad,
                      "camera_on": sorted(hands)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
