//! The `uint8_t` enums inside a `RobotState` (`rbk_types.h`).
//!
//! These number differently from the `uint32_t` enums of a Move request ([`crate::wire::tcp`]): in the state
//! `kIdle` comes first, so joint velocity is 2 here and 1 in a Move.

wire_enum! {
    /// `RobotState::robot_mode`: what the robot as a whole is doing.
    pub enum RobotMode: u8 {
        /// `kOther`: none of the others (e.g. user stop pressed, brakes closed).
        Other = 0 => "kOther",
        /// `kIdle`: ready for a motion.
        Idle = 1 => "kIdle",
        /// `kMove`: a motion (Move) is running.
        Move = 2 => "kMove",
        /// `kGuiding`: hand guiding.
        Guiding = 3 => "kGuiding",
        /// `kReflex`: a reflex stopped the robot; automatic error recovery clears it.
        Reflex = 4 => "kReflex",
        /// `kUserStopped`: the user stop is pressed.
        UserStopped = 5 => "kUserStopped",
        /// `kAutomaticErrorRecovery`: a recovery is running.
        AutomaticErrorRecovery = 6 => "kAutomaticErrorRecovery",
    }
}

wire_enum! {
    /// `RobotState::motion_generator_mode`: which motion generator runs.
    pub enum MotionGeneratorMode: u8 {
        /// `kIdle`: none.
        Idle = 0 => "kIdle",
        /// `kJointPosition`.
        JointPosition = 1 => "kJointPosition",
        /// `kJointVelocity`.
        JointVelocity = 2 => "kJointVelocity",
        /// `kCartesianPosition`.
        CartesianPosition = 3 => "kCartesianPosition",
        /// `kCartesianVelocity`.
        CartesianVelocity = 4 => "kCartesianVelocity",
        /// `kNone`: a torque controller without a motion generator.
        None = 5 => "kNone",
    }
}

wire_enum! {
    /// `RobotState::controller_mode`: which controller runs.
    pub enum ControllerMode: u8 {
        /// `kJointImpedance`: the robot's internal joint impedance controller.
        JointImpedance = 0 => "kJointImpedance",
        /// `kCartesianImpedance`: the robot's internal Cartesian impedance controller.
        CartesianImpedance = 1 => "kCartesianImpedance",
        /// `kExternalController`: the client commands torques.
        ExternalController = 2 => "kExternalController",
        /// `kOther`: none of the above (idle).
        Other = 3 => "kOther",
    }
}
