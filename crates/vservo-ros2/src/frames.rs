//! The arm's and the camera's frames as ROS names them: a URDF arm's base link and the link each joint moves,
//! its tool (tip) link, and the camera's optical frame (`camera_optical_frame`: x right, y down, z along the
//! axis, ROS's optical convention, which is vservo's camera frame). A DH arm (the PUMA 560) has no link names of
//! its own: `base`, `link1` … `linkN`, the last being the tool.
//!
//! The moving links go on `tf` with each joint state; what does not move — the tool on the last link, where it
//! is a frame of its own, and the camera on the tool — goes on `/tf_static` once (transient local: a node that
//! joins later gets it too), as tf2's static broadcaster sends it.

use nalgebra::IsometryMatrix3;
use vservo_arm::{Geometry, JointVector, SerialArm};
use vservo_protocol::JointStateMsg;

use crate::convert::{CAMERA_FRAME, transform};
use crate::msg::{Time, TransformStamped};

/// The frames of an arm on `tf`.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmFrames {
    /// The frame every pose is in: a URDF's base link, `base` for a DH arm.
    pub base: String,
    /// The link each joint moves, base outwards.
    pub links: Vec<String>,
    /// The tool (a URDF's tip link) and its pose in the last link's frame, where it is a frame of its own.
    pub tool: Option<(String, IsometryMatrix3<f64>)>,
}

impl ArmFrames {
    /// The frames of `arm`, by its robot description's names where it has them.
    pub fn of(arm: &SerialArm) -> Self {
        match &arm.geometry {
            Geometry::Chain(chain) => {
                let links: Vec<String> = chain.joints.iter().map(|joint| joint.child_link.clone()).collect();
                let last = links.last().cloned().unwrap_or_default();
                let tool = (chain.tip_link != last).then(|| (chain.tip_link.clone(), chain.last_from_tip));
                Self { base: chain.base_link.clone(), links, tool }
            }
            Geometry::Dh => Self {
                base: "base".to_string(),
                links: (1..=arm.joint_count()).map(|j| format!("link{j}")).collect(),
                tool: None,
            },
        }
    }

    /// The frame the camera is mounted on: the tool.
    pub fn tool_frame(&self) -> &str {
        match &self.tool {
            Some((tool, _)) => tool,
            None => self.links.last().map_or(self.base.as_str(), String::as_str),
        }
    }

    /// The moving links at a joint state (`base` → the first link → … → the last), for `tf`; none from a state
    /// of another arm's joint count.
    pub fn moving(&self, arm: &SerialArm, state: &JointStateMsg, stamp: Time) -> Vec<TransformStamped> {
        let n = self.links.len();
        let Some(q) = state.arm_q_rad(n).map(JointVector::from) else { return Vec::new() };
        let base_from_links = arm.link_frames(&q);
        // the last entry is the tool's frame; the last link is the tool less its fixed offset
        let last_from_tool = self.tool.as_ref().map_or(IsometryMatrix3::identity(), |(_, pose)| *pose);
        let mut transforms = Vec::with_capacity(n);
        let mut parent = (self.base.as_str(), IsometryMatrix3::identity());
        for (i, link) in self.links.iter().enumerate() {
            let base_from_link =
                if i + 1 == n { base_from_links[i] * last_from_tool.inverse() } else { base_from_links[i] };
            transforms.push(transform(stamp, parent.0, link, &(parent.1.inverse() * base_from_link)));
            parent = (link.as_str(), base_from_link);
        }
        transforms
    }

    /// What does not move, for `/tf_static`: the tool on the last link (where it is a frame of its own) and the
    /// camera's optical frame on the tool (a camera fixed in the world: in the base frame).
    pub fn fixed(&self, mount: &vservo_scene::CameraMount, stamp: Time) -> Vec<TransformStamped> {
        let mut transforms = Vec::with_capacity(2);
        if let (Some((tool, last_from_tool)), Some(last)) = (&self.tool, self.links.last()) {
            transforms.push(transform(stamp, last, tool, last_from_tool));
        }
        match mount {
            vservo_scene::CameraMount::Hand { tool_from_camera } => {
                transforms.push(transform(stamp, self.tool_frame(), CAMERA_FRAME, tool_from_camera));
            }
            vservo_scene::CameraMount::World { base_from_camera, .. } => {
                transforms.push(transform(stamp, &self.base, CAMERA_FRAME, base_from_camera));
            }
        }
        transforms
    }
}
