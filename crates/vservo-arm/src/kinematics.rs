//! Forward kinematics, geometric Jacobians and manipulability.

use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

use crate::{Chain, Geometry, JOINTS, JointMatrix, JointVector, SerialArm, Transform};

/// The rotation and origin of every link frame in the base frame: `frames[i]` is `base_from_link(i+1)`; each
/// joint's axis; and the tool.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LinkFrames {
    pub rotations: [Matrix3<f64>; JOINTS],
    pub origins: [Vector3<f64>; JOINTS],
    /// Joint `j`'s axis (unit, base frame) and a point on it.
    joint_axes: [(Vector3<f64>, Vector3<f64>); JOINTS],
    tool_rotation: Matrix3<f64>,
    tool_origin: Vector3<f64>,
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
    fn of_dh(rotations: [Matrix3<f64>; JOINTS], origins: [Vector3<f64>; JOINTS]) -> Self {
        let joint_axes = std::array::from_fn(|j| {
            if j == 0 {
                (Vector3::z(), Vector3::zeros())
            } else {
                (rotations[j - 1].column(2).into_owned(), origins[j - 1])
            }
        });
        Self {
            rotations,
            origins,
            joint_axes,
            tool_rotation: rotations[JOINTS - 1],
            tool_origin: origins[JOINTS - 1],
        }
    }

    /// A chain's frames (six joints): each joint's moving link, its axis, and the tool.
    fn of_chain(chain: &Chain, q: &JointVector) -> Self {
        let frames = chain.frames(q.as_slice());
        Self {
            rotations: std::array::from_fn(|i| *frames.links[i].rotation.matrix()),
            origins: std::array::from_fn(|i| frames.links[i].translation.vector),
            joint_axes: std::array::from_fn(|i| (frames.axes[i], frames.points[i])),
            tool_rotation: *frames.tool.rotation.matrix(),
            tool_origin: frames.tool.translation.vector,
        }
    }
}

impl SerialArm {
    /// sin θ and cos θ of every joint, computed up front so that they pipeline instead of sitting
    /// inside the serial chain of frame products.
    #[inline]
    pub(crate) fn joint_sin_cos(&self, q: &JointVector) -> [(f64, f64); JOINTS] {
        std::array::from_fn(|i| self.links[i].dh.sin_cos_theta(q[i]))
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
        let mut rotations = [Matrix3::identity(); JOINTS];
        let mut origins = [Vector3::zeros(); JOINTS];
        let mut axes = [Vector3::x(), Vector3::y(), Vector3::z()];
        let mut origin = Vector3::zeros();
        for (i, link) in self.links.iter().enumerate() {
            let (s, c) = sin_cos[i];
            origin += link.dh.advance_axes(c, s, &mut axes);
            rotations[i] = Matrix3::from_columns(&axes);
            origins[i] = origin;
        }
        LinkFrames::of_dh(rotations, origins)
    }

    /// Every link frame in the base frame: element `i` is `base_from_link(i+1)` (for a chain: the link joint
    /// `i` moves); the last is the tool.
    pub fn link_frames(&self, q: &JointVector) -> [Transform; JOINTS] {
        let frames = self.frames(q);
        std::array::from_fn(|i| {
            if i == JOINTS - 1 {
                frames.tool()
            } else {
                Transform::from_parts(
                    Translation3::from(frames.origins[i]),
                    Rotation3::from_matrix_unchecked(frames.rotations[i]),
                )
            }
        })
    }

    /// The tool (DH frame 6, or a chain's tip link) in the base frame.
    pub fn base_from_tool(&self, q: &JointVector) -> Transform {
        self.frames(q).tool()
    }

    /// `base_from_tool` and the base-frame Jacobian together, from one pass over the links (the 1 ms
    /// interpolator needs both).
    pub fn base_from_tool_and_jacobian(&self, q: &JointVector) -> (Transform, JointMatrix) {
        let frames = self.frames(q);
        (frames.tool(), jacobian_from_frames(&frames))
    }

    /// The geometric Jacobian in the base frame (the toolbox's `jacob0`): `[v; ω] = J q̇`, with `v` the
    /// velocity of the tool origin and `ω` the tool's angular velocity, both in base coordinates.
    pub fn jacobian_base(&self, q: &JointVector) -> JointMatrix {
        let frames = self.frames(q);
        jacobian_from_frames(&frames)
    }

    /// The geometric Jacobian in the tool frame (the toolbox's `jacobe`): the same twist in tool coordinates.
    pub fn jacobian_tool(&self, q: &JointVector) -> JointMatrix {
        let frames = self.frames(q);
        let jacobian = jacobian_from_frames(&frames);
        let tool_from_base = frames.tool_rotation.transpose();
        let mut out = JointMatrix::zeros();
        out.fixed_view_mut::<3, 6>(0, 0).copy_from(&(tool_from_base * jacobian.fixed_view::<3, 6>(0, 0)));
        out.fixed_view_mut::<3, 6>(3, 0).copy_from(&(tool_from_base * jacobian.fixed_view::<3, 6>(3, 0)));
        out
    }

    /// Yoshikawa's manipulability √det(J Jᵀ) of the base-frame Jacobian; 0 at a singularity.
    pub fn manipulability(&self, q: &JointVector) -> f64 {
        self.jacobian_base(q).determinant().abs()
    }
}

fn jacobian_from_frames(frames: &LinkFrames) -> JointMatrix {
    let tool_origin = frames.tool_origin;
    let mut jacobian = JointMatrix::zeros();
    for i in 0..JOINTS {
        let (axis, origin) = frames.joint_axis(i);
        let linear = axis.cross(&(tool_origin - origin));
        jacobian.fixed_view_mut::<3, 1>(0, i).copy_from(&linear);
        jacobian.fixed_view_mut::<3, 1>(3, i).copy_from(&axis);
    }
    jacobian
}
