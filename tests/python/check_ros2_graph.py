"""A ROS 2 node on Cyclone DDS (ROS 2's names and types on the wire, clients/python/ros2_types.py) that
listens to vservo's ROS 2 bridge for a while, calls its services, and prints one JSON object of what it got:
per topic the count and the newest sample; per service call the reply. The test judges it
(tests/tests/ros2_bridge.rs).

    check_ros2_graph.py --domain D [--namespace /ns] [--seconds S] [--before vservo/safe_stop]
                        [--settle-s S] [--after vservo/resume ...]

It waits for the first joint state, calls the `--before` services, waits `--settle-s`, listens for
`--seconds`, then calls the `--after` services.
"""

import argparse
import json
import os
import random
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "clients", "python"))

from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

import ros2_types as ros  # noqa: E402

TOPICS = {
    "joint_states": ros.JointState,
    "tf": ros.TFMessage,
    "camera/image_raw": ros.Image,
    "camera/camera_info": ros.CameraInfo,
    "vservo/features": ros.Float64MultiArray,
    "vservo/camera_twist": ros.TwistStamped,
    "diagnostics": ros.DiagnosticArray,
}


def stamp_s(header):
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def summary(name, sample):
    """What the test checks of a topic's newest sample."""
    if name == "joint_states":
        return {"stamp_s": stamp_s(sample.header), "name": list(sample.name), "position": list(sample.position),
                "velocity": list(sample.velocity), "effort": list(sample.effort)}
    if name == "camera/image_raw":
        data = bytes(sample.data)
        return {"stamp_s": stamp_s(sample.header), "frame_id": sample.header.frame_id, "width": sample.width,
                "height": sample.height, "encoding": sample.encoding, "step": sample.step, "bytes": len(data),
                "distinct_values": len(set(data))}
    if name == "camera/camera_info":
        return {"stamp_s": stamp_s(sample.header), "frame_id": sample.header.frame_id, "width": sample.width,
                "height": sample.height, "distortion_model": sample.distortion_model, "d": list(sample.d),
                "k": list(sample.k), "p": list(sample.p)}
    if name == "vservo/features":
        return {"data": [None if v != v else v for v in sample.data],
                "dims": [(d.label, d.size, d.stride) for d in sample.layout.dim]}
    if name == "vservo/camera_twist":
        t = sample.twist
        return {"stamp_s": stamp_s(sample.header), "frame_id": sample.header.frame_id,
                "linear": [t.linear.x, t.linear.y, t.linear.z], "angular": [t.angular.x, t.angular.y, t.angular.z]}
    if name == "diagnostics":
        return {"stamp_s": stamp_s(sample.header),
                "status": [{"name": s.name, "level": s.level, "message": s.message,
                            "values": {kv.key: kv.value for kv in s.values}} for s in sample.status]}
    return None


def percentiles(values):
    ordered = sorted(values)
    at = lambda p: 1e3 * ordered[min(len(ordered) - 1, int(p * len(ordered)))]  # noqa: E731
    return {"count": len(ordered), "p50": at(0.5), "p99": at(0.99), "max": 1e3 * ordered[-1]}


def transform_json(t):
    tr, q = t.transform.translation, t.transform.rotation
    return {"stamp_s": stamp_s(t.header), "parent": t.header.frame_id, "child": t.child_frame_id,
            "translation": [tr.x, tr.y, tr.z], "rotation_xyzw": [q.x, q.y, q.z, q.w]}


def request_of(spec):
    """A service call given as NAME (std_srvs/Trigger), NAME=x1,y1,...,x4,y4 (set_target_features) or
    NAME=x,y,z,qx,qy,qz,qw (set_target_pose): the service, its request and its reply types, the request's fields."""
    name, _, values = spec.partition("=")
    numbers = [float(v) for v in values.split(",")] if values else []
    if name.endswith("set_target_features"):
        return name, ros.SetTargetFeaturesRequest, ros.SetTargetFeaturesResponse, {"features_px": numbers}
    if name.endswith("set_target_pose"):
        x, y, z, qx, qy, qz, qw = numbers
        pose = ros.Pose(position=ros.Point(x=x, y=y, z=z), orientation=ros.Quaternion(x=qx, y=qy, z=qz, w=qw))
        return name, ros.SetTargetPoseRequest, ros.SetTargetPoseResponse, {"camera_from_target": pose}
    return name, ros.TriggerRequest, ros.TriggerResponse, {}


