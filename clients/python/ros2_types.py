"""ROS 2 message types as Cyclone DDS IDL structures, with ROS 2's names on the wire.

ROS 2 (rmw_cyclonedds) puts a message `pkg/msg/Name` on DDS as the type `pkg::msg::dds_::Name_`, a topic
`/a/b` as `rt/a/b`, and a service `/s` as the topics `rq/sRequest` and `rr/sReply`, whose samples start with
the client's 8-byte id and a 64-bit sequence number that the reply echoes. These structures follow the `.msg`
and `.srv` files of ROS 2 Jazzy field for field, so a Cyclone DDS participant built with them is, on the wire,
a ROS 2 node (the test peers of vservo's ROS 2 bridge, docs/ROS2.md).
"""

import types
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int32, int64, sequence, uint8, uint32, uint64  # noqa: F401


def _typed(class_name, typename, fields):
    """An IDL structure of `fields` (name, type, default; a callable default is a factory, for lists and
    nested structures), in their order, with its DDS type name."""

    def body(namespace):
        namespace["__annotations__"] = {name: kind for name, kind, _ in fields}
        for name, _, default in fields:
            namespace[name] = field(default_factory=default) if callable(default) else default

    return dataclass(types.new_class(class_name, (IdlStruct,), {"typename": typename}, body))


def message(package, name, fields):
    """The ROS 2 message `package/msg/name` as DDS carries it: `package::msg::dds_::name_`."""
    return _typed(name, f"{package}::msg::dds_::{name}_", fields)


Time = message("builtin_interfaces", "Time", [("sec", int32, 0), ("nanosec", uint32, 0)])

Header = message("std_msgs", "Header", [("stamp", Time, Time), ("frame_id", str, "")])

JointState = message("sensor_msgs", "JointState", [
    ("header", Header, Header),
    ("name", sequence[str], list),
    ("position", sequence[float64], list),
    ("velocity", sequence[float64], list),
    ("effort", sequence[float64], list),
])

Vector3 = message("geometry_msgs", "Vector3", [("x", float64, 0.0), ("y", float64, 0.0), ("z", float64, 0.0)])

Quaternion = message("geometry_msgs", "Quaternion", [
    ("x", float64, 0.0),
    ("y", float64, 0.0),
    ("z", float64, 0.0),
    ("w", float64, 1.0),
])

Transform = message("geometry_msgs", "Transform", [
    ("translation", Vector3, Vector3),
    ("rotation", Quaternion, Quaternion),
])

TransformStamped = message("geometry_msgs", "TransformStamped", [
    ("header", Header, Header),
    ("child_frame_id", str, ""),
    ("transform", Transform, Transform),
])

TFMessage = message("tf2_msgs", "TFMessage", [("transforms", sequence[TransformStamped], list)])

Image = message("sensor_msgs", "Image", [
    ("header", Header, Header),
    ("height", uint32, 0),
    ("width", uint32, 0),
    ("encoding", str, ""),
    ("is_bigendian", uint8, 0),
    ("step", uint32, 0),
    ("data", sequence[uint8], list),
])

RegionOfInterest = message("sensor_msgs", "RegionOfInterest", [
    ("x_offset", uint32, 0),
    ("y_offset", uint32, 0),
    ("height", uint32, 0),
    ("width", uint32, 0),
    ("do_rectify", bool, False),
])

CameraInfo = message("sensor_msgs", "CameraInfo", [
    ("header", Header, Header),
    ("height", uint32, 0),
    ("width", uint32, 0),
    ("distortion_model", str, ""),
    ("d", sequence[float64], list),
    ("k", array[float64, 9], lambda: [0.0] * 9),
    ("r", array[float64, 9], lambda: [0.0] * 9),
    ("p", array[float64, 12], lambda: [0.0] * 12),
    ("binning_x", uint32, 0),
    ("binning_y", uint32, 0),
    ("roi", RegionOfInterest, RegionOfInterest),
])

Twist = message("geometry_msgs", "Twist", [("linear", Vector3, Vector3), ("angular", Vector3, Vector3)])

TwistStamped = message("geometry_msgs", "TwistStamped", [("header", Header, Header), ("twist", Twist, Twist)])

MultiArrayDimension = message("std_msgs", "MultiArrayDimension", [
    ("label", str, ""),
    ("size", uint32, 0),
    ("stride", uint32, 0),
])

MultiArrayLayout = message("std_msgs", "MultiArrayLayout", [
    ("dim", sequence[MultiArrayDimension], list),
    ("data_offset", uint32, 0),
])

Float64MultiArray = message("std_msgs", "Float64MultiArray", [
    ("layout", MultiArrayLayout, MultiArrayLayout),
    ("data", sequence[float64], list),
])

KeyValue = message("diagnostic_msgs", "KeyValue", [("key", str, ""), ("value", str, "")])

DiagnosticStatus = message("diagnostic_msgs", "DiagnosticStatus", [
    ("level", uint8, 0),
    ("name", str, ""),
    ("message", str, ""),
    ("hardware_id", str, ""),
    ("values", sequence[KeyValue], list),
])

