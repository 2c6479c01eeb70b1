//! A ros2_control arm as vservo's robot driver, the pure part (docs/ROS2.md, "ROS 2 as the driver"): each
//! `sensor_msgs/JointState` of the arm becomes a `joint_state` of docs/DRIVERS.md, and the rmrc's newest
//! `joint_command` the `std_msgs/Float64MultiArray` its forward velocity (or position) controller takes.
//!
//! A forward controller holds its last command for ever: this is the watchdog. With no valid command for
//! `[ros2.driver] hold_after_s` (vservo gone, stalled or refusing), the arm is commanded to rest (zero
//! velocities, or the position where holding began) and the joint state says `holding`; the caller also sends
//! that command when the arm's joint states stop, and when it ends.
//!
//! The contract's rules (command admission with its one age window, holding, `applied_command_tick`, the period
//! check, the limit bits) are `vservo_driver::DriverSide`'s, as for every robot driver; ROS's own part is here.
//!
//! No I/O and no clock here: times come in as arguments (CLOCK_MONOTONIC ns), so the rules are tested as
//! functions.

use vservo_arm::SerialArm;
use vservo_driver::{CommandRefused, DriverSettings, DriverSide};
use vservo_protocol::seal::SealKey;
use vservo_protocol::{CellModeMsg, CommandMode, DriverStatus, JointCommandMsg, JointStateMsg, MAX_JOINTS};

use crate::msg::JointState;

/// What the driver knows of the arm and its controller.
#[derive(Debug, Clone)]
pub struct ArmSettings {
    /// The arm's joints in ROS, from the base outwards: also the order of the controller's command.
    pub joint_names: Vec<String>,
    /// The controller's interface: velocity or position.
    pub mode: CommandMode,
    /// The arm's joint-state period (ns): `[robot] period_s`.
    pub period_ns: u64,
    /// No valid command for this long: hold (ns).
    pub hold_after_ns: u64,
    /// Each joint's lowest angle (rad): the position-limit bits.
    pub position_min_rad: [f64; MAX_JOINTS],
    /// Each joint's highest angle (rad).
    pub position_max_rad: [f64; MAX_JOINTS],
    /// Each joint's speed limit (rad/s): the velocity-limit bits.
    pub velocity_max_rad_s: [f64; MAX_JOINTS],
    /// What a ramp to rest still gains (rad/s): how much a held cell's commands may add to the speed in force
    /// (`vservo_driver::speed_gained_braking` of the interpolator's limits).
    pub braking_gain_rad_s: [f64; MAX_JOINTS],
}

impl ArmSettings {
    /// From the configuration's arm, `[robot]` and `[ros2]`.
    pub fn of(config: &vservo_config::Config) -> Self {
        let arm: &SerialArm = &config.cell.arm;
        let joint_count = arm.joint_count();
        let mut settings = Self {
            joint_names: crate::convert::joint_names(&config.ros2.joint_names, &config.cell.arm),
            mode: match config.cell.command_interface() {
                vservo_config::CommandInterface::Position => CommandMode::Position,
                _ => CommandMode::Velocity,
            },
            period_ns: vservo_time::nanos(config.cell.robot.period_s),
            hold_after_ns: vservo_time::nanos(config.ros2.driver.hold_after_s),
            position_min_rad: [f64::NEG_INFINITY; MAX_JOINTS],
            position_max_rad: [f64::INFINITY; MAX_JOINTS],
            velocity_max_rad_s: [f64::INFINITY; MAX_JOINTS],
            braking_gain_rad_s: [0.0; MAX_JOINTS],
        };
        let interpolator = &config.cell.interpolator;
        for (j, limits) in arm.limits().enumerate().take(joint_count) {
            settings.position_min_rad[j] = limits.position_min;
            settings.position_max_rad[j] = limits.position_max;
            settings.velocity_max_rad_s[j] = limits.velocity_max;
            let jerk = interpolator.jerk_limit.map_or(f64::INFINITY, |jerk| jerk[j]);
            settings.braking_gain_rad_s[j] =
                vservo_driver::speed_gained_braking(interpolator.acceleration_limit[j], jerk);
        }
        settings
    }

