"""Reads a `vservoctl record` file with the `mcap` package from PyPI and checks that the arm it draws is the
arm configured: each `base → linkN` transform on /tf equals the forward kinematics of the given standard-DH
table at the joint angles of the joint state with the same stamp, computed here with numpy from the DH
convention alone (frame i = frame i−1 · Rz(q_i + offset) · Tz(d) · Tx(a) · Rx(α)). Prints one JSON line of
figures; exits 1 with the reason on the first failure. Usage: check_arm_drawing.py FILE INSTANCE DH_JSON"""

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


def rotation_of(quaternion):
    x, y, z, w = quaternion.x, quaternion.y, quaternion.z, quaternion.w
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def main() -> int:
    path, instance, dh = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
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
            expected = dh_frames(dh, joints[stamp])
            if len(links) != len(dh):
                fail(f"{len(links)} links drawn, the arm has {len(dh)}")
            for t in links:
                index = int(t.child_frame_id[len("link"):]) - 1
                position = np.array([t.translation.x, t.translation.y, t.translation.z])
                worst_m = max(worst_m, float(np.abs(position - expected[index][:3, 3]).max()))
                worst_rad = max(worst_rad, float(np.abs(rotation_of(t.rotation) - expected[index][:3, :3]).max()))
            hands.update(t.parent_frame_id for t in decoded.transforms if t.child_frame_id == "camera")
            checked += 1
    if checked == 0:
        fail("no arm transforms")
    if worst_m > 1e-9 or worst_rad > 1e-9:
        fail(f"the drawn links are up to {worst_m} m and {worst_rad} off the configured arm's")
    print(json.dumps({"transforms_checked": checked, "worst_m": worst_m, "worst_rotation": worst_rad,
                      "camera_on": sorted(hands)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
