//! # vservo-arm — the serial-arm model
//!
//! This crate owns the model of the manipulator that carries vservo's camera: a six-joint, all-revolute
//! serial arm in standard Denavit–Hartenberg form or as the chain of a URDF ([`urdf`], [`chain`]), with the
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
//! - joint position, velocity and torque limits ([`JointLimits`]).
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

pub use chain::{Chain, ChainJoint};
pub use drive::Drive;
pub use dynamics::DynamicsError;
pub use ik::{ArmConfig, IkSolution, IkSolutions};
pub use limits::{JointLimits, LimitViolation, LimitedQuantity};
pub use link::{DhParameters, Link, LinkInertia};

use nalgebra::{IsometryMatrix3, Matrix6, Vector3, Vector6};

/// Number of joints of every arm this crate models.
pub const JOINTS: usize = 6;
/// A value per joint: angles (rad), velocities (rad/s), accelerations (rad/s²) or torques (N·m).
pub type JointVector = Vector6<f64>;
/// A 6×6 matrix over the joints (mass matrix, Coriolis matrix) or a Jacobian with rows `[v; ω]`.
pub type JointMatrix = Matrix6<f64>;
/// A rigid transform held as a rotation matrix and a translation: `a_from_b` maps points in `b` to `a`.
pub type Transform = IsometryMatrix3<f64>;

/// A six-joint revolute serial arm in standard DH form, with its inertial, drive and limit data.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialArm {
    /// A name for messages ("PUMA 560").
    pub name: &'static str,
    /// The links from the base outwards; link `i` moves with joint `i`.
    pub links: [Link; JOINTS],
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
    pub fn kinematic(name: &'static str, dh: [DhParameters; JOINTS], limits: [JointLimits; JOINTS]) -> Self {
        let massless = LinkInertia {
            mass_kg: 0.0,
            com_in_link: Vector3::zeros(),
            inertia_about_com: nalgebra::Matrix3::zeros(),
        };
        Self {
            name,
            links: std::array::from_fn(|j| Link {
                dh: dh[j],
                inertia: massless,
                drive: Drive::NONE,
                limits: limits[j],
            }),
            gravity_in_base: Vector3::new(0.0, 0.0, -9.81),
            geometry: Geometry::Dh,
        }
    }

    /// A six-joint arm known by a URDF chain and joint limits (kinematics only, like [`Self::kinematic`]).
    /// `None` when the chain does not have exactly [`JOINTS`] joints.
    pub fn from_chain(name: &'static str, chain: Chain, limits: [JointLimits; JOINTS]) -> Option<Self> {
        if chain.joint_count() != JOINTS {
            return None;
        }
        let unused = DhParameters::new(0.0, 0.0, 0.0, 0.0);
        let mut arm = Self::kinematic(name, [unused; JOINTS], limits);
        arm.geometry = Geometry::Chain(std::sync::Arc::new(chain));
        Some(arm)
    }

    /// The joint limits, one per joint.
    pub fn limits(&self) -> [JointLimits; JOINTS] {
        self.links.map(|link| link.limits)
    }
}
