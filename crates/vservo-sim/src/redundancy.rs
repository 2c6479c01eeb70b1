//! Resolving a tool twist into joint rates for an arm of six or seven joints (a URDF chain): the twist met
//! by damped least squares, and the joints a seven-joint arm has to spare moved in the Jacobian's null space,
//! away from their limits and, if configured, towards a preferred posture.
//!
//! q̇ = J⁺v + (I − J⁺J) z, with J⁺ = Jᵀ(JJᵀ + λ²I)⁻¹ (λ = 0 away from singularities: then J q̇ = v exactly and
//! the null-space motion moves no part of the tool), and z the secondary task:
//! - each joint closer to a limit than `limit_zone_rad` is pushed away from it at `limit_gain` × the depth
//!   (rad/s per rad);
//! - with a preferred posture, every joint is pulled towards it at `posture_gain` (1/s).
//!
//! The speed and acceleration limits are the interpolator's, applied after this to the whole vector. Fixed-size
//! arrays throughout: no allocation (the 1 ms path calls it every tick).

use nalgebra::{SMatrix, Vector6};
use vservo_arm::{Jacobian, JointLimits, JointVector, MAX_JOINTS};
pub use vservo_settings::simulation::NullSpaceTask;

/// How the Jacobian is inverted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damping {
    /// Below this manipulability √det(JJᵀ) the inverse is damped (Nakamura's damped least squares).
    pub manipulability_threshold: f64,
    /// The damping λ at zero manipulability; it falls to 0 at the threshold.
    pub max_damping: f64,
}

/// The joint rates for one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointRates {
    /// q̇ (rad/s); zero past the arm's joints, and zero when the twist could not be resolved.
    pub qd: JointVector,
    /// The part of `qd` in the null space (rad/s).
    pub null_space: JointVector,
    /// Whether damping was used (near a singularity).
    pub damped: bool,
    /// √det(JJᵀ).
    pub manipulability: f64,
}

/// The joint rates that give the tool the twist `tool_twist` (`[v; ω]` in the base frame, at the tool origin)
/// for the base-frame `jacobian` at `q`, with `task` in the null space. `limits` has one entry per joint of
/// the arm (six or seven); the Jacobian's columns past them are zero.
pub fn resolve(
    jacobian: &Jacobian,
    q: &JointVector,
    limits: &[JointLimits],
    tool_twist: &Vector6<f64>,
    damping: &Damping,
    task: &NullSpaceTask,
) -> JointRates {
    let product = jacobian * jacobian.transpose();
    let manipulability = product.cholesky().map_or(0.0, |c| c.l().diagonal().product().abs());
    let lambda = if manipulability >= damping.manipulability_threshold {
        0.0
    } else {
        damping.max_damping * (1.0 - manipulability / damping.manipulability_threshold)
    };
    let Some(inverse) =
        (product + SMatrix::<f64, 6, 6>::identity() * (lambda * lambda).max(1e-12)).cholesky()
    else {
        return JointRates {
            qd: JointVector::zeros(),
            null_space: JointVector::zeros(),
            damped: true,
            manipulability,
        };
    };
    let pseudo_inverse = |v: &Vector6<f64>| -> JointVector { jacobian.transpose() * inverse.solve(v) };
    let task_rates = pseudo_inverse(tool_twist);
    let z = secondary_task(q, limits, task);
    let null_space = z - pseudo_inverse(&(jacobian * z));
    let qd = task_rates + null_space;
    if !qd.iter().all(|v| v.is_finite()) {
        return JointRates {
            qd: JointVector::zeros(),
            null_space: JointVector::zeros(),
            damped: true,
            manipulability,
        };
    }
    JointRates { qd, null_space, damped: lambda > 0.0, manipulability }
}

/// z: away from the limits near them, towards the posture if any; zero past the arm's joints, and zero for
/// an arm of six joints (it has none to spare).
fn secondary_task(q: &JointVector, limits: &[JointLimits], task: &NullSpaceTask) -> JointVector {
    let mut z = JointVector::zeros();
    if limits.len() <= 6 {
        return z;
    }
    for (j, limit) in limits.iter().enumerate().take(MAX_JOINTS) {
        let above_lower = q[j] - limit.position_min;
        let below_upper = limit.position_max - q[j];
        if above_lower < task.limit_zone_rad {
            z[j] += task.limit_gain * (task.limit_zone_rad - above_lower);
        }
        if below_upper < task.limit_zone_rad {
            z[j] -= task.limit_gain * (task.limit_zone_rad - below_upper);
        }
        if let Some(posture) = &task.posture {
            z[j] += task.posture_gain * (posture[j] - q[j]);
        }
    }
    z
}
