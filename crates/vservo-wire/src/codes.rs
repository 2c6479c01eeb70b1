//! The wire codes as enums. A message carries a code as a plain integer (another process may write any
//! number there); a program turns it into its enum once, where it takes the message in
//! (`Verdict::try_from(msg.verdict)`), and back into a number only where it writes one
//! (`u32::from(Verdict::Servoing)`). Inside the program only the enums exist.
//!
//! Each enum is declared once with [`wire_code!`]: its numbers, the names the status, logs and JSON use, and
//! the legend docs/PROTOCOL.md prints all come from that one declaration.

/// A code that is none of its enum's values: the message it came in is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{what} {code} is not a known code")]
pub struct UnknownCode {
    /// What the code is (`verdict`, `fault`, …).
    pub what: &'static str,
    /// The number that came.
    pub code: u32,
}

/// Declares a wire-code enum: `#[repr]`, its numbers and names, `TryFrom` the number, `From` into it, the
/// legend for docs/PROTOCOL.md.
macro_rules! wire_code {
    (
        $(#[$meta:meta])*
        pub enum $name:ident: $repr:ty, $what:literal {
            $( $(#[$vmeta:meta])* $variant:ident = $value:literal, $text:literal; )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr($repr)]
        pub enum $name {
            $( $(#[$vmeta])* $variant = $value, )*
        }

        impl $name {
            /// Every value, in the order of their numbers.
            pub const ALL: &'static [$name] = &[$($name::$variant),*];

            /// The name the status, the logs and the JSON views write.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text,)*
                }
            }

            /// The value of this name.
            pub fn from_name(name: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|value| value.name() == name)
            }

            /// The number on the wire.
            pub const fn code(self) -> $repr {
                self as $repr
            }

            /// The legend docs/PROTOCOL.md prints: "0 name, 1 name, …".
            pub fn legend() -> String {
                let items: Vec<String> =
                    Self::ALL.iter().map(|value| format!("{} {}", value.code(), value.name())).collect();
                items.join(", ")
            }
        }

        impl TryFrom<$repr> for $name {
            type Error = UnknownCode;

            fn try_from(code: $repr) -> Result<Self, UnknownCode> {
                match code {
                    $($value => Ok($name::$variant),)*
                    _ => Err(UnknownCode { what: $what, code: u32::from(code) }),
                }
            }
        }

        impl From<$name> for $repr {
            fn from(value: $name) -> $repr {
                value as $repr
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

wire_code! {
    /// The command interfaces a robot driver may take (`joint_state.command_mode`, `joint_command.mode`).
    pub enum CommandMode: u32, "command mode" {
        /// Joint torques (`torque_nm`): the rmrc runs the joint servo (the simulated dynamic PUMA 560).
        Torque = 0, "torque";
        /// Joint velocities (`qd_ref_rad_s`, with `q_ref_rad` for drivers that correct drift): the
        /// interpolator's q̇ reference, velocity- and acceleration-limited.
        Velocity = 1, "velocity";
        /// Joint positions (`q_ref_rad`, with `qd_ref_rad_s` as feed-forward): the interpolator's q reference.
        Position = 2, "position";
    }
}

wire_code! {
    /// A robot driver's state (`joint_state.driver_status`).
    pub enum DriverStatus: u32, "driver status" {
        /// Following the commands it receives.
        Following = 0, "following";
        /// Holding the arm at rest: no valid command came in time (or none yet).
        Holding = 1, "holding";
        /// The driver or the arm is in fault (protective stop, drive error): it does not move.
        Fault = 2, "fault";
    }
}

wire_code! {
    /// Pixel formats (`camera_image.format`).
    pub enum PixelFormat: u32, "pixel format" {
        /// 8 bits per pixel, grey.
        Mono8 = 0, "mono8";
    }
}

wire_code! {
    /// Per-mark status (`features.mark_status`).
    pub enum MarkStatus: u8, "mark status" {
        /// Found; its feature is valid.
        Valid = 0, "valid";
        /// Its expected position is outside the image.
        OutsideImage = 1, "outside the image";
        /// Its blob touches the image border.
        CutByBorder = 2, "cut by the border";
        /// Run together with another mark into one blob.
        Merged = 3, "merged";
        /// Its blob has the wrong shape.
        Irregular = 4, "irregular";
        /// No blob where it should be.
        NotFound = 5, "not found";
        /// The image itself is unusable.
        BadImage = 6, "bad image";
        /// A blob was found for it, but with marks missing the blobs seen could be other marks.
        Ambiguous = 7, "ambiguous";
    }
}

wire_code! {
    /// What the servo did on a frame (`camera_twist.verdict`).
    pub enum Verdict: u32, "verdict" {
        /// No frame yet: zero twist.
        Waiting = 0, "waiting";
        /// The law's twist.
        Servoing = 1, "servoing";
        /// Marks missing and no camera pose known where all four were seen: zero twist (`missing_mask` says
        /// which).
        MarksMissing = 2, "marks missing";
        /// The servo is stopping (shutdown): zero twist.
        Stopping = 3, "stopping";
        /// The cell is in a safe stop (`cell_mode`): zero twist until the daemon resumes it.
        SafeStop = 4, "safe stop";
        /// One mark missing (`missing_mask`): the law's twist on the other three.
        ServoingOnThree = 5, "servoing on three marks";
        /// Two or more marks missing (`missing_mask`), or one and no design for the three seen (their desired
        /// images in a line): steering the camera back to where all were last seen.
        Reacquiring = 6, "reacquiring";
        /// The cell moves the arm's joints to a goal a client set (`cell_mode` moving, `vservoctl calibrate`):
        /// zero twist, the marks not looked at.
        Moving = 7, "moving";
    }
}

impl Verdict {
    /// Whether a twist of this verdict is to be followed (the others mean: bring the arm to rest).
    pub fn moves(self) -> bool {
        matches!(self, Verdict::Servoing | Verdict::ServoingOnThree | Verdict::Reacquiring)
    }
}

wire_code! {
    /// A node as the daemon sees it (`status.nodes[].state`).
    pub enum NodeState: u32, "node state" {
        /// Not started yet.
        NotStarted = 0, "not started";
        /// Running.
        Running = 1, "running";
        /// Exited; waiting to be restarted.
        BackingOff = 2, "backing off";
        /// Stopped on purpose.
        Stopped = 3, "stopped";
        /// Hung (its loop made no progress for `runtime.hang_timeout_s`): being killed, then restarted.
        Hung = 4, "hung";
    }
}

wire_code! {
    /// The daemon's state (`status.state`).
    pub enum DaemonState: u32, "daemon state" {
        /// Starting the nodes.
        Starting = 0, "starting";
        /// Every node running and healthy.
        Running = 1, "running";
        /// A node is down or not healthy.
        Degraded = 2, "degraded";
        /// Stopping.
        Stopping = 3, "stopping";
        /// A fault stopped the cell (`status.fault` says which, `fault_since_ns` since when): the arm is
        /// brought to rest and held until the cell is resumed.
        SafeStop = 4, "safe-stop";
        /// The arm moves its joints to a goal a client set (`vservoctl calibrate`), or holds there, instead of
        /// servoing; `servo` (or a safe stop) ends it.
        Moving = 5, "moving";
    }
}

wire_code! {
    /// The faults that end in a safe stop (`status.fault`, `cell_mode.fault`).
    pub enum Fault: u32, "fault" {
        /// None.
        None = 0, "none";
        /// A joint beyond its position range (`fault_joints` says which).
        PositionLimit = 1, "position_limit";
        /// A joint faster than its velocity limit.
        VelocityLimit = 2, "velocity_limit";
        /// A joint's torque cut to its limit for longer than `faults.saturation_s`.
        TorqueSaturated = 3, "torque_saturated";
        /// The robot driver reports a fault (`driver_status` fault, or the driver-failed bit).
        DriverFault = 4, "driver_fault";
        /// Marks missing (the servo could not servo) for longer than `faults.target_lost_s`.
        TargetLost = 5, "target_lost";
        /// An external robot driver's joint states stopped for longer than its deadline.
        RobotStalled = 6, "robot_stalled";
        /// A safe stop asked for by a client (`vservoctl safe-stop`).
        Requested = 7, "requested";
        /// A stream's one publisher slot is held by a process that is not the stream's designed writer (a node
        /// could not publish because its slot was taken, or another process publishes in its place).
        StreamTaken = 8, "stream_taken";
        /// The camera sent no frame for longer than `faults.camera_timeout_periods` vision periods.
        CameraStalled = 9, "camera_stalled";
        /// The cell came up held (`robot.start = "held"`, the default for an external driver): nothing moves
        /// until `vservoctl resume`; never resumed automatically.
        StartHeld = 10, "start_held";
        /// vservod itself stopped supervising (SIGSTOP, a debugger, a frozen machine) for longer than the nodes
        /// wait for its word (`vservo_protocol::supervision`): they held the arm on their own; never resumed
        /// automatically.
        SupervisionStalled = 11, "supervision_stalled";
        /// The collision guard stopped the arm (`[collision]`): a motion kept closing a distance at the stop
        /// distance, or the reference could not brake before it. A resume is taken at once; the guard then takes
        /// only motions that do not close a distance within the slowdown distance.
        Collision = 12, "collision";
    }
}

wire_code! {
    /// Why a robot driver reports a fault (`joint_state.driver_error`, with `driver_status` fault;
    /// `status.driver_error` for the fault that stopped the cell): the robot's own reason where the driver knows
    /// it. 1000 + i: the Franka's error flag i (`research_interface::robot::Error`, libfranka's names), the
    /// first of those that stopped its motion.
    pub enum DriverError: u32, "driver error" {
        /// None given (no fault, or a driver that names none).
        None = 0, "none";
        /// The contract's period check: the joint states come at another period than `[robot] period_s`
        /// (`vservo_driver::PeriodCheck`; the driver's log names both periods).
        PeriodMismatch = 1, "period_mismatch";
        /// The driver lost its connection to the robot (the robot or its server went away, or the network): it
        /// reports this while it reconnects, so that a resume is refused with it; once connected again the fault
        /// is gone and a resume starts a new motion.
        RobotConnectionLost = 2, "robot_connection_lost";
        /// The Franka's `joint_position_limits_violation`.
        FrankaJointPositionLimitsViolation = 1000, "joint_position_limits_violation";
        /// The Franka's `cartesian_position_limits_violation`.
        FrankaCartesianPositionLimitsViolation = 1001, "cartesian_position_limits_violation";
        /// The Franka's `self_collision_avoidance_violation`.
        FrankaSelfCollisionAvoidanceViolation = 1002, "self_collision_avoidance_violation";
        /// The Franka's `joint_velocity_violation`.
        FrankaJointVelocityViolation = 1003, "joint_velocity_violation";
        /// The Franka's `cartesian_velocity_violation`.
        FrankaCartesianVelocityViolation = 1004, "cartesian_velocity_violation";
        /// The Franka's `force_control_safety_violation`.
        FrankaForceControlSafetyViolation = 1005, "force_control_safety_violation";
        /// The Franka's `joint_reflex`.
        FrankaJointReflex = 1006, "joint_reflex";
        /// The Franka's `cartesian_reflex`.
        FrankaCartesianReflex = 1007, "cartesian_reflex";
        /// The Franka's `max_goal_pose_deviation_violation`.
        FrankaMaxGoalPoseDeviationViolation = 1008, "max_goal_pose_deviation_violation";
        /// The Franka's `max_path_pose_deviation_violation`.
        FrankaMaxPathPoseDeviationViolation = 1009, "max_path_pose_deviation_violation";
        /// The Franka's `cartesian_velocity_profile_safety_violation`.
        FrankaCartesianVelocityProfileSafetyViolation = 1010, "cartesian_velocity_profile_safety_violation";
        /// The Franka's `joint_position_motion_generator_start_pose_invalid`.
        FrankaJointPositionMotionGeneratorStartPoseInvalid = 1011, "joint_position_motion_generator_start_pose_invalid";
        /// The Franka's `joint_motion_generator_position_limits_violation`.
        FrankaJointMotionGeneratorPositionLimitsViolation = 1012, "joint_motion_generator_position_limits_violation";
        /// The Franka's `joint_motion_generator_velocity_limits_violation`.
        FrankaJointMotionGeneratorVelocityLimitsViolation = 1013, "joint_motion_generator_velocity_limits_violation";
        /// The Franka's `joint_motion_generator_velocity_discontinuity`.
        FrankaJointMotionGeneratorVelocityDiscontinuity = 1014, "joint_motion_generator_velocity_discontinuity";
        /// The Franka's `joint_motion_generator_acceleration_discontinuity`.
        FrankaJointMotionGeneratorAccelerationDiscontinuity = 1015, "joint_motion_generator_acceleration_discontinuity";
        /// The Franka's `cartesian_position_motion_generator_start_pose_invalid`.
        FrankaCartesianPositionMotionGeneratorStartPoseInvalid = 1016, "cartesian_position_motion_generator_start_pose_invalid";
        /// The Franka's `cartesian_motion_generator_elbow_limit_violation`.
        FrankaCartesianMotionGeneratorElbowLimitViolation = 1017, "cartesian_motion_generator_elbow_limit_violation";
        /// The Franka's `cartesian_motion_generator_velocity_limits_violation`.
        FrankaCartesianMotionGeneratorVelocityLimitsViolation = 1018, "cartesian_motion_generator_velocity_limits_violation";
        /// The Franka's `cartesian_motion_generator_velocity_discontinuity`.
        FrankaCartesianMotionGeneratorVelocityDiscontinuity = 1019, "cartesian_motion_generator_velocity_discontinuity";
        /// The Franka's `cartesian_motion_generator_acceleration_discontinuity`.
        FrankaCartesianMotionGeneratorAccelerationDiscontinuity = 1020, "cartesian_motion_generator_acceleration_discontinuity";
        /// The Franka's `cartesian_motion_generator_elbow_sign_inconsistent`.
        FrankaCartesianMotionGeneratorElbowSignInconsistent = 1021, "cartesian_motion_generator_elbow_sign_inconsistent";
        /// The Franka's `cartesian_motion_generator_start_elbow_invalid`.
        FrankaCartesianMotionGeneratorStartElbowInvalid = 1022, "cartesian_motion_generator_start_elbow_invalid";
        /// The Franka's `force_controller_desired_force_tolerance_violation`.
        FrankaForceControllerDesiredForceToleranceViolation = 1023, "force_controller_desired_force_tolerance_violation";
        /// The Franka's `start_elbow_sign_inconsistent`.
        FrankaStartElbowSignInconsistent = 1024, "start_elbow_sign_inconsistent";
        /// The Franka's `communication_constraints_violation`.
        FrankaCommunicationConstraintsViolation = 1025, "communication_constraints_violation";
        /// The Franka's `power_limit_violation`.
        FrankaPowerLimitViolation = 1026, "power_limit_violation";
        /// The Franka's `cartesian_motion_generator_joint_position_limits_violation`.
        FrankaCartesianMotionGeneratorJointPositionLimitsViolation = 1027, "cartesian_motion_generator_joint_position_limits_violation";
        /// The Franka's `cartesian_motion_generator_joint_velocity_limits_violation`.
        FrankaCartesianMotionGeneratorJointVelocityLimitsViolation = 1028, "cartesian_motion_generator_joint_velocity_limits_violation";
        /// The Franka's `cartesian_motion_generator_joint_velocity_discontinuity`.
        FrankaCartesianMotionGeneratorJointVelocityDiscontinuity = 1029, "cartesian_motion_generator_joint_velocity_discontinuity";
        /// The Franka's `cartesian_motion_generator_joint_acceleration_discontinuity`.
        FrankaCartesianMotionGeneratorJointAccelerationDiscontinuity = 1030, "cartesian_motion_generator_joint_acceleration_discontinuity";
        /// The Franka's `cartesian_position_motion_generator_invalid_frame_flag`.
        FrankaCartesianPositionMotionGeneratorInvalidFrameFlag = 1031, "cartesian_position_motion_generator_invalid_frame_flag";
        /// The Franka's `controller_torque_discontinuity`.
        FrankaControllerTorqueDiscontinuity = 1032, "controller_torque_discontinuity";
        /// The Franka's `joint_p2p_insufficient_torque_for_planning`.
        FrankaJointP2pInsufficientTorqueForPlanning = 1033, "joint_p2p_insufficient_torque_for_planning";
        /// The Franka's `tau_J_range_violation`.
        FrankaTauJRangeViolation = 1034, "tau_J_range_violation";
        /// The Franka's `instability_detected`.
        FrankaInstabilityDetected = 1035, "instability_detected";
        /// The Franka's `joint_move_in_wrong_direction`.
        FrankaJointMoveInWrongDirection = 1036, "joint_move_in_wrong_direction";
        /// The Franka's `cartesian_spline_motion_generator_violation`.
        FrankaCartesianSplineMotionGeneratorViolation = 1037, "cartesian_spline_motion_generator_violation";
        /// The Franka's `joint_via_motion_generator_planning_joint_limit_violation`.
        FrankaJointViaMotionGeneratorPlanningJointLimitViolation = 1038, "joint_via_motion_generator_planning_joint_limit_violation";
        /// The Franka's `base_acceleration_initialization_timeout`.
        FrankaBaseAccelerationInitializationTimeout = 1039, "base_acceleration_initialization_timeout";
        /// The Franka's `base_acceleration_invalid_reading`.
        FrankaBaseAccelerationInvalidReading = 1040, "base_acceleration_invalid_reading";
    }
}

wire_code! {
    /// Whether the cell servos (`cell_mode.mode`).
    pub enum CellMode: u32, "cell mode" {
        /// The servo's twists move the arm.
        Servoing = 0, "servoing";
        /// Safe stop: the servo sends zero twists, the rmrc ramps the reference to rest at its acceleration
        /// limits and holds it there, whatever twist arrives.
        SafeStop = 1, "safe_stop";
        /// A joint move: the rmrc takes each joint to `goal_rad` at up to `speed_fraction` of its speed limit
        /// (speeding up at `speed_fraction`² of its acceleration limit, stopping on the goal), and holds it there;
        /// the servo sends zero twists.
        Moving = 2, "moving";
    }
}

wire_code! {
    /// The robot driver as the daemon sees it (`status.robot`).
    pub enum RobotState: u32, "robot state" {
        /// No joint state yet.
        Waiting = 0, "waiting";
        /// Joint states arrive within their deadline.
        Running = 1, "running";
        /// No joint state for longer than the deadline: the driver stalled or is gone; no motion is commanded.
        Stalled = 2, "stalled";
    }
}

wire_code! {
    /// What a client asks of the daemon (`command.kind`); the object kinds also travel in `object.kind`.
    pub enum CommandKind: u32, "command kind" {
        /// A new target: `features_px` becomes ξ_d.
        TargetFeatures = 1, "target_features";
        /// A new target: the camera's desired pose relative to the board (`translation_m`,
        /// `rotation_rpy_rad` give camera_from_board); ξ_d and the depths follow from it.
        TargetPose = 2, "target_pose";
        /// A new target: the features and pose the camera has now.
        TargetTeach = 3, "target_teach";
        /// The simulated board stops where it is.
        ObjectHold = 4, "object_hold";
        /// The simulated board jumps by `translation_m` (desired camera frame) now.
        ObjectStep = 5, "object_step";
        /// The simulated board moves on a circle of `radius_m` at `rev_per_min` in the desired camera
        /// frame's y–z plane, starting where it is.
        ObjectCircle = 6, "object_circle";
        /// Reload the configuration file (as SIGHUP does).
        Reload = 7, "reload";
        /// Resume servoing after a safe stop (refused, saying why, while the fault's cause is still there).
        Resume = 8, "resume";
        /// Bring the arm to rest and hold it: a safe stop asked for by the client (fault `requested`).
        SafeStop = 9, "safe_stop";
        /// Move the arm's joints to `joints_rad` at up to `speed_fraction` (0–1] of their speed limits and hold
        /// them there instead of servoing (`vservoctl calibrate`); refused in a safe stop (a `target_lost` one it ends), outside the joint
        /// limits, or with values for joints the arm does not have.
        MoveJoints = 10, "move_joints";
        /// End a joint move: servo again from where the arm is.
        Servo = 11, "servo";
        /// Set the dynamics override to `speed_fraction` (0–1]: every path of the reference keeps that share of
        /// the joints' speed, acceleration and jerk limits and of the tool's caps. Lowering it is always taken;
        /// raising it only while the cell is held, or with `flags` bit 0.
        Speed = 12, "speed";
    }
}

wire_code! {
    /// Where the gain's interaction matrix B is evaluated (`gains.interaction`).
    pub enum Interaction: u32, "interaction" {
        /// At ξ_d and Z_d: the paper's fixed gain.
        Desired = 0, "desired";
        /// At the mean of the desired and the current image Jacobians' pseudo-inverses.
        Mean = 1, "mean";
        /// At the current features and depths.
        Current = 2, "current";
    }
}

wire_code! {
    /// What the servo's law servoes on with all four marks seen (`gains.servo_features`).
    pub enum ServoFeatures: u32, "servo features" {
        /// The image: the paper's and the delay-aware law.
        Image = 0, "image";
        /// The camera's pose, on a straight line (`pbvs`).
        CameraPose = 1, "camera-pose";
        /// The marks' centre on a straight line in the camera's frame, and the rotation (`pbvs-target`).
        TargetPose = 2, "target-pose";
        /// 2½-D: the marks' centre's image point and log depth, and the rotation (`2.5d`).
        TwoAndAHalfD = 3, "2.5d";
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trips<E>(
        all: &[E],
        code: impl Fn(E) -> u32,
        name: impl Fn(E) -> &'static str,
        parse: impl Fn(u32) -> Option<E>,
        by_name: impl Fn(&str) -> Option<E>,
    ) where
        E: Copy + PartialEq + std::fmt::Debug,
    {
        for &value in all {
            assert_eq!(parse(code(value)), Some(value));
            assert_eq!(by_name(name(value)), Some(value));
        }
    }

    #[test]
    fn every_code_round_trips_through_its_number_and_name() {
        round_trips(
            Verdict::ALL,
            |v| v.code(),
            Verdict::name,
            |c| Verdict::try_from(c).ok(),
            Verdict::from_name,
        );
        round_trips(Fault::ALL, |v| v.code(), Fault::name, |c| Fault::try_from(c).ok(), Fault::from_name);
        round_trips(
            CommandKind::ALL,
            |v| v.code(),
            CommandKind::name,
            |c| CommandKind::try_from(c).ok(),
            CommandKind::from_name,
        );
        round_trips(
            MarkStatus::ALL,
            |v| u32::from(v.code()),
            MarkStatus::name,
            |c| u8::try_from(c).ok().and_then(|c| MarkStatus::try_from(c).ok()),
            MarkStatus::from_name,
        );
        round_trips(
            ServoFeatures::ALL,
            |v| v.code(),
            ServoFeatures::name,
            |c| ServoFeatures::try_from(c).ok(),
            ServoFeatures::from_name,
        );
    }

    #[test]
    fn an_unknown_number_is_refused_naming_what_it_is() {
        let refused = Verdict::try_from(8).err();
        assert_eq!(refused, Some(UnknownCode { what: "verdict", code: 8 }));
        assert_eq!(
            CommandKind::try_from(0).err().map(|e| e.to_string()).as_deref(),
            Some("command kind 0 is not a known code")
        );
        assert!(MarkStatus::try_from(200u8).is_err());
    }

    #[test]
    fn the_legend_lists_every_value_with_its_number() {
        assert_eq!(CommandMode::legend(), "0 torque, 1 velocity, 2 position");
        assert!(Verdict::moves(Verdict::Reacquiring) && !Verdict::moves(Verdict::SafeStop));
    }
}
