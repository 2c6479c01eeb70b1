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
from cyclonedds.idl.types import array, float64, int32, int64, sequence, uint8, uint32, uint64


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped] = field(default_factory=list)


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    encoding: str = ""
    is_bigendian: uint8 = 0
    step: uint32 = 0
    data: sequence[uint8] = field(default_factory=list)


@dataclass
class RegionOfInterest(IdlStruct, typename="sensor_msgs::msg::dds_::RegionOfInterest_"):
    x_offset: uint32 = 0
    y_offset: uint32 = 0
    height: uint32 = 0
    width: uint32 = 0
    do_rectify: bool = False


@dataclass
class CameraInfo(IdlStruct, typename="sensor_msgs::msg::dds_::CameraInfo_"):
    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    distortion_model: str = ""
    d: sequence[float64] = field(default_factory=list)
    k: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    r: array[float64, 9] = field(default_factory=lambda: [0.0] * 9)
    p: array[float64, 12] = field(default_factory=lambda: [0.0] * 12)
    binning_x: uint32 = 0
    binning_y: uint32 = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[float64] = field(default_factory=list)


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8 = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: sequence[KeyValue] = field(default_factory=list)


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header = field(default_factory=Header)
    status: sequence[DiagnosticStatus] = field(default_factory=list)


def topic_name(namespace, relative):
    """The DDS topic of a ROS 2 topic."""
    return f"rt{namespace}/{relative}"


def service_names(namespace, relative):
    """The DDS request and reply topics of a ROS 2 service."""
    return f"rq{namespace}/{relative}Request", f"rr{namespace}/{relative}Reply"


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


def service_types(package, service, request_fields, response_fields):
    """A ROS 2 service's request and reply types as rmw_cyclonedds puts them on the wire: the client's 8-byte
    id and a 64-bit sequence number (the reply echoes both), then the `.srv` file's fields, given as
    (name, type, default) with a default factory for lists."""
    header = [("client_id", array[uint8, 8], lambda: [0] * 8), ("sequence_number", int64, 0)]

    def make(part, fields):
        typename = f"{package}::srv::dds_::{service}_{part}_"

        def body(namespace):
            namespace["__annotations__"] = {name: kind for name, kind, _ in header + fields}
            for name, _, default in header + fields:
                namespace[name] = field(default_factory=default) if callable(default) else default

        return dataclass(types.new_class(f"{service}{part}", (IdlStruct,), {"typename": typename}, body))

    return make("Request", request_fields), make("Response", response_fields)


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