    fn joint_count(&self) -> usize {
        self.joint_names.len()
    }

    /// What the driver side of the contract (`vservo_driver::DriverSide`) is told of this driver.
    fn driver_settings(&self) -> DriverSettings {
        DriverSettings {
            mode: self.mode,
            joint_count: self.joint_count(),
            period_ns: self.period_ns,
            hold_after_ns: self.hold_after_ns,
            position_min_rad: self.position_min_rad,
            position_max_rad: self.position_max_rad,
            velocity_max_rad_s: self.velocity_max_rad_s,
            braking_gain_rad_s: self.braking_gain_rad_s,
        }
    }
}

/// `; did you mean "name"?` for a name a slip of the keyboard away, else nothing.
fn meant(nearest: &Option<String>) -> String {
    nearest.as_ref().map_or(String::new(), |name| format!("; did you mean {name:?}?"))
}

/// A joint state of the arm's that is not passed on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateRefused {
    /// A configured joint is not in it (another arm's, or `[ros2] joint_names` do not match the URDF's), and the
    /// name of its nearest a slip of the keyboard away, if one is.
    #[error("has no joint {0:?} (ros2.joint_names){meant}", meant = meant(.1))]
    MissingJoint(String, Option<String>),
    /// Its positions, velocities or efforts do not match its names, or a position is not finite.
    #[error("is malformed: {0}")]
    Malformed(&'static str),
    /// Its stamp is not after the last one passed on (a repeat, or out of order).
    #[error(
        "is not newer than the last one (stamp {stamp_ns} ns, period {tick}; the last passed on: {last_tick})"
    )]
    NotNewer {
        /// Its stamp (CLOCK_MONOTONIC ns).
        stamp_ns: u64,
        /// The tick the stamp makes.
        tick: u64,
        /// The last tick passed on.
        last_tick: u64,
    },
}

impl StateRefused {
    /// The kind of refusal, for a log that says each kind once.
    pub fn kind(&self) -> &'static str {
        match self {
            StateRefused::MissingJoint(..) => "joint state without a configured joint",
            StateRefused::Malformed(_) => "malformed joint state",
            StateRefused::NotNewer { .. } => "joint state not newer",
        }
    }
}

/// What the driver counts (logged now and then).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ArmCounts {
    /// Joint states passed on to vservo.
    pub states: u64,
    /// Joint states refused.
    pub states_refused: u64,
    /// Commands of vservo's taken.
    pub commands_taken: u64,
    /// Commands of vservo's refused (another epoch, mode or arm, too old, not finite).
    pub commands_refused: u64,
    /// Controller commands sent while holding.
    pub holds: u64,
}

/// One joint state passed on: the vservo message, and the controller's command to send now.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// For `joint_state`.
    pub state: JointStateMsg,
    /// For the controller: `Float64MultiArray.data`, in `joint_names` order.
    pub command: Vec<f64>,
}

/// The driver's state between joint states: the contract's side of it (command admission with its one age
/// window, holding, `applied_command_tick`, the period check and the limit bits) is `vservo_driver::DriverSide`'s;
/// what is ROS's (joints by name, ticks from stamps, speeds from positions, holding a position) is here.
#[derive(Debug, Clone)]
pub struct ArmFollower {
    settings: ArmSettings,
    side: DriverSide,
    /// The stamp of the first joint state: tick 0.
    origin_ns: Option<u64>,
    last: Option<(u64, [f64; MAX_JOINTS])>,
    /// Where the arm is held (position mode), from when holding began.
    hold_at: Option<[f64; MAX_JOINTS]>,
    /// What happened so far.
    pub counts: ArmCounts,
}