def send_malformed(participant, namespace, service, qos):
    """Writes requests under the service's request type name that are not ones (4 bytes where the header alone
    is 16): the bridge must refuse them, count them, and do nothing."""
    bad_type = ros._typed("Malformed", "std_srvs::srv::dds_::Trigger_Request_",
                          [("client_id", ros.array[ros.uint8, 4], lambda: [0] * 4)])
    request_topic, _ = ros.service_names(namespace, service)
    writer = DataWriter(participant, Topic(participant, request_topic, bad_type), qos=qos)
    deadline = time.time() + 5.0
    while time.time() < deadline and not writer.get_matched_subscriptions():
        time.sleep(0.05)
    # a few times: the bridge drops what arrives before it has matched this writer (volatile)
    for _ in range(3):
        time.sleep(0.5)
        writer.write(bad_type(client_id=[9, 9, 9, 9]))
    matched = bool(writer.get_matched_subscriptions())
    # the writer lives until the reliable sample is acknowledged (deleted at once, it may never be sent)
    writer.wait_for_acks(duration(seconds=2))
    return {"service": service, "malformed": True, "matched": matched}


def reply_json(reply):
    if hasattr(reply, "success"):
        return {"success": reply.success, "message": reply.message}
    return {"success": reply.accepted, "message": reply.reason, "gains_version": reply.gains_version,
            "target_features_px": [None if v != v else v for v in reply.target_features_px]}


def call(participant, namespace, spec, qos, timeout_s=5.0):
    """Calls a service as rmw_cyclonedds does; the reply that echoes our id and number."""
    service, request_type, reply_type, fields = request_of(spec)
    request_topic, reply_topic = ros.service_names(namespace, service)
    writer = DataWriter(participant, Topic(participant, request_topic, request_type), qos=qos)
    reader = DataReader(participant, Topic(participant, reply_topic, reply_type), qos=qos)
    client_id = [random.randrange(256) for _ in range(8)]
    number = random.randrange(1, 1 << 40)
    deadline = time.time() + timeout_s
    # as rclpy's service_is_ready: our requests matched by the server's reader and its replies by ours; then a
    # moment for the server's side of the match (it drops what comes from a writer it does not know yet)
    while time.time() < deadline and not (writer.get_matched_subscriptions() and reader.get_matched_publications()):
        time.sleep(0.05)
    time.sleep(0.5)
    writer.write(request_type(client_id=client_id, sequence_number=number, **fields))
    foreign = 0
    while time.time() < deadline:
        for reply in reader.take(10):
            if list(reply.client_id) == client_id and reply.sequence_number == number:
                return {"answered": True, "foreign": foreign, **reply_json(reply)}
            foreign += 1
        time.sleep(0.02)
    return {"answered": False, "foreign": foreign}


