//! # vservo-ros2 — a vservo instance in a ROS 2 graph
//!
//! The bridge `vservo-ros2` (started by vservod with `[ros2] enabled = true`, or on its own) is a client of
//! the instance like any other: it reads the instance's iceoryx2 services with their safe overflow, so it is
//! never on the 1 ms path, and publishes them to ROS 2 over DDS with ros2-client 0.12 on RustDDS 0.15 (pure
//! Rust, no ROS installation): `joint_states`, `tf`, the camera's image and camera info, the features, the
//! camera twist and `diagnostics`; it serves `vservo/safe_stop` (always) and `vservo/resume` (only with
//! `allow_motion`) as `std_srvs/Trigger`. docs/ROS2.md has the topics, their types and QoS, and how to bind
//! DDS to one interface. The instance's robot and camera driver over ROS 2 is another binary of the crate,
//! `vservo-ros2-driver`: the bridge observes, the driver owns the arm.
//!
//! This library holds what can be checked without a network, and the two pieces of DDS that `vservoctl`
//! shares with the binary:
//! - [`msg`]: the ROS 2 messages as serde structures in their `.msg` field order, CDR on the wire, with their
//!   package and name;
//! - [`convert`] (pure): vservo's messages to ROS's — stamps from CLOCK_MONOTONIC to the system clock, ROS's
//!   pixel centres, the arm's tf chain `base` → `linkK` → `camera`, the target as seen from the four
//!   features' pose, diagnostics from `vservo_client::StatusView`;
//! - [`translate`]: which messages are made when — joint states at most at the configured rate with the arm's
//!   tf, each frame's features and the target, each twist, each image with its camera info, diagnostics;
//!   [`translate::Translator::look`] is one look at the instance (every 2 ms, and once a second the clock
//!   offset, services not yet open and the diagnostics), what the bridge publishes and `vservoctl record
//!   --ros2` writes, neither with a loop of its own;
//! - [`cell`]: the instance's side (its services, opened when they exist, read; messages of another schema
//!   refused by `vservo_protocol::inbox`, images too);
//! - [`schema`]: the messages' ROS 2 definitions as MCAP `ros2msg` schemas, their CDR with the encapsulation
//!   header; [`qos`]: ROS 2's profiles; [`names`]: topics and services in the namespace, their `rt/`, `rq/`,
//!   `rr/` DDS names;
//! - [`obstacles`] (pure): the collision guard's obstacles and workspace box as markers;
//! - [`target`]: a ROS target as the client's command (ROS's pixels to vservo's, a pose's unit quaternion to
//!   roll–pitch–yaw, the reply back);
//! - [`arm_driver`] (pure, time passed in): a ros2_control arm's `JointState` as the contract's `joint_state`
//!   (joints by name, tick by stamp, limit bits from the configured arm, the period checked with
//!   `vservo_driver`'s period check), the rmrc's command checked and turned into the forward controller's
//!   `Float64MultiArray`, the hold when no valid command comes; [`image_in`]: a ROS `Image` as 8-bit gray
//!   (mono8/16, rgb/bgr(a), yuyv; size and encoding refused with the reason);
//! - [`domain`]: joining the graph, the DDS participant in the configured domain, on one interface if asked;
//!   [`probe`]: an arm's joint names heard on its joint states (for `vservoctl check`).

pub mod arm_driver;
pub mod cell;
pub mod convert;
pub mod domain;
pub mod frames;
pub mod image_in;
pub mod msg;
pub mod names;
pub mod obstacles;
pub mod probe;
pub mod qos;
pub mod schema;
pub mod target;
pub mod translate;