impl ArmFollower {
    /// A driver run that starts now: `epoch` is its start time (ns), as docs/DRIVERS.md asks; `key`, the run's
    /// seal key (vservod hands it over; without it no command is taken).
    pub fn new(settings: ArmSettings, epoch: u64, key: Option<SealKey>) -> Self {
        let side = DriverSide::new(settings.driver_settings(), epoch, key);
        Self { settings, side, origin_ns: None, last: None, hold_at: None, counts: ArmCounts::default() }
    }

    /// Takes one of vservo's commands if the contract admits it (`DriverSide::take_command`: the rmrc's seal,
    /// this run's, of the declared mode and arm, answering one of the last states published, finite, and a
    /// ramp to rest while the cell is held); the refusal, if any.
    pub fn take_command(&mut self, command: &JointCommandMsg, now_ns: u64) -> Option<CommandRefused> {
        match self.side.take_command(command, now_ns) {
            Ok(()) => {
                self.counts.commands_taken += 1;
                None
            }
            Err(refused) => {
                self.counts.commands_refused += 1;
                Some(refused)
            }
        }
    }

    /// The cell's mode (`cell_mode`), taken by the driver side when the daemon sealed it.
    pub fn cell_mode(&mut self, message: &CellModeMsg) {
        self.side.cell_mode(message);
    }

    /// One of the arm's joint states, measured at `stamp_ns` and received at `now_ns`: the `joint_state` to
    /// publish and the controller command to send now (for the period it starts).
    pub fn on_joint_state(
        &mut self,
        ros: &JointState,
        stamp_ns: u64,
        now_ns: u64,
    ) -> Result<Step, StateRefused> {
        let measured = self.measured(ros).inspect_err(|_| self.counts.states_refused += 1)?;
        let tick = self.tick_of(stamp_ns).inspect_err(|_| self.counts.states_refused += 1)?;
        let qd_rad_s =
            measured.qd_rad_s.unwrap_or_else(|| self.velocity_from_positions(stamp_ns, &measured.q_rad));
        let seen = vservo_driver::Measured { q_rad: measured.q_rad, qd_rad_s, torque_nm: measured.torque_nm };
        let mut state = self.side.joint_state(tick, stamp_ns, &seen, None);
        let (status, command) = match self.side.period_mismatch_ns() {
            // not the configured arm's period: a fault (the cell stops safely), the arm held
            Some(_) => {
                self.side.hold();
                let at = self.hold_values(Some(measured.q_rad)).unwrap_or_default();
                (DriverStatus::Fault, at)
            }
            None => self.command_for(now_ns, &measured.q_rad),
        };
        // the status of the command sent now, with this state (the controller takes it at once)
        state.driver_status = status.code();
        self.origin_ns.get_or_insert(stamp_ns);
        self.last = Some((stamp_ns, measured.q_rad));
        self.counts.states += 1;
        Ok(Step { state, command })
    }

    /// The controller command that holds the arm: zero velocities, or the position where holding began
    /// (the last measured one). For when the joint states stop, and at the end. `None` in position mode
    /// before any joint state: there is no position to hold, and an empty command would only be refused.
    pub fn hold(&mut self) -> Option<Vec<f64>> {
        self.side.hold();
        let q_rad = self.last.map(|(_, q)| q);
        let values = self.hold_values(q_rad);
        self.counts.holds += u64::from(values.is_some());
        values
    }

    /// The configured period of the arm's joint states (ns).
    pub fn period_ns(&self) -> u64 {
        self.settings.period_ns
    }

    /// The median gap between the arm's joint states (ns) when it is not `[robot] period_s`: the driver then
    /// reports a fault and holds the arm.
    pub fn period_mismatch_ns(&self) -> Option<u64> {
        self.side.period_mismatch_ns()
    }

    /// Whether a command has come in time (`DriverSide::apply`): the status to report and the controller's
    /// command.
    fn command_for(&mut self, now_ns: u64, q_rad: &[f64; MAX_JOINTS]) -> (DriverStatus, Vec<f64>) {
        let n = self.settings.joint_count();
        match self.side.apply(now_ns) {
            Some(in_force) => {
                self.hold_at = None;
                (DriverStatus::Following, in_force.values[..n].to_vec())
            }
            None => {
                self.counts.holds += 1;
                let at = self.hold_values(Some(*q_rad)).unwrap_or_default();
                (DriverStatus::Holding, at)
            }
        }
    }