def marker_json(marker):
    """A marker as a test reads it: its frame, namespace, id, type, action, where, how large, its text and points."""
    p = marker.pose.position
    return {"frame_id": marker.header.frame_id, "ns": marker.ns, "id": marker.id, "type": marker.type,
            "action": marker.action, "position": [p.x, p.y, p.z],
            "scale": [marker.scale.x, marker.scale.y, marker.scale.z], "text": marker.text,
            "points": len(marker.points), "alpha": marker.color.a}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--domain", type=int, required=True)
    parser.add_argument("--namespace", default="")
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--before", action="append", default=[], help="a service to call before listening")
    parser.add_argument("--settle-s", type=float, default=1.5, help="the wait after the --before calls")
    parser.add_argument("--malformed", action="append", default=[],
                        help="a service to send a malformed request to before listening")
    parser.add_argument("--after", action="append", default=[], help="a service to call after listening")
    parser.add_argument("--wait-s", type=float, default=20.0, help="the longest wait for the first joint state")
    args = parser.parse_args()

    participant = DomainParticipant(args.domain)
    reliable = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10))
    best_effort = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(10))
    readers, reliable_readers = {}, {}
    for name, kind in TOPICS.items():
        topic = Topic(participant, ros.topic_name(args.namespace, name), kind)
        # what ROS's sensor-data profile asks, and what its default profile asks: both must hear every topic
        readers[name] = DataReader(participant, topic, qos=reliable if name in ("tf", "diagnostics") else best_effort)
        reliable_readers[name] = DataReader(participant, topic, qos=reliable)

    # /tf_static as tf2's static listener reads it: reliable, transient local (what was sent before it joined)
    static_reader = DataReader(participant, Topic(participant, ros.topic_name(args.namespace, "tf_static"),
                                                  ros.TFMessage),
                               qos=Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                                       Policy.Durability.TransientLocal, Policy.History.KeepLast(1)))
    static_frames = {}
    # /vservo/obstacles as RViz's marker display reads a latched topic: reliable, transient local
    obstacles_reader = DataReader(participant, Topic(participant, ros.topic_name(args.namespace, "vservo/obstacles"),
                                                     ros.MarkerArray),
                                  qos=Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                                          Policy.Durability.TransientLocal, Policy.History.KeepLast(1)))
    obstacles = []

    # the ROS 2 nodes the graph announces (what `ros2 node list` shows), kept for late joiners
    discovery = DataReader(participant, Topic(participant, "ros_discovery_info", ros.ParticipantEntitiesInfo),
                           qos=Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                                   Policy.Durability.TransientLocal, Policy.History.KeepLast(1)))
    nodes = set()
    counts = {name: 0 for name in TOPICS}
    reliable_counts = {name: 0 for name in TOPICS}
    newest = {}
    frames = {}
    # receipt less the header's stamp (s): the measurement (or exposure) to this node, both on this machine's clock
    ages = {"joint_states": [], "camera/image_raw": []}

    def take(keep):
        for name, reader in reliable_readers.items():
            taken = len(reader.take(100))
            if keep:
                reliable_counts[name] += taken
        for name, reader in readers.items():
            for sample in reader.take(100):
                if not keep:
                    continue
                counts[name] += 1
                newest[name] = sample
                if name in ages:
                    ages[name].append(time.time() - stamp_s(sample.header))
                if name == "tf":
                    for t in sample.transforms:
                        frames[f"{t.header.frame_id}->{t.child_frame_id}"] = transform_json(t)

    started = time.time()
    while time.time() - started < args.wait_s and not readers["joint_states"].take(1):
        time.sleep(0.01)
    calls = [send_malformed(participant, args.namespace, service, reliable) for service in args.malformed]
    for service in args.before:
        calls.append({"service": service.partition("=")[0], **call(participant, args.namespace, service, reliable)})
    if args.before or args.malformed:
        time.sleep(args.settle_s)
    take(keep=False)
    listening = time.time()
    while time.time() - listening < args.seconds:
        take(keep=True)
        for sample in static_reader.take(10):
            for t in sample.transforms:
                static_frames[f"{t.header.frame_id}->{t.child_frame_id}"] = transform_json(t)
        for sample in obstacles_reader.take(10):
            obstacles = [marker_json(m) for m in sample.markers]
        for info in discovery.take(10):
            for node in info.node_entities_info_seq:
                nodes.add(f"{node.node_namespace.rstrip('/')}/{node.node_name}")
        time.sleep(0.01)
    for service in args.after:
        calls.append({"service": service.partition("=")[0], **call(participant, args.namespace, service, reliable)})

    print(json.dumps({
        "wall_s": time.time(),
        "counts": counts,
        "reliable_counts": reliable_counts,
        "newest": {name: summary(name, sample) for name, sample in newest.items() if name != "tf"},
        "tf": frames,
        "tf_static": static_frames,
        "obstacles": obstacles,
        "calls": calls,
        "age_ms": {name: percentiles(values) for name, values in ages.items() if values},
        "ros_nodes": sorted(nodes),
    }))


if __name__ == "__main__":
    main()
