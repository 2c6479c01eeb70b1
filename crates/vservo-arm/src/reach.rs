//! Reaching a tool pose: the closed-form solution where the arm has one (the PUMA 560 and arms of its
//! geometry, [`crate::ik`]), a numerical one otherwise — damped least squares on the pose error from a seed
//! (the joints now), so that a velocity- or position-commanded arm of any standard-DH geometry can be
//! checked for reachability.

use crate::ik::{IkError, shift_into_limits};
use crate::{JointMatrix, JointVector, SerialArm, Transform};

/// The largest pose error the numerical solution accepts: translation (m) and rotation (rad) together.
pub const NUMERICAL_TOLERANCE: f64 = 1e-10;
/// Damped least-squares iterations before the numerical solution gives up.
const MAX_ITERATIONS: usize = 200;
/// The damping λ of (J Jᵀ + λ² I)⁻¹: small, so that the iteration is Newton's away from singularities.
const DAMPING: f64 = 1e-3;
/// The largest joint step per iteration (rad): keeps the linearisation honest far from the solution.
const MAX_STEP_RAD: f64 = 0.3;

/// Joints that put the tool at `base_from_tool`, found by damped least squares from `seed`; `None` when
/// the iteration does not get within [`NUMERICAL_TOLERANCE`] (out of reach, or a seed too far away). The
/// result is not checked against the joint limits.
pub fn numerical_ik(arm: &SerialArm, base_from_tool: &Transform, seed: &JointVector) -> Option<JointVector> {
    let mut q = *seed;
    for _ in 0..MAX_ITERATIONS {
        let (pose, jacobian) = arm.base_from_tool_and_jacobian(&q);
        let position_error = base_from_tool.translation.vector - pose.translation.vector;
        // the rotation still to go, from the skew part of R_target·Rᵀ: exact to first order and resolving
        // small angles that an acos-based axis-angle rounds to zero below ~1e-8 rad
        let r = (base_from_tool.rotation * pose.rotation.inverse()).into_inner();
        let rotation_error =
            nalgebra::Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]) * 0.5;
        let error = nalgebra::Vector6::new(
            position_error.x,
            position_error.y,
            position_error.z,
            rotation_error.x,
            rotation_error.y,
            rotation_error.z,
        );
        if error.norm() < NUMERICAL_TOLERANCE {
            return Some(q);
        }
        let damped = jacobian * jacobian.transpose() + JointMatrix::identity() * (DAMPING * DAMPING);
        let mut step = jacobian.transpose() * damped.lu().solve(&error)?;
        let largest = step.amax();
        if largest > MAX_STEP_RAD {
            step *= MAX_STEP_RAD / largest;
        }
        q += step;
    }
    None
}

impl SerialArm {
    /// Joints inside the limits that put the tool at `base_from_tool`, nearest `near`: of the closed-form
    /// solutions where the arm's geometry has them, else the numerical solution seeded at `near`; `None`
    /// when the pose is out of reach or every solution is outside the joint limits.
    pub fn reach(&self, base_from_tool: &Transform, near: &JointVector) -> Option<JointVector> {
        match self.inverse_kinematics(base_from_tool) {
            Ok(solutions) => solutions.nearest(self, near).map(|s| s.q),
            Err(IkError::UnsupportedGeometry(_)) => {
                let q = numerical_ik(self, base_from_tool, near)?;
                shift_into_limits(self, &q, near)
            }
            Err(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{puma560, six_joints};

    #[test]
    fn the_numerical_solution_agrees_with_the_closed_form_near_the_seed() {
        let arm = puma560::puma560();
        let q = puma560::QN + six_joints([0.2, -0.1, 0.15, 0.3, -0.2, 0.4]);
        let target = arm.base_from_tool(&q);
        let closed = arm.reach(&target, &puma560::QN).expect("reachable");
        let numerical = numerical_ik(&arm, &target, &puma560::QN).expect("converges");
        assert!((closed - q).amax() < 1e-9, "{closed} vs {q}");
        assert!((numerical - q).amax() < 1e-8, "{numerical} vs {q}");
    }

    #[test]
    fn an_arm_without_a_closed_form_is_reached_numerically_inside_its_limits() {
        // a UR5-like geometry (no PUMA wrist): the closed form refuses it, the numerical solution does not
        let dh = [
            crate::DhParameters::new(0.0, std::f64::consts::FRAC_PI_2, 0.089159, 0.0),
            crate::DhParameters::new(-0.425, 0.0, 0.0, 0.0),
            crate::DhParameters::new(-0.39225, 0.0, 0.0, 0.0),
            crate::DhParameters::new(0.0, std::f64::consts::FRAC_PI_2, 0.10915, 0.0),
            crate::DhParameters::new(0.0, -std::f64::consts::FRAC_PI_2, 0.09465, 0.0),
            crate::DhParameters::new(0.0, 0.0, 0.0823, 0.0),
        ];
        let limits = crate::JointLimits {
            position_min: -std::f64::consts::TAU,
            position_max: std::f64::consts::TAU,
            velocity_max: std::f64::consts::PI,
            torque_max: f64::INFINITY,
        };
        let arm = SerialArm::kinematic("UR5-like", dh, [limits; 6]);
        let seed = six_joints([0.1, -1.2, 1.5, -0.4, 1.4, 0.2]);
        let q = seed + six_joints([0.1, 0.05, -0.1, 0.2, -0.1, 0.3]);
        let target = arm.base_from_tool(&q);
        assert!(matches!(arm.inverse_kinematics(&target), Err(IkError::UnsupportedGeometry(_))));
        let reached = arm.reach(&target, &seed).expect("reachable");
        let pose = arm.base_from_tool(&reached);
        assert!((pose.translation.vector - target.translation.vector).norm() < 1e-9);
        assert!((pose.rotation.matrix() - target.rotation.matrix()).amax() < 1e-9);
    }

    #[test]
    fn a_pose_out_of_reach_has_no_numerical_solution() {
        let arm = puma560::puma560();
        let mut target = arm.base_from_tool(&puma560::QN);
        target.translation.vector.x += 5.0;
        assert_eq!(numerical_ik(&arm, &target, &puma560::QN), None);
    }
}