    /// Rest: zero velocities; or the position where holding began (`q_rad` if it begins now; none if no
    /// position is known).
    fn hold_values(&mut self, q_rad: Option<[f64; MAX_JOINTS]>) -> Option<Vec<f64>> {
        let n = self.settings.joint_count();
        match self.settings.mode {
            CommandMode::Position => {
                let at = self.hold_at.or(q_rad)?;
                self.hold_at = Some(at);
                Some(at[..n].to_vec())
            }
            _ => Some(vec![0.0; n]),
        }
    }

    /// The configured joints' values in the message, by name.
    fn measured(&self, ros: &JointState) -> Result<Measured, StateRefused> {
        let named = ros.name.len();
        if ros.position.len() != named {
            return Err(StateRefused::Malformed("positions and names differ in number"));
        }
        let velocities = ros.velocity.len() == named;
        let efforts = ros.effort.len() == named;
        if (!velocities && !ros.velocity.is_empty()) || (!efforts && !ros.effort.is_empty()) {
            return Err(StateRefused::Malformed("velocities or efforts and names differ in number"));
        }
        let mut measured = Measured {
            q_rad: [0.0; MAX_JOINTS],
            qd_rad_s: velocities.then_some([0.0; MAX_JOINTS]),
            torque_nm: [f64::NAN; MAX_JOINTS],
        };
        for (j, name) in self.settings.joint_names.iter().enumerate() {
            let i = ros.name.iter().position(|n| n == name).ok_or_else(|| {
                // the nearest of the names it has that are not the arm's other joints
                let others = ros.name.iter().filter(|n| !self.settings.joint_names.contains(n));
                let nearest = vservo_config::did_you_mean(name, others.map(String::as_str));
                StateRefused::MissingJoint(name.clone(), nearest.map(str::to_string))
            })?;
            measured.q_rad[j] = ros.position[i];
            if let Some(qd) = &mut measured.qd_rad_s {
                qd[j] = ros.velocity[i];
            }
            if efforts {
                measured.torque_nm[j] = ros.effort[i];
            }
        }
        let n = self.settings.joint_count();
        if !measured.q_rad[..n].iter().all(|q| q.is_finite())
            || !measured.qd_rad_s.is_none_or(|qd| qd[..n].iter().all(|v| v.is_finite()))
        {
            return Err(StateRefused::Malformed("a position or velocity is not finite"));
        }
        Ok(measured)
    }

    /// The arm's periods since the first state: the stamp's distance from it in periods (docs/DRIVERS.md,
    /// "`tick` over missed periods"), and at least one more than the last: a state that came late and the
    /// next one on time may round to the same period, and both are the arm's.
    fn tick_of(&self, stamp_ns: u64) -> Result<u64, StateRefused> {
        let (Some(origin_ns), Some((last_ns, _))) = (self.origin_ns, self.last) else { return Ok(0) };
        let period = self.settings.period_ns.max(1);
        let periods = (stamp_ns.saturating_sub(origin_ns) + period / 2) / period;
        let last_tick = self.side.last_tick().unwrap_or(0);
        if stamp_ns <= last_ns {
            return Err(StateRefused::NotNewer { stamp_ns, tick: periods, last_tick });
        }
        Ok(periods.max(last_tick + 1))
    }

    /// With no velocities in the message: the positions' change since the last state, or zero at the first.
    fn velocity_from_positions(&self, stamp_ns: u64, q_rad: &[f64; MAX_JOINTS]) -> [f64; MAX_JOINTS] {
        match self.last {
            Some((last_ns, last_q)) if stamp_ns > last_ns => {
                let dt_s = vservo_time::seconds_between(stamp_ns, last_ns);
                std::array::from_fn(|j| (q_rad[j] - last_q[j]) / dt_s)
            }
            _ => [0.0; MAX_JOINTS],
        }
    }
}