DiagnosticArray = message("diagnostic_msgs", "DiagnosticArray", [
    ("header", Header, Header),
    ("status", sequence[DiagnosticStatus], list),
])

Point = message("geometry_msgs", "Point", [("x", float64, 0.0), ("y", float64, 0.0), ("z", float64, 0.0)])

Pose = message("geometry_msgs", "Pose", [("position", Point, Point), ("orientation", Quaternion, Quaternion)])

# visualization_msgs (the same fields in Humble and Jazzy): the collision guard's obstacles on vservo/obstacles
Duration = message("builtin_interfaces", "Duration", [("sec", int32, 0), ("nanosec", uint32, 0)])

ColorRGBA = message("std_msgs", "ColorRGBA", [("r", float32, 0.0), ("g", float32, 0.0), ("b", float32, 0.0),
                                              ("a", float32, 0.0)])

CompressedImage = message("sensor_msgs", "CompressedImage", [
    ("header", Header, Header),
    ("format", str, ""),
    ("data", sequence[uint8], list),
])

UVCoordinate = message("visualization_msgs", "UVCoordinate", [("u", float32, 0.0), ("v", float32, 0.0)])

MeshFile = message("visualization_msgs", "MeshFile", [("filename", str, ""), ("data", sequence[uint8], list)])

Marker = message("visualization_msgs", "Marker", [
    ("header", Header, Header),
    ("ns", str, ""),
    ("id", int32, 0),
    ("type", int32, 0),
    ("action", int32, 0),
    ("pose", Pose, Pose),
    ("scale", Vector3, Vector3),
    ("color", ColorRGBA, ColorRGBA),
    ("lifetime", Duration, Duration),
    ("frame_locked", bool, False),
    ("points", sequence[Point], list),
    ("colors", sequence[ColorRGBA], list),
    ("texture_resource", str, ""),
    ("texture", CompressedImage, CompressedImage),
    ("uv_coordinates", sequence[UVCoordinate], list),
    ("text", str, ""),
    ("mesh_resource", str, ""),
    ("mesh_file", MeshFile, MeshFile),
    ("mesh_use_embedded_materials", bool, False),
])

MarkerArray = message("visualization_msgs", "MarkerArray", [("markers", sequence[Marker], list)])

# rmw_dds_common (Jazzy: a 16-byte Gid): which ROS 2 nodes a participant holds, on `ros_discovery_info` (no `rt/`),
# what `ros2 node list` reads
Gid = message("rmw_dds_common", "Gid", [("data", array[uint8, 16], lambda: [0] * 16)])

NodeEntitiesInfo = message("rmw_dds_common", "NodeEntitiesInfo", [
    ("node_namespace", str, ""),
    ("node_name", str, ""),
    ("reader_gid_seq", sequence[Gid], list),
    ("writer_gid_seq", sequence[Gid], list),
])

ParticipantEntitiesInfo = message("rmw_dds_common", "ParticipantEntitiesInfo", [
    ("gid", Gid, Gid),
    ("node_entities_info_seq", sequence[NodeEntitiesInfo], list),
])


def service_types(package, service, request_fields, response_fields):
    """A ROS 2 service's request and reply types as rmw_cyclonedds puts them on the wire: the client's 8-byte
    id and a 64-bit sequence number (the reply echoes both), then the `.srv` file's fields."""
    header = [("client_id", array[uint8, 8], lambda: [0] * 8), ("sequence_number", int64, 0)]
    return tuple(
        _typed(f"{service}{part}", f"{package}::srv::dds_::{service}_{part}_", header + fields)
        for part, fields in (("Request", request_fields), ("Response", response_fields))
    )


# std_srvs/Trigger: an empty request carries the one member IDL needs
TriggerRequest, TriggerResponse = service_types(
    "std_srvs", "Trigger", [("structure_needs_at_least_one_member", uint8, 0)],
    [("success", bool, False), ("message", str, "")])

# vservo_msgs (clients/ros2/vservo_msgs): the bridge's target services
_TARGET_RESPONSE = [("accepted", bool, False), ("reason", str, ""), ("gains_version", uint64, 0),
                    ("target_features_px", array[float64, 8], lambda: [0.0] * 8)]
SetTargetFeaturesRequest, SetTargetFeaturesResponse = service_types(
    "vservo_msgs", "SetTargetFeatures", [("features_px", array[float64, 8], lambda: [0.0] * 8)], _TARGET_RESPONSE)
SetTargetPoseRequest, SetTargetPoseResponse = service_types(
    "vservo_msgs", "SetTargetPose", [("camera_from_target", Pose, Pose)], _TARGET_RESPONSE)


def topic_name(namespace, relative):
    """The DDS topic of a ROS 2 topic."""
    return f"rt{namespace}/{relative}"


def service_names(namespace, relative):
    """The DDS request and reply topics of a ROS 2 service."""
    return f"rq{namespace}/{relative}Request", f"rr{namespace}/{relative}Reply"
