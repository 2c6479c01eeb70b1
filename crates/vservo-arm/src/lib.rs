//! # vservo-arm — the serial-arm model
//!
//! This crate owns the model of the manipulator that carries vservo's camera: an all-revolute serial arm of
//! six joints in standard Denavit–Hartenberg form, or of six or seven as the chain of a URDF ([`urdf`],
//! [`chain`]; joint vectors have room for [`MAX_JOINTS`], the Jacobian is 6×7), with the
//! **PUMA 560** built in
//! ([`puma560::puma560`]) exactly as Peter Corke's Robotics Toolbox defines it (DH and inertial parameters
//! of Armstrong, Khatib & Burdick 1986; motor inertias, gear ratios and friction of the toolbox's
//! `Puma560`; the pedestal included in d₁ = 0.6718 m).
//!
//! What it computes, all on fixed-size `nalgebra` types and without allocation:
//! - forward kinematics: every link frame and `base_from_tool` ([`SerialArm::link_frames`],
//!   [`SerialArm::base_from_tool`]);
//! - the geometric Jacobian in the base and tool frames, rows `[v; ω]`, and Yoshikawa's manipulability;
//! - the PUMA 560's closed-form inverse kinematics, all eight solutions ([`ik`]), and for any other
//!   geometry a numerical solution near a seed ([`reach`]);
//! - rigid-body dynamics: recursive Newton–Euler, mass matrix (composite rigid body algorithm), gravity
//!   torque, the Coriolis matrix, forward dynamics ([`dynamics`]);
//! - motor armature inertia and friction as a separate term ([`Drive`]), in the toolbox convention
//!   τ_full = τ_rigid + G²J_m q̈ + G²B q̇ + |G|·T_c;
//! - joint position, velocity and torque limits ([`JointLimits`]), and how far inside them a joint move's
//!   goal must be ([`GOAL_MARGIN_RAD`]).
//!
//! The arms it builds: [`SerialArm::dh`], six joints in standard DH with masses and drives (kinematics, the
//! closed-form IK where the geometry has one, dynamics); [`SerialArm::kinematic`], a DH table of the user's
//! with limits and no masses (kinematics, Jacobians and reach: what a velocity- or position-commanded arm
//! needs); and [`SerialArm::from_chain`], a URDF's chain of six or seven joints, kinematics only. [`urdf`]
//! reads the chain between two links with the `urdf-rs` parser, fixed joints folded in, and refuses what
//! cannot be driven, naming the joint; [`chain`] gives its forward kinematics and Jacobian (checked against
//! PyBullet, `tests/urdf_reference.rs`). The entries of a [`JointVector`] past the arm's
//! [`SerialArm::joint_count`] are zero.
//!
//! Units are SI throughout (m, rad, s, kg, N·m). Gravity points along the base's −z.
//!
//! ```
//! use vservo_arm::puma560;
//!
//! let arm = puma560::puma560();
//! let q = puma560::QN;
//! let base_from_tool = arm.base_from_tool(&q);
//! let torque = arm.gravity_torque(&q);
//! assert!((base_from_tool.translation.vector.z - 0.6718).abs() < 0.2);
//! assert!(torque[1] > 0.0); // the shoulder holds the arm up
//! ```

pub mod chain;
pub mod drive;
pub mod dynamics;
pub mod ik;
pub mod kinematics;
pub mod limits;
pub mod link;
pub mod puma560;
pub mod reach;
pub mod urdf;
pub mod urdf_bounds;

pub use chain::{Chain, ChainJoint};
pub use drive::Drive;
pub use dynamics::DynamicsError;
pub use ik::{ArmConfig, IkSolution, IkSolutions};
pub use kinematics::Placement;
pub use limits::{GOAL_MARGIN_RAD, JointLimits, LIMIT_MARGIN, LimitViolation, LimitedQuantity};
pub use link::{DhParameters, Link, LinkInertia};

use nalgebra::{IsometryMatrix3, Matrix6, SMatrix, SVector, Vector3};

/// The most joints an arm may have: six to move the camera in all six directions, a seventh to spare.
pub const MAX_JOINTS: usize = 7;
/// The joints of an arm written as a standard-DH table (the PUMA 560): its kinematics, closed-form inverse
/// kinematics and dynamics are over six joints.
pub const DH_JOINTS: usize = 6;
/// A value per joint: angles (rad), velocities (rad/s), accelerations (rad/s²) or torques (N·m). Room for
/// [`MAX_JOINTS`]; the entries past the arm's [`SerialArm::joint_count`] are zero.
pub type JointVector = SVector<f64, MAX_JOINTS>;
/// A 6×6 matrix over a DH arm's joints (mass matrix, Coriolis matrix).
pub type JointMatrix = Matrix6<f64>;
/// The geometric Jacobian, rows `[v; ω]`, a column per joint; the columns past the arm's joint count are
/// zero.
pub type Jacobian = SMatrix<f64, 6, MAX_JOINTS>;

