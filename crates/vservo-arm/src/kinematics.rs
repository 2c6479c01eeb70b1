//! Forward kinematics, geometric Jacobians and manipulability.

use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

use crate::{Chain, DH_JOINTS, Geometry, Jacobian, JointVector, MAX_JOINTS, SerialArm, Transform};

/// The rotation and origin of every link frame in the base frame: `frames[i]` is `base_from_link(i+1)`; each
/// joint's axis; and the tool. Entries past `joint_count` are unused (their axes zero).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LinkFrames {
    pub joint_count: usize,
    pub rotations: [Matrix3<f64>; MAX_JOINTS],
    pub origins: [Vector3<f64>; MAX_JOINTS],
    /// Joint `j`'s axis (unit, base frame) and a point on it.
    joint_axes: [(Vector3<f64>, Vector3<f64>); MAX_JOINTS],
    tool_rotation: Matrix3<f64>,
    tool_origin: Vector3<f64>,
}

/// Every link of an arm at one joint vector, and each joint's axis.
#[derive(Debug, Clone, Copy)]
pub struct Placement {
    /// How many joints the arm has.
    pub joint_count: usize,
    /// `carriers[0]` is the base (the identity); `carriers[k]`, for `k` from 1 to `joint_count`, is the link
    /// joint `k − 1` moves, in the base frame (a DH arm's frame `k`; the last is the tool's for a DH arm, the
    /// last link's for a chain). Entries past `joint_count` are the identity.
    pub carriers: [Transform; MAX_JOINTS + 1],
    /// Joint `j`'s axis (unit, base frame) and a point on it.
    pub joint_axes: [(Vector3<f64>, Vector3<f64>); MAX_JOINTS],
}

impl LinkFrames {
    /// Joint `j`'s axis (unit, base frame) and a point on it (for a DH arm: z and origin of frame j-1, the
    /// base for j = 0).
    #[inline]
    pub fn joint_axis(&self, j: usize) -> (Vector3<f64>, Vector3<f64>) {
        self.joint_axes[j]
    }

    fn tool(&self) -> Transform {
        Transform::from_parts(
            Translation3::from(self.tool_origin),
            Rotation3::from_matrix_unchecked(self.tool_rotation),
        )
    }

    /// A DH arm's frames: the joint axes are the previous frames' z, the tool is the last frame.
    fn of_dh(rotations: [Matrix3<f64>; DH_JOINTS], origins: [Vector3<f64>; DH_JOINTS]) -> Self {
        let joint_axes = std::array::from_fn(|j| match j {
            0 => (Vector3::z(), Vector3::zeros()),
            j if j < DH_JOINTS => (rotations[j - 1].column(2).into_owned(), origins[j - 1]),
            _ => (Vector3::zeros(), Vector3::zeros()),
        });
        let tool_rotation = rotations[DH_JOINTS - 1];
        let tool_origin = origins[DH_JOINTS - 1];
        Self {
            joint_count: DH_JOINTS,
            rotations: std::array::from_fn(|i| rotations.get(i).copied().unwrap_or(tool_rotation)),
            origins: std::array::from_fn(|i| origins.get(i).copied().unwrap_or(tool_origin)),
            joint_axes,
            tool_rotation,
            tool_origin,
        }
    }

    /// A chain's frames (six or seven joints): each joint's moving link, its axis, and the tool.
    fn of_chain(chain: &Chain, q: &JointVector) -> Self {
        let frames = chain.frames(q.as_slice());
        Self {
            joint_count: frames.joint_count,
            rotations: std::array::from_fn(|i| *frames.links[i].rotation.matrix()),
            origins: std::array::from_fn(|i| frames.links[i].translation.vector),
            joint_axes: std::array::from_fn(|i| (frames.axes[i], frames.points[i])),
            tool_rotation: *frames.tool.rotation.matrix(),
            tool_origin: frames.tool.translation.vector,
        }
    }
}

impl SerialArm {
    /// sin θ and cos θ of every joint of a DH arm, computed up front so that they pipeline instead of
    /// sitting inside the serial chain of frame products.
    #[inline]
    pub(crate) fn joint_sin_cos(&self, q: &JointVector) -> [(f64, f64); DH_JOINTS] {
        let links = self.dh_links();
        std::array::from_fn(|i| links[i].dh.sin_cos_theta(q[i]))
    }

    #[inline]
    pub(crate) fn frames(&self, q: &JointVector) -> LinkFrames {
        match &self.geometry {
            Geometry::Dh => self.dh_frames(q),
            Geometry::Chain(chain) => LinkFrames::of_chain(chain, q),
        }
    }

    #[inline]
    fn dh_frames(&self, q: &JointVector) -> LinkFrames {
        let sin_cos = self.joint_sin_cos(q);
        let mut rotations = [Matrix3::identity(); DH_JOINTS];
        let mut origins = [Vector3::zeros(); DH_JOINTS];
        let mut axes = [Vector3::x(), Vector3::y(), Vector3::z()];
        let mut origin = Vector3::zeros();
        for (i, link) in self.dh_links().iter().enumerate() {
            let (s, c) = sin_cos[i];
            origin += link.dh.advance_axes(c, s, &mut axes);
            rotations[i] = Matrix3::from_columns(&axes);
            origins[i] = origin;
        }
        LinkFrames::of_dh(rotations, origins)
    }

