//! A serial chain of revolute joints as a robot description gives it (URDF): each joint placed by a fixed
//! transform from its parent's frame, turning about an axis of its own frame, and the tool fixed to the last
//! link. This is the geometry of any arm that comes with a URDF; standard DH is the special case the PUMA 560
//! is written in ([`crate::DhParameters`]).
//!
//! Forward kinematics and the geometric Jacobian for six or seven joints, on fixed-size arrays, without
//! allocation (the 1 ms interpolator calls them every tick).

use nalgebra::{Matrix3, Rotation3, Translation3, Unit, Vector3};

use crate::Transform;

/// The most joints a chain may have.
pub const MAX_CHAIN_JOINTS: usize = crate::MAX_JOINTS;
/// The fewest joints a chain may have: six, to move the camera in all six directions.
pub const MIN_CHAIN_JOINTS: usize = crate::DH_JOINTS;

/// One revolute joint of a chain: where it sits on its parent link and the axis it turns about.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainJoint {
    /// The joint's name in the robot description (for messages and for drivers that address joints by name).
    pub name: String,
    /// The link it moves (its URDF `<child>`): the frame at `parent_from_joint` turned by the joint, which ROS
    /// tools name so on `tf`.
    pub child_link: String,
    /// The joint frame at q = 0 in the frame of the link before it (URDF `<origin>`, fixed joints before it
    /// folded in).
    pub parent_from_joint: Transform,
    /// The axis the joint turns about, a unit vector in the joint frame (URDF `<axis>`).
    pub axis: Unit<Vector3<f64>>,
}

/// A serial chain from the arm's base to its tool.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    /// The base link's name: the frame every pose is given in.
    pub base_link: String,
    /// The tool link's name: the frame `tool_from_camera` is given in.
    pub tip_link: String,
    /// The moving joints from the base outwards (six or seven).
    pub joints: Vec<ChainJoint>,
    /// The tool in the frame of the last joint (fixed joints after it folded in).
    pub last_from_tip: Transform,
}

/// The frames of a chain at one joint vector: what kinematics and the Jacobian need, for up to seven joints.
#[derive(Debug, Clone, Copy)]
pub struct ChainFrames {
    /// How many of the entries below are the chain's.
    pub joint_count: usize,
    /// Joint `i`'s axis (unit) in the base frame.
    pub axes: [Vector3<f64>; MAX_CHAIN_JOINTS],
    /// The origin of joint `i`'s frame (a point on its axis) in the base frame.
    pub points: [Vector3<f64>; MAX_CHAIN_JOINTS],
    /// The link each joint moves (the joint frame turned by q), in the base frame.
    pub links: [Transform; MAX_CHAIN_JOINTS],
    /// The tool in the base frame.
    pub tool: Transform,
}

impl ChainFrames {
    /// The geometric Jacobian in the base frame, rows `[v; ω]` of the tool origin; columns past
    /// `joint_count` are zero.
    pub fn jacobian_base(&self) -> crate::Jacobian {
        let tool_origin = self.tool.translation.vector;
        let mut jacobian = crate::Jacobian::zeros();
        for i in 0..self.joint_count {
            let linear = self.axes[i].cross(&(tool_origin - self.points[i]));
            jacobian.fixed_view_mut::<3, 1>(0, i).copy_from(&linear);
            jacobian.fixed_view_mut::<3, 1>(3, i).copy_from(&self.axes[i]);
        }
        jacobian
    }
}

