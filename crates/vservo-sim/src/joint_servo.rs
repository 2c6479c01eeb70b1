//! The joint servo: the torques that make the arm follow the interpolator's reference.

use vservo_arm::{JointVector, SerialArm};

use crate::interpolator::Reference;
pub use vservo_settings::simulation::JointServoLaw;

/// The joint servo and its gains.
#[derive(Debug, Clone)]
pub struct JointServo {
    arm: SerialArm,
    law: JointServoLaw,
    kp: JointVector,
    kv: JointVector,
}

impl JointServo {
    /// A servo on `arm`'s model.
    pub fn new(arm: SerialArm, law: JointServoLaw, kp: JointVector, kv: JointVector) -> Self {
        Self { arm, law, kp, kv }
    }

    /// The torque for the measured state (q, q̇) and the reference.
    pub fn torque(&self, q: &JointVector, qd: &JointVector, reference: &Reference) -> JointVector {
        let e = reference.q - q;
        let e_dot = reference.qd - qd;
        match self.law {
            JointServoLaw::ComputedTorque => {
                let accel = reference.qdd + self.kv.component_mul(&e_dot) + self.kp.component_mul(&e);
                // friction is compensated at the reference speed: at the measured one its Coulomb part
                // vanishes whenever the joint sticks, which leaves a static error that the visual loop then
                // winds up into a stick-slip cycle of a few pixels
                self.arm.inertia_torque(q, &accel)
                    + self.arm.rne_rigid(q, qd, &JointVector::zeros())
                    + self.arm.drive_torque(&reference.qd, &JointVector::zeros())
            }
            JointServoLaw::PdGravity => {
                self.kp.component_mul(&e) + self.kv.component_mul(&e_dot) + self.arm.gravity_torque(q)
            }
        }
    }
}
