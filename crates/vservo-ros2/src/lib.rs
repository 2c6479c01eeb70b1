//! # vservo-ros2 — a vservo instance in a ROS 2 graph
//!
//! The bridge `vservo-ros2` (started by vservod with `[ros2] enabled = true`, or on its own) is a client of
//! the instance like any other: it reads the instance's iceoryx2 services with their safe overflow, so it is
//! never on the 1 ms path, and publishes them to ROS 2 over DDS with ros2-client (RustDDS: pure Rust, no ROS
//! installation): `joint_states`, `tf`, the camera's image and camera info, the features, the camera twist and
//! `diagnostics`; it serves `vservo/safe_stop` (always) and `vservo/resume` (only with `allow_motion`) as
//! `std_srvs/Trigger`. docs/ROS2.md has the topics, their types and QoS, and how to bind DDS to one
//! interface.
//!
//! This library holds what can be checked without a network: the ROS 2 message types ([`msg`]), the
//! conversions from vservo's messages ([`convert`]) and which are made when ([`translate`]), the QoS ROS 2
//! users expect ([`qos`]), joining the domain ([`domain`]), hearing an arm's joint names ([`probe`]), the topic and service names in a namespace ([`names`]); and the instance's side
//! ([`cell`]: its services, read). `vservoctl record --ros2` writes the same messages to MCAP ([`schema`]:
//! their ROS 2 message definitions and CDR).

pub mod arm_driver;
pub mod cell;
pub mod convert;
pub mod domain;
pub mod image_in;
pub mod msg;
pub mod names;
pub mod probe;
pub mod qos;
pub mod schema;
pub mod target;
pub mod translate;
