//! The joint drive: motor armature inertia, gear ratio and friction, kept apart from the rigid-body model.
//!
//! Convention of Corke's Robotics Toolbox: motor-side quantities reflected to the link side through the
//! gear ratio G, so a joint needs, on top of the rigid-body torque,
//!
//! τ_drive = G²·J_m·q̈ + G²·B·q̇ + |G|·T_c(q̇)
//!
//! where T_c(q̇) is the Coulomb friction for positive velocity when q̇ > 0, the one for negative velocity
//! (a negative number) when q̇ < 0, and 0 at rest.

/// Motor, gearbox and friction of one joint, all measured at the motor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Motor armature inertia J_m (kg·m², at the motor).
    pub motor_inertia: f64,
    /// Gear ratio G (motor angle per joint angle; the sign gives the direction).
    pub gear_ratio: f64,
    /// Viscous friction B (N·m·s/rad, at the motor).
    pub viscous_friction: f64,
    /// Coulomb friction for positive velocity T_c⁺ (N·m, at the motor, ≥ 0).
    pub coulomb_friction_positive: f64,
    /// Coulomb friction for negative velocity T_c⁻ (N·m, at the motor, ≤ 0).
    pub coulomb_friction_negative: f64,
}

impl Drive {
    /// A drive that adds nothing: no armature, no friction.
    pub const NONE: Drive = Drive {
        motor_inertia: 0.0,
        gear_ratio: 1.0,
        viscous_friction: 0.0,
        coulomb_friction_positive: 0.0,
        coulomb_friction_negative: 0.0,
    };

    /// The armature inertia seen at the joint, G²·J_m (kg·m²).
    #[inline]
    pub fn reflected_inertia(&self) -> f64 {
        self.gear_ratio * self.gear_ratio * self.motor_inertia
    }

    /// The friction torque at the joint, G²·B·q̇ + |G|·T_c(q̇) (N·m); it opposes the motion, so a motor
    /// must supply it.
    #[inline]
    pub fn friction_torque(&self, joint_velocity: f64) -> f64 {
        let g = self.gear_ratio;
        let coulomb = if joint_velocity > 0.0 {
            self.coulomb_friction_positive
        } else if joint_velocity < 0.0 {
            self.coulomb_friction_negative
        } else {
            0.0
        };
        g * g * self.viscous_friction * joint_velocity + g.abs() * coulomb
    }

    /// The torque the drive itself needs at the joint: G²·J_m·q̈ + friction (N·m).
    #[inline]
    pub fn torque(&self, joint_velocity: f64, joint_acceleration: f64) -> f64 {
        self.reflected_inertia() * joint_acceleration + self.friction_torque(joint_velocity)
    }

    /// The same drive without any friction (armature kept).
    pub fn without_friction(&self) -> Drive {
        Drive {
            viscous_friction: 0.0,
            coulomb_friction_positive: 0.0,
            coulomb_friction_negative: 0.0,
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DRIVE: Drive = Drive {
        motor_inertia: 200e-6,
        gear_ratio: -62.6111,
        viscous_friction: 1.48e-3,
        coulomb_friction_positive: 0.395,
        coulomb_friction_negative: -0.435,
    };

    #[test]
    fn coulomb_friction_takes_the_side_of_the_velocity_and_vanishes_at_rest() {
        let g = 62.6111;
        assert_eq!(DRIVE.friction_torque(0.0), 0.0);
        let up = DRIVE.friction_torque(1e-12);
        let down = DRIVE.friction_torque(-1e-12);
        assert!((up - g * 0.395).abs() < 1e-6, "{up}");
        assert!((down + g * 0.435).abs() < 1e-6, "{down}");
    }

    #[test]
    fn viscous_friction_and_armature_scale_with_the_square_of_the_gear_ratio() {
        let g2 = 62.6111_f64 * 62.6111;
        let viscous = DRIVE.friction_torque(2.0) - DRIVE.friction_torque(1.0);
        assert!((viscous - g2 * 1.48e-3).abs() < 1e-9);
        assert!((DRIVE.reflected_inertia() - g2 * 200e-6).abs() < 1e-12);
        assert_eq!(DRIVE.without_friction().torque(5.0, 0.0), 0.0);
    }
}