/// A joint state's values in the configured order.
struct Measured {
    q_rad: [f64; MAX_JOINTS],
    qd_rad_s: Option<[f64; MAX_JOINTS]>,
    torque_nm: [f64; MAX_JOINTS],
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_driver::PERIOD_CHECK_GAPS;
    use vservo_protocol::SCHEMA_VERSION;
    use vservo_protocol::messages::fault_bits;

    const PERIOD_NS: u64 = 2_000_000;
    const EPOCH: u64 = 77;

    fn settings(mode: CommandMode) -> ArmSettings {
        ArmSettings {
            joint_names: (1..=6).map(|j| format!("j{j}")).collect(),
            mode,
            period_ns: PERIOD_NS,
            hold_after_ns: 20_000_000,
            position_min_rad: [-3.0; MAX_JOINTS],
            position_max_rad: [3.0; MAX_JOINTS],
            velocity_max_rad_s: [2.0; MAX_JOINTS],
            braking_gain_rad_s: [0.01; MAX_JOINTS],
        }
    }

    fn key() -> SealKey {
        SealKey::from_hex(b"0f0e0d0c0b0a09080706050403020100").expect("a key")
    }

    fn follower(mode: CommandMode) -> ArmFollower {
        ArmFollower::new(settings(mode), EPOCH, Some(key()))
    }

    /// Takes `command` as the rmrc sealed it.
    fn take(arm: &mut ArmFollower, command: &JointCommandMsg, now_ns: u64) -> Option<CommandRefused> {
        let mut command = *command;
        key().sign(&mut command);
        arm.take_command(&command, now_ns)
    }

    /// A ROS joint state with the joints in reverse order (the broadcaster's order is the URDF's, not ours).
    fn ros_state(q: [f64; 6]) -> JointState {
        JointState {
            name: (1..=6).rev().map(|j| format!("j{j}")).chain(["gripper".to_string()]).collect(),
            position: q.iter().rev().copied().chain([0.5]).collect(),
            velocity: vec![0.1; 7],
            effort: Vec::new(),
            ..JointState::default()
        }
    }

    fn command_answering(tick: u64, qd: f64) -> JointCommandMsg {
        JointCommandMsg {
            schema: SCHEMA_VERSION,
            mode: CommandMode::Velocity.code(),
            joint_count: 6,
            answers_tick: tick,
            driver_epoch: EPOCH,
            qd_ref_rad_s: [qd; MAX_JOINTS],
            q_ref_rad: [0.25; MAX_JOINTS],
            ..JointCommandMsg::default()
        }
    }

    #[test]
    fn joints_are_taken_by_name_and_ticks_by_stamp() {
        let mut arm = follower(CommandMode::Velocity);
        let q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let first = arm.on_joint_state(&ros_state(q), 1_000_000_000, 1_000_100_000).expect("the first");
        assert_eq!(&first.state.q_rad[..6], &q);
        assert_eq!(first.state.q_rad[6], 0.0, "the gripper is not a joint of the arm");
        assert_eq!((first.state.tick, first.state.driver_epoch, first.state.joint_count), (0, EPOCH, 6));
        assert!(first.state.torque_nm[..6].iter().all(|t| t.is_nan()), "no efforts: unknown torque");
        // three periods later (two states lost on the way): the tick says so
        let later =
            arm.on_joint_state(&ros_state(q), 1_000_000_000 + 3 * PERIOD_NS + 1000, 0).expect("later");
        assert_eq!(later.state.tick, 3);
        // a state that came 1.2 periods late, then the next on time: both the arm's, one tick apart
        let late =
            arm.on_joint_state(&ros_state(q), 1_000_000_000 + 5 * PERIOD_NS + 1000, 0).expect("late one");
        assert_eq!(late.state.tick, 5);
        let on_time = arm.on_joint_state(&ros_state(q), 1_000_000_000 + 5 * PERIOD_NS + 900_000, 0);
        assert_eq!(on_time.expect("on time").state.tick, 6);
        let repeat = arm.on_joint_state(&ros_state(q), 1_000_000_000 + 5 * PERIOD_NS + 900_000, 0);
        assert!(matches!(repeat, Err(StateRefused::NotNewer { .. })), "{repeat:?}");
        let mut other_arm = ros_state(q);
        other_arm.name[0] = "elbow".into();
        let refused = arm.on_joint_state(&other_arm, 1_000_000_000 + 8 * PERIOD_NS, 0);
        assert_eq!(refused, Err(StateRefused::MissingJoint("j6".into(), None)));
        // a slip in a name: said, with the name meant
        let mut slip = ros_state(q);
        slip.name[0] = "j_6".into();
        let refused = arm.on_joint_state(&slip, 1_000_000_000 + 8 * PERIOD_NS, 0).expect_err("refused");
        assert_eq!(refused.to_string(), "has no joint \"j6\" (ros2.joint_names); did you mean \"j_6\"?");
        let mut nan = ros_state(q);
        nan.position[2] = f64::NAN;
        assert!(matches!(
            arm.on_joint_state(&nan, 1_000_000_000 + 9 * PERIOD_NS, 0),
            Err(StateRefused::Malformed(_))
        ));
        assert_eq!((arm.counts.states, arm.counts.states_refused), (4, 4));
    }