    /// Every link frame in the base frame: element `i` is `base_from_link(i+1)` (for a chain: the link joint
    /// `i` moves), element `joint_count − 1` is the tool, and so are the elements past it.
    pub fn link_frames(&self, q: &JointVector) -> [Transform; MAX_JOINTS] {
        let frames = self.frames(q);
        std::array::from_fn(|i| {
            if i + 1 >= frames.joint_count {
                frames.tool()
            } else {
                Transform::from_parts(
                    Translation3::from(frames.origins[i]),
                    Rotation3::from_matrix_unchecked(frames.rotations[i]),
                )
            }
        })
    }

    /// Where every link is and what each joint turns about, at `q`: what a collision model places its bodies by
    /// and measures their speeds with.
    pub fn placement(&self, q: &JointVector) -> Placement {
        let frames = self.frames(q);
        let joints = frames.joint_count;
        Placement {
            joint_count: joints,
            carriers: std::array::from_fn(|k| match k {
                0 => Transform::identity(),
                k if k <= joints => Transform::from_parts(
                    Translation3::from(frames.origins[k - 1]),
                    Rotation3::from_matrix_unchecked(frames.rotations[k - 1]),
                ),
                _ => Transform::identity(),
            }),
            joint_axes: frames.joint_axes,
        }
    }

    /// The tool in the frame of the last joint's link ([`Placement::carriers`]'s last): a chain's fixed
    /// joints after its last moving one; the identity for a DH arm, whose last frame is the tool.
    pub fn last_from_tool(&self) -> Transform {
        match &self.geometry {
            Geometry::Dh => Transform::identity(),
            Geometry::Chain(chain) => chain.last_from_tip,
        }
    }

    /// The tool (DH frame 6, or a chain's tip link) in the base frame.
    pub fn base_from_tool(&self, q: &JointVector) -> Transform {
        self.frames(q).tool()
    }

    /// `base_from_tool` and the base-frame Jacobian together, from one pass over the links (the 1 ms
    /// interpolator needs both).
    pub fn base_from_tool_and_jacobian(&self, q: &JointVector) -> (Transform, Jacobian) {
        let frames = self.frames(q);
        (frames.tool(), jacobian_from_frames(&frames))
    }

    /// The geometric Jacobian in the base frame (the toolbox's `jacob0`): `[v; ω] = J q̇`, with `v` the
    /// velocity of the tool origin and `ω` the tool's angular velocity, both in base coordinates. The columns
    /// past the arm's joints are zero.
    pub fn jacobian_base(&self, q: &JointVector) -> Jacobian {
        let frames = self.frames(q);
        jacobian_from_frames(&frames)
    }

    /// The geometric Jacobian in the tool frame (the toolbox's `jacobe`): the same twist in tool coordinates.
    pub fn jacobian_tool(&self, q: &JointVector) -> Jacobian {
        let frames = self.frames(q);
        let jacobian = jacobian_from_frames(&frames);
        let tool_from_base = frames.tool_rotation.transpose();
        let mut out = Jacobian::zeros();
        out.fixed_view_mut::<3, MAX_JOINTS>(0, 0)
            .copy_from(&(tool_from_base * jacobian.fixed_view::<3, MAX_JOINTS>(0, 0)));
        out.fixed_view_mut::<3, MAX_JOINTS>(3, 0)
            .copy_from(&(tool_from_base * jacobian.fixed_view::<3, MAX_JOINTS>(3, 0)));
        out
    }

    /// Yoshikawa's manipulability √det(J Jᵀ) of the base-frame Jacobian; 0 at a singularity. For six joints
    /// that is |det J|.
    pub fn manipulability(&self, q: &JointVector) -> f64 {
        manipulability(&self.jacobian_base(q), self.joint_count)
    }
}

/// √det(J Jᵀ) of a Jacobian with `joint_count` columns (|det J| for six).
fn manipulability(jacobian: &Jacobian, joint_count: usize) -> f64 {
    if joint_count == DH_JOINTS {
        jacobian.fixed_view::<6, 6>(0, 0).determinant().abs()
    } else {
        (jacobian * jacobian.transpose()).determinant().max(0.0).sqrt()
    }
}

fn jacobian_from_frames(frames: &LinkFrames) -> Jacobian {
    let tool_origin = frames.tool_origin;
    let mut jacobian = Jacobian::zeros();
    for i in 0..frames.joint_count {
        let (axis, origin) = frames.joint_axis(i);
        let linear = axis.cross(&(tool_origin - origin));
        jacobian.fixed_view_mut::<3, 1>(0, i).copy_from(&linear);
        jacobian.fixed_view_mut::<3, 1>(3, i).copy_from(&axis);
    }
    jacobian
}
