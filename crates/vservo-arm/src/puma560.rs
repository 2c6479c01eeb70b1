//! The PUMA 560 as Corke's Robotics Toolbox defines it (`roboticstoolbox.models.DH.Puma560`, v1.5).
//!
//! - Standard DH kinematics with the pedestal in d₁ = 26.45 in = 0.6718 m (the toolbox's Python model;
//!   its MATLAB model leaves the pedestal out).
//! - Link masses, centres of mass and inertias of Armstrong, Khatib & Burdick (1986), "The explicit
//!   dynamic model and inertial parameters of the PUMA 560 arm", as collected by Corke &
//!   Armstrong-Hélouvry (1994). The mass of link 1 is 0 (only its inertia about the waist axis matters).
//! - Motor inertias, gear ratios, viscous and Coulomb friction (at the motor) and joint angle ranges of the
//!   toolbox model.
//! - Velocity and torque limits: the toolbox carries none. The values here are those widely used for the
//!   PUMA 560 in the trajectory-planning literature (for example Constantinescu & Croft, "Smooth and
//!   time-optimal trajectory planning for industrial manipulators along specified paths", J. Robotic
//!   Systems 17(5), 2000): torques 97.6, 186.4, 89.4, 24.2, 20.1, 21.3 N·m, speeds 8, 10, 10, 5, 5, 5 rad/s.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use crate::{DhParameters, Drive, JointLimits, JointVector, Link, LinkInertia, SerialArm, six_joints};

/// Pedestal height plus shoulder: d₁ = 26.45 in (m).
pub const D1_M: f64 = 26.45 * 0.0254;

/// Zero angles: the arm in an 'L' (wrist singular).
pub const QZ: JointVector = six_joints([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
/// Ready: the arm straight up (wrist singular).
pub const QR: JointVector = six_joints([0.0, FRAC_PI_2, -FRAC_PI_2, 0.0, 0.0, 0.0]);
/// Stretched out horizontally along base x (singular).
pub const QS: JointVector = six_joints([0.0, 0.0, -FRAC_PI_2, 0.0, 0.0, 0.0]);
/// Nominal table-top pose, well away from singularities; vservo's desired pose.
pub const QN: JointVector = six_joints([0.0, FRAC_PI_4, -PI, 0.0, FRAC_PI_4, 0.0]);

/// The PUMA 560's joint accelerations (rad/s²). None are published: about what its torque limits give over its
/// inertia at the nominal pose, with margin. No jerk limit is published either.
pub const ACCELERATION_LIMITS_RAD_S2: JointVector = six_joints([22.5, 22.5, 45.0, 90.0, 90.0, 90.0]);

/// The named poses, for the command line and messages.
pub const NAMED_POSES: [(&str, JointVector); 4] = [("qz", QZ), ("qr", QR), ("qs", QS), ("qn", QN)];

/// Looks up a named pose ("qz", "qr", "qs", "qn").
pub fn named_pose(name: &str) -> Option<JointVector> {
    NAMED_POSES.iter().find(|(n, _)| *n == name).map(|(_, q)| *q)
}

fn degrees(d: f64) -> f64 {
    d.to_radians()
}

#[allow(clippy::too_many_arguments)]
fn link(
    (a, alpha, d): (f64, f64, f64),
    mass_kg: f64,
    r: [f64; 3],
    i: [f64; 6],
    (jm, g, b, tc): (f64, f64, f64, [f64; 2]),
    (q_min_deg, q_max_deg): (f64, f64),
    velocity_max: f64,
    torque_max: f64,
) -> Link {
    Link {
        dh: DhParameters::new(a, alpha, d, 0.0),
        inertia: LinkInertia::from_toolbox(mass_kg, r, i),
        drive: Drive {
            motor_inertia: jm,
            gear_ratio: g,
            viscous_friction: b,
            coulomb_friction_positive: tc[0],
            coulomb_friction_negative: tc[1],
        },
        limits: JointLimits {
            position_min: degrees(q_min_deg),
            position_max: degrees(q_max_deg),
            velocity_max,
            torque_max,
        },
    }
}

/// The PUMA 560 with armature inertia and friction (the toolbox's full model).
pub fn puma560() -> SerialArm {
    SerialArm::dh(
        "PUMA 560",
        [
            link(
                (0.0, FRAC_PI_2, D1_M),
                0.0,
                [0.0, 0.0, 0.0],
                [0.0, 0.35, 0.0, 0.0, 0.0, 0.0],
                (200e-6, -62.6111, 1.48e-3, [0.395, -0.435]),
                (-160.0, 160.0),
                8.0,
                97.6,
            ),
            link(
                (0.4318, 0.0, 0.0),
                17.4,
                [-0.3638, 0.006, 0.2275],
                [0.13, 0.524, 0.539, 0.0, 0.0, 0.0],
                (200e-6, 107.815, 0.817e-3, [0.126, -0.071]),
                (-45.0, 225.0),
                10.0,
                186.4,
            ),
            link(
                (0.0203, -FRAC_PI_2, 0.15005),
                4.8,
                [-0.0203, -0.0141, 0.070],
                [0.066, 0.086, 0.0125, 0.0, 0.0, 0.0],
                (200e-6, -53.7063, 1.38e-3, [0.132, -0.105]),
                (-225.0, 45.0),
                10.0,
                89.4,
            ),
            link(
                (0.0, FRAC_PI_2, 0.4318),
                0.82,
                [0.0, 0.019, 0.0],
                [1.8e-3, 1.3e-3, 1.8e-3, 0.0, 0.0, 0.0],
                (33e-6, 76.0364, 71.2e-6, [11.2e-3, -16.9e-3]),
                (-110.0, 170.0),
                5.0,
                24.2,
            ),
            link(
                (0.0, -FRAC_PI_2, 0.0),
                0.34,
                [0.0, 0.0, 0.0],
                [0.3e-3, 0.4e-3, 0.3e-3, 0.0, 0.0, 0.0],
                (33e-6, 71.923, 82.6e-6, [9.26e-3, -14.5e-3]),
                (-100.0, 100.0),
                5.0,
                20.1,
            ),
            link(
                (0.0, 0.0, 0.0),
                0.09,
                [0.0, 0.0, 0.032],
                [0.15e-3, 0.15e-3, 0.04e-3, 0.0, 0.0, 0.0],
                (33e-6, 76.686, 36.7e-6, [3.96e-3, -10.5e-3]),
                (-266.0, 266.0),
                5.0,
                21.3,
            ),
        ],
    )
}

/// The same arm with the motors' armature inertia and friction removed: the rigid-body model alone.
pub fn puma560_rigid() -> SerialArm {
    let mut arm = puma560();
    for link in &mut arm.links {
        link.drive = Drive { gear_ratio: link.drive.gear_ratio, ..Drive::NONE };
    }
    arm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nominal_pose_is_inside_the_joint_limits_and_the_zero_pose_too() {
        let arm = puma560();
        assert!(arm.check_positions(&QN).is_ok());
        assert!(arm.check_positions(&QZ).is_ok());
        assert!(arm.check_positions(&QR).is_ok());
        assert!(named_pose("qn") == Some(QN));
        assert!(named_pose("nope").is_none());
    }

    #[test]
    fn pedestal_height_is_0_6718_m() {
        assert!((D1_M - 0.67183).abs() < 1e-5);
    }
}