    #[test]
    fn a_recent_command_of_this_run_is_followed_and_reported_applied() {
        let mut arm = follower(CommandMode::Velocity);
        let q = [0.0; 6];
        let t0 = 5_000_000_000;
        let first = arm.on_joint_state(&ros_state(q), t0, t0).expect("state 0");
        assert_eq!(first.state.driver_status, DriverStatus::Holding.code(), "no command yet");
        assert_eq!(first.command, vec![0.0; 6], "rest");
        take(&mut arm, &command_answering(0, 0.3), t0 + 100_000);
        let second = arm.on_joint_state(&ros_state(q), t0 + PERIOD_NS, t0 + PERIOD_NS).expect("state 1");
        assert_eq!(second.state.driver_status, DriverStatus::Following.code());
        assert_eq!(second.command, vec![0.3; 6]);
        assert_eq!(second.state.applied_command_tick, u64::MAX, "nothing was applied over period 0");
        let third =
            arm.on_joint_state(&ros_state(q), t0 + 2 * PERIOD_NS, t0 + 2 * PERIOD_NS).expect("state 2");
        assert_eq!(third.state.applied_command_tick, 0, "the command answering state 0, over period 1");
        // refused: another epoch, another mode, another arm, too old, not finite
        let mut nan = command_answering(2, 0.1);
        nan.qd_ref_rad_s[4] = f64::NAN;
        let refused = [
            JointCommandMsg { driver_epoch: EPOCH + 1, ..command_answering(2, 0.1) },
            JointCommandMsg { mode: CommandMode::Position.code(), ..command_answering(2, 0.1) },
            JointCommandMsg { joint_count: 7, ..command_answering(2, 0.1) },
            command_answering(3, 0.1),
            nan,
        ];
        for command in &refused {
            take(&mut arm, command, t0 + 2 * PERIOD_NS + 100_000);
        }
        assert_eq!(arm.counts.commands_refused, 5);
        let fourth =
            arm.on_joint_state(&ros_state(q), t0 + 3 * PERIOD_NS, t0 + 3 * PERIOD_NS).expect("state 3");
        assert_eq!(fourth.command, vec![0.3; 6], "the refused ones changed nothing");
    }

    #[test]
    fn with_no_command_in_time_the_arm_is_held() {
        let mut arm = follower(CommandMode::Velocity);
        let t0 = 1_000_000_000;
        arm.on_joint_state(&ros_state([0.0; 6]), t0, t0).expect("state 0");
        take(&mut arm, &command_answering(0, 0.3), t0 + 100_000);
        let within = t0 + 10 * PERIOD_NS;
        let step = arm.on_joint_state(&ros_state([0.0; 6]), within, t0 + 20_100_000).expect("within");
        assert_eq!(step.command, vec![0.3; 6], "20 ms after the command: still followed");
        let late =
            arm.on_joint_state(&ros_state([0.0; 6]), within + PERIOD_NS, t0 + 20_200_000).expect("late");
        assert_eq!(late.state.driver_status, DriverStatus::Holding.code());
        assert_eq!(late.command, vec![0.0; 6]);
        assert_eq!(arm.hold(), Some(vec![0.0; 6]), "the hold when the joint states stop");
    }