impl Chain {
    /// The number of moving joints.
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// Every frame of the chain at `q` (one angle per joint, rad; extra entries are ignored).
    ///
    /// Each joint's rotation about its axis uses `libm::sincos`, the same bits on every platform, as the
    /// lockstep simulator's repeatability wants.
    pub fn frames(&self, q: &[f64]) -> ChainFrames {
        let mut frames = ChainFrames {
            joint_count: self.joints.len().min(MAX_CHAIN_JOINTS),
            axes: [Vector3::zeros(); MAX_CHAIN_JOINTS],
            points: [Vector3::zeros(); MAX_CHAIN_JOINTS],
            links: [Transform::identity(); MAX_CHAIN_JOINTS],
            tool: Transform::identity(),
        };
        let mut base_from_link = Transform::identity();
        for (i, joint) in self.joints.iter().take(MAX_CHAIN_JOINTS).enumerate() {
            let base_from_joint = base_from_link * joint.parent_from_joint;
            frames.axes[i] = base_from_joint.rotation * joint.axis.into_inner();
            frames.points[i] = base_from_joint.translation.vector;
            let angle = q.get(i).copied().unwrap_or(0.0);
            base_from_link = base_from_joint * rotation_about(&joint.axis, angle);
            frames.links[i] = base_from_link;
        }
        frames.tool = base_from_link * self.last_from_tip;
        frames
    }
}

/// A rotation by `angle` about the unit `axis`, as a transform (Rodrigues' formula).
fn rotation_about(axis: &Unit<Vector3<f64>>, angle: f64) -> Transform {
    let (s, c) = libm::sincos(angle);
    let k = axis.into_inner();
    let cross = Matrix3::new(0.0, -k.z, k.y, k.z, 0.0, -k.x, -k.y, k.x, 0.0);
    let matrix = Matrix3::identity() + cross * s + cross * cross * (1.0 - c);
    Transform::from_parts(Translation3::identity(), Rotation3::from_matrix_unchecked(matrix))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joint(name: &str, xyz: [f64; 3], axis: Vector3<f64>) -> ChainJoint {
        ChainJoint {
            name: name.to_string(),
            child_link: format!("{name}_link"),
            parent_from_joint: Transform::from_parts(
                Translation3::new(xyz[0], xyz[1], xyz[2]),
                Rotation3::identity(),
            ),
            axis: Unit::new_normalize(axis),
        }
    }

    #[test]
    fn a_rotation_about_an_axis_matches_nalgebras_axis_angle() {
        let axis = Unit::new_normalize(Vector3::new(0.3, -0.5, 0.8));
        for angle in [-2.5, -0.3, 0.0, 0.7, 3.0] {
            let ours = rotation_about(&axis, angle).rotation;
            let theirs = Rotation3::from_axis_angle(&axis, angle);
            assert!((ours.matrix() - theirs.matrix()).amax() < 1e-15, "angle {angle}");
        }
    }

    #[test]
    fn a_planar_chain_puts_the_tool_where_the_angles_say() {
        // three joints about z, links of 0.5 m and 0.3 m along x, then the tool 0.2 m further
        let chain = Chain {
            base_link: "base".into(),
            tip_link: "tip".into(),
            joints: vec![
                joint("a", [0.0, 0.0, 0.0], Vector3::z()),
                joint("b", [0.5, 0.0, 0.0], Vector3::z()),
                joint("c", [0.3, 0.0, 0.0], Vector3::z()),
            ],
            last_from_tip: Transform::from_parts(Translation3::new(0.2, 0.0, 0.0), Rotation3::identity()),
        };
        let q = [0.4, -0.9, 0.3];
        let frames = chain.frames(&q);
        let (a, ab, abc) = (q[0], q[0] + q[1], q[0] + q[1] + q[2]);
        let expected = Vector3::new(
            0.5 * a.cos() + 0.3 * ab.cos() + 0.2 * abc.cos(),
            0.5 * a.sin() + 0.3 * ab.sin() + 0.2 * abc.sin(),
            0.0,
        );
        assert!((frames.tool.translation.vector - expected).norm() < 1e-15);
        assert!((frames.tool.rotation.angle() - abc.abs()).abs() < 1e-14);
        assert_eq!(frames.joint_count, 3);
        assert!(
            (frames.points[2]
                - Vector3::new(0.5 * a.cos() + 0.3 * ab.cos(), 0.5 * a.sin() + 0.3 * ab.sin(), 0.0))
            .norm()
                < 1e-15
        );
    }
}
