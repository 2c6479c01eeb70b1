"""Reads a `vservoctl record --ros2` file with the Python `rosbags` library, as a ROS user's own tooling
would, twice: with the types the file's own schemas define, and with rosbags' ROS 2 Jazzy types. Prints one
JSON object: per topic the message type and count, the joint states' names, first and last stamps and
positions, the newest image's size, encoding and pixels, the obstacles' markers, and whether both readings agree.

    check_ros2_recording.py FILE.mcap
"""

import json
import sys
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore


def read(path, typestore):
    kwargs = {"default_typestore": typestore} if typestore else {}
    topics = {}
    joints = []
    image = None
    obstacles = None
    with AnyReader([Path(path)], **kwargs) as reader:
        for connection in reader.connections:
            topics[connection.topic] = {"type": connection.msgtype, "count": 0}
        for connection, log_time, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topics[connection.topic]["count"] += 1
            if connection.topic == "/joint_states":
                stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
                joints.append({"stamp_s": stamp, "log_s": log_time * 1e-9, "name": list(message.name),
                               "position": [float(v) for v in message.position]})
            if connection.topic == "/camera/image_raw":
                data = bytes(message.data)
                image = {"width": int(message.width), "height": int(message.height), "encoding": message.encoding,
                         "step": int(message.step), "bytes": len(data), "distinct_values": len(set(data)),
                         "frame_id": message.header.frame_id}
            if connection.topic == "/vservo/obstacles":
                obstacles = [{"ns": m.ns, "type": int(m.type), "action": int(m.action),
                              "scale": [round(float(v), 9) for v in (m.scale.x, m.scale.y, m.scale.z)]}
                             for m in message.markers]
    return topics, joints, image, obstacles


def main():
    own = read(sys.argv[1], None)
    jazzy = read(sys.argv[1], get_typestore(Stores.ROS2_JAZZY))
    topics, joints, image, obstacles = own
    print(json.dumps({
        "topics": topics,
        "joint_states": {"count": len(joints), "first": joints[0] if joints else None,
                         "last": joints[-1] if joints else None,
                         "stamps_increase": all(a["stamp_s"] < b["stamp_s"] for a, b in zip(joints, joints[1:]))},
        "image": image,
        "obstacles": obstacles,
        "readings_agree": own == jazzy,
    }))


if __name__ == "__main__":
    main()