/// The values of up to [`MAX_JOINTS`] joints as a [`JointVector`], the entries past them zero; `None` for
/// more.
pub fn joint_vector(values: &[f64]) -> Option<JointVector> {
    (values.len() <= MAX_JOINTS).then(|| JointVector::from_fn(|i, _| values.get(i).copied().unwrap_or(0.0)))
}

/// A six-joint arm's values as a [`JointVector`] (the seventh entry zero).
pub const fn six_joints(values: [f64; 6]) -> JointVector {
    let [a, b, c, d, e, f] = values;
    JointVector::from_array_storage(nalgebra::ArrayStorage([[a, b, c, d, e, f, 0.0]]))
}
/// A rigid transform held as a rotation matrix and a translation: `a_from_b` maps points in `b` to `a`.
pub type Transform = IsometryMatrix3<f64>;

/// A revolute serial arm of six or seven joints, in standard DH form (six) or as a URDF chain, with its
/// inertial, drive and limit data.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialArm {
    /// A name for messages ("PUMA 560").
    pub name: &'static str,
    /// The links from the base outwards; link `i` moves with joint `i`. The links past
    /// [`Self::joint_count`] are [`Link::UNUSED`].
    pub links: [Link; MAX_JOINTS],
    /// How many joints the arm has: six, or seven for a URDF chain.
    joint_count: usize,
    /// The acceleration of gravity in the base frame (m/s²), `[0, 0, −9.81]` for a floor-mounted arm.
    pub gravity_in_base: Vector3<f64>,
    /// How the joints are placed: by the links' DH parameters, or by a robot description's chain.
    pub geometry: Geometry,
}

/// Where the arm's joints are and what they turn about.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// The links' standard-DH parameters ([`Link::dh`]): kinematics, the closed-form IK where the geometry
    /// has one, and dynamics.
    Dh,
    /// A chain from a robot description (a URDF): kinematics only (the links' DH parameters are unused and
    /// zero; the arm is velocity- or position-commanded). Shared, so that copying the arm (the rmrc does, when
    /// it starts again at rest) does not allocate.
    Chain(std::sync::Arc<Chain>),
}

impl SerialArm {
    /// An arm known by its kinematics only: a standard-DH table and joint limits, no mass and no drive
    /// model (what a velocity- or position-commanded arm needs: forward kinematics, Jacobians, reach).
    pub fn kinematic(
        name: &'static str,
        dh: [DhParameters; DH_JOINTS],
        limits: [JointLimits; DH_JOINTS],
    ) -> Self {
        let links = std::array::from_fn(|j| Link { dh: dh[j], limits: limits[j], ..Link::UNUSED });
        Self::dh(name, links)
    }

    /// A six-joint arm in standard DH form from its links (mass, drive and limits).
    pub fn dh(name: &'static str, links: [Link; DH_JOINTS]) -> Self {
        Self {
            name,
            links: std::array::from_fn(|j| links.get(j).copied().unwrap_or(Link::UNUSED)),
            joint_count: DH_JOINTS,
            gravity_in_base: Vector3::new(0.0, 0.0, -9.81),
            geometry: Geometry::Dh,
        }
    }

    /// An arm of six or seven joints known by a URDF chain and joint limits, one per joint of the chain
    /// (kinematics only, like [`Self::kinematic`]). `None` when the chain has fewer than six or more than
    /// [`MAX_JOINTS`] joints, or the limits are not one per joint.
    pub fn from_chain(name: &'static str, chain: Chain, limits: &[JointLimits]) -> Option<Self> {
        let joint_count = chain.joint_count();
        if !(DH_JOINTS..=MAX_JOINTS).contains(&joint_count) || limits.len() != joint_count {
            return None;
        }
        Some(Self {
            name,
            links: std::array::from_fn(|j| {
                limits.get(j).map_or(Link::UNUSED, |&limits| Link { limits, ..Link::UNUSED })
            }),
            joint_count,
            gravity_in_base: Vector3::new(0.0, 0.0, -9.81),
            geometry: Geometry::Chain(std::sync::Arc::new(chain)),
        })
    }

    /// How many joints the arm has (six or seven).
    pub fn joint_count(&self) -> usize {
        self.joint_count
    }

    /// The arm's links, one per joint.
    pub fn joints(&self) -> &[Link] {
        &self.links[..self.joint_count]
    }

    /// A DH arm's six links (for a chain: unused placeholders).
    pub(crate) fn dh_links(&self) -> &[Link; DH_JOINTS] {
        self.links.first_chunk::<DH_JOINTS>().unwrap_or(&[Link::UNUSED; DH_JOINTS])
    }

    /// The joint limits, one per joint.
    pub fn limits(&self) -> impl ExactSizeIterator<Item = JointLimits> + '_ {
        self.joints().iter().map(|link| link.limits)
    }
}
