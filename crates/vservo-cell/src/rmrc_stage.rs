//! The rmrc stage: the 1 ms interpolator and the joint servo behind it.

use vservo_arm::{JointVector, SerialArm};
use vservo_config::{CommandInterface, Config};
use vservo_control::Twist;
use vservo_sim::interpolator::{Interpolator, InterpolatorSettings, Reference};
use vservo_sim::joint_servo::JointServo;

/// What the rmrc sends the robot driver for one period, in the interface the driver takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ActuatorCommand {
    /// Joint torques (N·m), for the dynamic plant and a real arm's torque-controlled drives.
    Torque(JointVector),
    /// The joint reference itself: the velocity q̇_d over the next period and the position q_d at its end.
    /// A velocity-commanded driver applies `qd`, a position-commanded one `q` (the kinematic plant both).
    Reference {
        /// q_d (rad).
        q: JointVector,
        /// q̇_d (rad/s).
        qd: JointVector,
    },
}

/// The interpolator and the joint servo.
#[derive(Debug, Clone)]
pub struct RmrcStage {
    interpolator: Interpolator,
    joint_servo: JointServo,
    command: CommandInterface,
}

impl RmrcStage {
    pub(crate) fn new(
        config: &Config,
        settings: InterpolatorSettings,
        arm: SerialArm,
        q: JointVector,
    ) -> Self {
        Self {
            interpolator: Interpolator::new(settings, arm.clone(), config.tool_from_camera, q),
            joint_servo: JointServo::new(
                arm,
                config.joint_servo.law,
                config.joint_servo.kp,
                config.joint_servo.kv,
            ),
            command: config.command_interface(),
        }
    }

    /// A new twist from the servo, received at simulated time `now_s`.
    pub fn set_twist(&mut self, twist: Twist, now_s: f64) {
        self.interpolator.set_twist(twist, now_s);
    }

    /// The command interface of the driver.
    pub fn command_interface(&self) -> CommandInterface {
        self.command
    }

    /// The reference of the last tick.
    pub fn reference(&self) -> &Reference {
        self.interpolator.reference()
    }

    /// The command for the tick that ends at `next_s`, given the measured joints at its start.
    pub fn step(&mut self, next_s: f64, q: &JointVector, qd: &JointVector) -> ActuatorCommand {
        let reference = *self.interpolator.step(next_s);
        match self.command {
            CommandInterface::Velocity | CommandInterface::Position => {
                ActuatorCommand::Reference { q: reference.q, qd: reference.qd }
            }
            CommandInterface::Torque => ActuatorCommand::Torque(self.joint_servo.torque(q, qd, &reference)),
        }
    }
}