    #[test]
    fn position_mode_holds_where_holding_began() {
        let mut arm = follower(CommandMode::Position);
        assert_eq!(arm.hold(), None, "no position known yet: nothing to hold at");
        let t0 = 1_000_000_000;
        let q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let first = arm.on_joint_state(&ros_state(q), t0, t0).expect("state 0");
        assert_eq!(first.command, q.to_vec(), "held where it is");
        let drifted =
            arm.on_joint_state(&ros_state([0.7; 6]), t0 + PERIOD_NS, t0 + PERIOD_NS).expect("state 1");
        assert_eq!(drifted.command, q.to_vec(), "still where holding began, not where the arm drifted");
        let command = JointCommandMsg { mode: CommandMode::Position.code(), ..command_answering(1, 0.0) };
        take(&mut arm, &command, t0 + PERIOD_NS + 1000);
        let following = arm.on_joint_state(&ros_state([0.7; 6]), t0 + 2 * PERIOD_NS, t0 + 2 * PERIOD_NS);
        assert_eq!(following.expect("state 2").command, vec![0.25; 6], "q_ref");
    }

    /// Joint states every 1 ms for a configured 2 ms: each would count as a period the arm did not live; after
    /// [`PERIOD_CHECK_GAPS`] of them the driver reports a fault and holds. A late state and a lost one among
    /// states at the right period change nothing.
    #[test]
    fn an_arm_of_another_period_is_a_fault() {
        let mut arm = follower(CommandMode::Velocity);
        let t0 = 1_000_000_000;
        let mut last = None;
        for k in 0..=PERIOD_CHECK_GAPS as u64 {
            let stamp = t0 + k * PERIOD_NS / 2;
            take(&mut arm, &command_answering(k.saturating_sub(1), 0.3), stamp);
            last = Some(arm.on_joint_state(&ros_state([0.0; 6]), stamp, stamp).expect("a state"));
        }
        let last = last.expect("states");
        assert_eq!(arm.period_mismatch_ns(), Some(PERIOD_NS / 2));
        assert_eq!(last.state.driver_status, DriverStatus::Fault.code());
        assert_eq!(last.command, vec![0.0; 6], "held");

        let mut arm = follower(CommandMode::Velocity);
        let mut stamp = t0;
        for k in 0..3 * PERIOD_CHECK_GAPS as u64 {
            stamp += match k % 20 {
                7 => 2 * PERIOD_NS,      // one lost
                13 => PERIOD_NS * 5 / 2, // one late
                14 => PERIOD_NS / 2,     // and the next on time
                _ => PERIOD_NS,
            };
            let step = arm.on_joint_state(&ros_state([0.0; 6]), stamp, stamp).expect("a state");
            assert_ne!(step.state.driver_status, DriverStatus::Fault.code(), "state {k}");
        }
        assert_eq!(arm.period_mismatch_ns(), None);
    }

    #[test]
    fn limits_set_fault_bits() {
        let mut arm = follower(CommandMode::Velocity);
        let mut state = ros_state([0.0, 0.0, 3.1, 0.0, 0.0, 0.0]);
        state.velocity[0] = -2.5; // the message's first joint is j6
        let step = arm.on_joint_state(&state, 1_000_000_000, 0).expect("state");
        let position = fault_bits::joints(step.state.faults, fault_bits::POSITION_LIMIT_SHIFT);
        let velocity = fault_bits::joints(step.state.faults, fault_bits::VELOCITY_LIMIT_SHIFT);
        assert_eq!((position, velocity), (1 << 2, 1 << 5));
    }
}
