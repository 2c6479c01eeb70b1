//! The fault reaction's decisions, apart from any I/O: what the loop published goes in (every joint state,
//! twist and feature vector the supervisor drains), and out comes whether the cell must go to a safe stop,
//! which fault and since when, and whether it may servo again.
//!
//! At once: a joint beyond its position range or its velocity limit, a driver that reports a fault, an
//! external driver that stalled, a camera that sent no frame for `faults.camera_timeout_periods` vision
//! periods (judged by the supervisor: `supervisor::health::CameraWatch`). Once they last: a torque cut to its limit (`faults.saturation_s`), marks
//! missing so that the servo cannot servo (`faults.target_lost_s`). The first fault is latched; the cell
//! resumes on a command, or by itself under `faults.resume = "automatic"`, only once no cause is left.
//!
//! Each condition is written once ([`CONDITIONS`]) and judged on [`Evidence`]: what was seen since the last
//! cycle (a fault found) or how things stand now (a cause that keeps the cell from resuming).

use vservo_config::{Faults, ResumePolicy};
use vservo_protocol::{
    CameraTwistMsg, DriverError, DriverStatus, Fault, FeaturesMsg, JointCommandMsg, JointStateMsg,
    RobotState, Verdict, fault_bits, guard_bits,
};

/// Four bits, one per mark.
const ALL_MARKS: u32 = 0b1111;
/// Features older than this do not show that the marks are seen (ns).
const FRESH_FEATURES_NS: u64 = vservo_time::NANOS_PER_SECOND;

/// A latched fault.
#[derive(Debug, Clone, PartialEq)]
pub struct LatchedFault {
    /// Which fault.
    pub code: Fault,
    /// The joints it concerns (bit j: joint j + 1).
    pub joints: u32,
    /// CLOCK_MONOTONIC (ns) when it was found.
    pub since_ns: u64,
    /// What was seen.
    pub cause: Cause,
}

/// One thing that stops the cell, or keeps it from servoing again; its message is the log's and the
/// refused resume's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Cause {
    /// The rmrc (and the simulated plant) do not all run healthy: not a fault of its own.
    #[error("the nodes that move the arm are not all running")]
    MotionNodesDown,
    /// No joint state yet: not a fault of its own.
    #[error("no joint state from the robot driver yet")]
    RobotWaiting,
    /// Joints beyond their position range.
    #[error("joint {} is beyond its position range", joint_list(*.0))]
    PositionLimit(u32),
    /// Joints over their velocity limit.
    #[error("joint {} is over its velocity limit", joint_list(*.0))]
    VelocityLimit(u32),
    /// The driver reports a fault, and the robot's reason where the driver gives one.
    #[error("the robot driver reports a fault{}", driver_reason(*.0))]
    DriverFault(DriverError),
    /// The driver's joint states carry another number of joints than the configured arm has.
    #[error("the robot driver reports {reported} joints; the configured arm has {configured}")]
    JointCount {
        /// The joint count in the driver's states.
        reported: u32,
        /// The configured arm's.
        configured: u32,
    },
    /// The driver's joint states stopped (a fault of an external driver only).
    #[error("the robot driver's joint states do not arrive")]
    RobotStalled,
    /// The camera sends no frame (the simulated one or an external one; not a vision node that is down).
    #[error("the camera sends no frame (none for faults.camera_timeout_periods vision periods)")]
    CameraStalled,
    /// Joint torques cut to their limit.
    #[error("joint {} torque is at its limit", joint_list(*.0))]
    TorqueSaturated(u32),
    /// Marks missing (bit m: mark m + 1).
    #[error("the camera does not see all four marks (mark {} missing)", mark_list(*.0))]
    MarksMissing(u32),
    /// A client asked for the safe stop.
    #[error("asked for by a client")]
    Requested,
    /// The cell came up held (`robot.start = "held"`): a first motion waits for a resume.
    #[error(
        "the cell came up held (robot.start = \"held\"); `vservoctl check`, then `vservoctl resume` begins servoing"
    )]
    StartHeld,
    /// The daemon itself stopped supervising for longer than the nodes wait for its word (ms).
    #[error(
        "vservod stopped supervising for {0} ms (SIGSTOP, a debugger, a frozen machine); the nodes held the arm"
    )]
    SupervisionStalled(u64),
    /// The collision guard stopped the arm (the rmrc's `joint_command.guard` word, which names the distance).
    #[error(
        "the collision guard stopped the arm: a motion closed a distance it watches to its stop distance"
    )]
    Collision(u32),
    /// A process that is not a stream's writer holds its writer slot, or a node's port was refused because
    /// its slots are held (the log names the stream and the process).
    #[error("a stream's writer slot is held by a process that is not its writer")]
    StreamTaken,
}

impl Cause {
    /// The fault this cause is, if it is one.
    pub fn fault(self) -> Option<Fault> {
        match self {
            Cause::MotionNodesDown | Cause::RobotWaiting => None,
            Cause::PositionLimit(_) => Some(Fault::PositionLimit),
            Cause::VelocityLimit(_) => Some(Fault::VelocityLimit),
            Cause::DriverFault(_) | Cause::JointCount { .. } => Some(Fault::DriverFault),
            Cause::RobotStalled => Some(Fault::RobotStalled),
            Cause::CameraStalled => Some(Fault::CameraStalled),
            Cause::TorqueSaturated(_) => Some(Fault::TorqueSaturated),
            Cause::MarksMissing(_) => Some(Fault::TargetLost),
            Cause::Requested => Some(Fault::Requested),
            Cause::StartHeld => Some(Fault::StartHeld),
            Cause::SupervisionStalled(_) => Some(Fault::SupervisionStalled),
            Cause::StreamTaken => Some(Fault::StreamTaken),
            Cause::Collision(_) => Some(Fault::Collision),
        }
    }

    /// The joints it concerns (bit j: joint j + 1).
    pub fn joints(self) -> u32 {
        match self {
            Cause::PositionLimit(joints) | Cause::VelocityLimit(joints) | Cause::TorqueSaturated(joints) => {
                joints
            }
            _ => 0,
        }
    }
}

/// What the conditions are judged on: what was seen since the last cycle (finding a fault), or how things
/// stand now (what keeps the cell from resuming).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// `fault_bits` of the joint states.
    pub fault_bits: u32,
    /// A joint state's driver status said FAULT (or the driver-failed bit was set), with the driver's reason.
    pub driver_fault: Option<DriverError>,
    /// A joint state's joint count and the configured arm's, where they differ.
    pub foreign_joint_count: Option<(u32, u32)>,
    /// The robot driver's state, as far as it counts.
    pub robot: RobotState,
    /// Joints whose torque is at its limit, as far as it counts.
    pub saturated_joints: u32,
    /// Marks missing, as far as it counts (bit m: mark m + 1; 0: none).
    pub missing_marks: u32,
    /// The nodes that bring the arm to rest run healthy.
    pub motion_nodes_healthy: bool,
    /// A stream's writer slot is held by a process that is not its writer.
    pub stream_taken: bool,
    /// The camera has sent no frame for its timeout while the vision node ran.
    pub camera_stalled: bool,
    /// The collision guard stopped the arm (its word), seen since the last cycle; never a cause that stays: the
    /// guard itself takes only motions away once the cell resumes.
    pub guard_stop: Option<u32>,
}

/// A condition: the cause it finds in the evidence, if any.
pub type Condition = fn(&Evidence) -> Option<Cause>;

/// Every condition, in the order a fault is chosen when several are found at once.
pub const CONDITIONS: [Condition; 12] = [
    |e| e.stream_taken.then_some(Cause::StreamTaken),
    |e| (!e.motion_nodes_healthy).then_some(Cause::MotionNodesDown),
    |e| (e.robot == RobotState::Waiting).then_some(Cause::RobotWaiting),
    |e| nonzero(fault_bits::joints(e.fault_bits, fault_bits::POSITION_LIMIT_SHIFT)).map(Cause::PositionLimit),
    |e| nonzero(fault_bits::joints(e.fault_bits, fault_bits::VELOCITY_LIMIT_SHIFT)).map(Cause::VelocityLimit),
    |e| {
        let failed = e.fault_bits & fault_bits::DRIVER_FAILED != 0;
        e.driver_fault.or(failed.then_some(DriverError::None)).map(Cause::DriverFault)
    },
    |e| e.foreign_joint_count.map(|(reported, configured)| Cause::JointCount { reported, configured }),
    |e| (e.robot == RobotState::Stalled).then_some(Cause::RobotStalled),
    |e| e.camera_stalled.then_some(Cause::CameraStalled),
    |e| nonzero(e.saturated_joints).map(Cause::TorqueSaturated),
    |e| nonzero(e.missing_marks).map(Cause::MarksMissing),
    |e| e.guard_stop.map(Cause::Collision),
];

impl Evidence {
    /// Every cause present, in [`CONDITIONS`]' order.
    pub fn causes(&self) -> Vec<Cause> {
        CONDITIONS.iter().filter_map(|condition| condition(self)).collect()
    }

    /// The first cause that is a fault.
    pub fn first_fault(&self) -> Option<Cause> {
        CONDITIONS.iter().filter_map(|condition| condition(self)).find(|cause| cause.fault().is_some())
    }
}

/// The stops a joint move may end (nothing else keeping them): lost marks, which a joint move does not need, a
/// cell held by the user, and the collision guard's stop (the guard still stops a move towards what it is near).
const JOINT_MOVE_ENDS: [Fault; 4] = [Fault::TargetLost, Fault::StartHeld, Fault::Requested, Fault::Collision];

/// What the supervisor knows besides the messages.
#[derive(Debug, Clone, Copy)]
pub struct Conditions {
    /// CLOCK_MONOTONIC now (ns).
    pub now_ns: u64,
    /// The robot driver's state.
    pub robot: RobotState,
    /// An external robot driver (its stall is a fault; the simulated plant's is a node restart).
    pub external_robot: bool,
    /// The nodes that bring the arm to rest and move it (rmrc; the plant when simulated) run healthy.
    pub motion_nodes_healthy: bool,
    /// A stream's writer slot is held by a process that is not its writer (`supervisor::streams`).
    pub stream_taken: bool,
    /// The camera sends no frame (`supervisor::health::CameraWatch`: the vision node runs, the robot
    /// runs, and no frame came for `faults.camera_timeout_periods` vision periods).
    pub camera_stalled: bool,
}

/// What a cycle decided.
#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    /// Nothing changes.
    Same,
    /// A new fault: go to a safe stop.
    SafeStop(LatchedFault),
    /// `faults.resume = "automatic"` and no cause is left: servo again.
    ResumeAutomatically,
}

/// Why a resume is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResumeRefused {
    /// Nothing to resume from.
    #[error("the cell is not in a safe stop")]
    NotHeld,
    /// Causes are still present.
    #[error("cannot resume after {fault}: {}{}", cause_list(causes), after_lost_marks(*fault, causes))]
    CausesLeft {
        /// The latched fault.
        fault: Fault,
        /// Every cause still present.
        causes: Vec<Cause>,
    },
}

/// Why a client's safe stop is refused: the cell is held already.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("the cell is already in a safe stop ({0})")]
pub struct AlreadyHeld(pub Fault);

/// A run of joint states or twists that shows a condition: when it began and the latest stamp (ns), and
/// the joints or marks concerned.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run {
    first_ns: u64,
    last_ns: u64,
    bits: u32,
}

impl Run {
    /// The bits, once the run has lasted `at_least_s`; 0 before.
    fn lasting(run: Option<Run>, at_least_s: f64) -> u32 {
        run.filter(|r| vservo_time::seconds_between(r.last_ns, r.first_ns) >= at_least_s)
            .map_or(0, |r| r.bits)
    }
}

/// Follows the loop and latches faults.
#[derive(Debug)]
pub struct FaultMonitor {
    settings: Faults,
    /// The configured arm's joints: a driver's states of another count are a fault.
    arm_joints: u32,
    /// The latest joint state: position, velocity, saturation and driver bits as they are now.
    latest_state: Option<JointStateMsg>,
    /// Position and velocity bits and driver faults seen in any state since the last cycle (a limit crossed
    /// for a tick between two cycles counts).
    seen_bits: u32,
    /// A driver fault seen since the last cycle, with the first reason given.
    driver_fault_seen: Option<DriverError>,
    /// A stop of the collision guard seen since the last cycle (the rmrc's guard word as it began to hold).
    guard_stop_seen: Option<u32>,
    /// The latest command's guard held the arm (a stop is where that begins).
    guard_holding: bool,
    /// A joint count not the configured arm's, seen in a state since the last cycle.
    foreign_joint_count_seen: Option<u32>,
    /// The current run of saturated states.
    saturated: Option<Run>,
    /// The current run of "marks missing" twists, and which marks.
    missing: Option<Run>,
    /// The marks the latest features show, and when they came (ns).
    marks_seen: Option<(u32, u64)>,
    latched: Option<LatchedFault>,
    /// The last fault, kept for the status after a resume.
    last: Option<LatchedFault>,
    /// Since when no cause has been present (automatic resume).
    clear_since_ns: Option<u64>,
    safe_stops: u64,
}

/// A state's driver fault and its reason (an unknown reason is none: the fault stands all the same).
fn driver_fault(state: &JointStateMsg) -> Option<DriverError> {
    (DriverStatus::try_from(state.driver_status) == Ok(DriverStatus::Fault))
        .then(|| DriverError::try_from(state.driver_error).unwrap_or(DriverError::None))
}

/// The driver's reason as the fault's message gives it.
fn driver_reason(reason: DriverError) -> String {
    if reason == DriverError::None { String::new() } else { format!(": {reason}") }
}

fn nonzero(bits: u32) -> Option<u32> {
    (bits != 0).then_some(bits)
}

fn joint_list(joints: u32) -> String {
    (0..vservo_protocol::MAX_JOINTS)
        .filter(|j| joints & (1 << j) != 0)
        .map(|j| (j + 1).to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn mark_list(marks: u32) -> String {
    (0..4).filter(|m| marks & (1 << m) != 0).map(|m| (m + 1).to_string()).collect::<Vec<_>>().join(", ")
}

fn cause_list(causes: &[Cause]) -> String {
    causes.iter().map(Cause::to_string).collect::<Vec<_>>().join("; ")
}

/// The way out of a `target_lost` stop that only the lost marks keep: a joint move needs no marks.
fn after_lost_marks(fault: Fault, causes: &[Cause]) -> &'static str {
    if only_marks_missing(fault, causes) {
        "; a joint move needs no marks: `vservoctl move-joints --q …` to where the camera sees them, then \
         `vservoctl servo`"
    } else {
        ""
    }
}

/// A `target_lost` stop whose only causes left are the marks the camera does not see.
fn only_marks_missing(fault: Fault, causes: &[Cause]) -> bool {
    fault == Fault::TargetLost && causes.iter().all(|c| matches!(c, Cause::MarksMissing(_)))
}

impl FaultMonitor {
    /// A monitor under `settings`, for an arm of `arm_joints` joints.
    pub fn new(settings: Faults, arm_joints: u32) -> Self {
        Self {
            settings,
            arm_joints,
            latest_state: None,
            seen_bits: 0,
            driver_fault_seen: None,
            guard_stop_seen: None,
            guard_holding: false,
            foreign_joint_count_seen: None,
            saturated: None,
            missing: None,
            marks_seen: None,
            latched: None,
            last: None,
            clear_since_ns: None,
            safe_stops: 0,
        }
    }

    /// Takes one joint state (every one the supervisor drains, in order).
    pub fn on_joint_state(&mut self, state: &JointStateMsg) {
        self.seen_bits |= state.faults;
        if let Some(reason) = driver_fault(state) {
            // the first reason given is kept: the one that stopped the robot
            self.driver_fault_seen = match self.driver_fault_seen {
                None | Some(DriverError::None) => Some(reason),
                seen => seen,
            };
        }
        if state.joint_count != self.arm_joints {
            self.foreign_joint_count_seen = Some(state.joint_count);
        }
        let saturated = fault_bits::joints(state.faults, fault_bits::TORQUE_SATURATED_SHIFT);
        self.saturated = match (self.saturated, saturated) {
            (_, 0) => None,
            (Some(run), now) => Some(Run { last_ns: state.stamp_ns, bits: run.bits | now, ..run }),
            (None, now) => Some(Run { first_ns: state.stamp_ns, last_ns: state.stamp_ns, bits: now }),
        };
        self.latest_state = Some(*state);
    }

    /// Takes one joint command of the rmrc (every one the supervisor drains, in order): a collision guard that
    /// begins to hold the arm is a stop.
    pub fn on_joint_command(&mut self, command: &JointCommandMsg) {
        let holding = command.guard & guard_bits::HOLDING != 0;
        if holding && !self.guard_holding && self.guard_stop_seen.is_none() {
            self.guard_stop_seen = Some(command.guard);
        }
        self.guard_holding = holding;
    }

    /// Takes one twist of the servo.
    pub fn on_twist(&mut self, twist: &CameraTwistMsg) {
        // servoing on three marks is servoing; reacquiring is not: the target is lost until it is back; a
        // verdict that is none ends a run like any twist that servos
        let verdict = Verdict::try_from(twist.verdict).ok();
        let lost = matches!(verdict, Some(Verdict::MarksMissing | Verdict::Reacquiring));
        let stamp_ns = twist.stamp_ns;
        self.missing = match (self.missing, verdict) {
            (Some(run), _) if lost => Some(Run { last_ns: stamp_ns, bits: twist.missing_mask, ..run }),
            (None, _) if lost => {
                Some(Run { first_ns: stamp_ns, last_ns: stamp_ns, bits: twist.missing_mask })
            }
            // held in a safe stop, the servo does not look at the marks: the run goes on
            (run, Some(Verdict::SafeStop)) => run,
            _ => None,
        };
    }

    /// Takes one feature vector.
    pub fn on_features(&mut self, features: &FeaturesMsg, now_ns: u64) {
        self.marks_seen = Some((features.valid_mask & ALL_MARKS, now_ns));
    }

    /// The latched fault, if the cell is in a safe stop.
    pub fn latched(&self) -> Option<&LatchedFault> {
        self.latched.as_ref()
    }

    /// The latched fault, or the last one since the start.
    pub fn shown(&self) -> Option<&LatchedFault> {
        self.latched.as_ref().or(self.last.as_ref())
    }

    /// Safe stops since the start.
    pub fn safe_stops(&self) -> u64 {
        self.safe_stops
    }

    /// What was seen since the last cycle: limits crossed, driver faults, an external driver's stall,
    /// saturation and lost marks once they have lasted.
    fn seen_since_last_cycle(&self, c: &Conditions) -> Evidence {
        Evidence {
            fault_bits: self.seen_bits,
            driver_fault: self.driver_fault_seen,
            foreign_joint_count: self.foreign_joint_count_seen.map(|reported| (reported, self.arm_joints)),
            // the simulated plant's stall is a node restart, not a fault
            robot: if c.external_robot { c.robot } else { RobotState::Running },
            saturated_joints: Run::lasting(self.saturated, self.settings.saturation.as_secs_f64()),
            missing_marks: Run::lasting(self.missing, self.settings.target_lost.as_secs_f64()),
            motion_nodes_healthy: c.motion_nodes_healthy,
            stream_taken: c.stream_taken,
            camera_stalled: c.camera_stalled,
            guard_stop: self.guard_stop_seen,
        }
    }

    /// How things stand now: the latest joint state's bits, the driver's state, and — after lost marks —
    /// whether fresh features show all four.
    fn standing_now(&self, c: &Conditions) -> Evidence {
        let state = self.latest_state.as_ref();
        let bits = state.map_or(0, |s| s.faults);
        let lost_target = self.latched.as_ref().is_some_and(|f| f.code == Fault::TargetLost);
        let fresh_marks = self
            .marks_seen
            .filter(|(_, at)| c.now_ns.saturating_sub(*at) < FRESH_FEATURES_NS)
            .map_or(0, |(marks, _)| marks);
        Evidence {
            fault_bits: bits,
            driver_fault: state.and_then(driver_fault),
            foreign_joint_count: state
                .map(|s| (s.joint_count, self.arm_joints))
                .filter(|&(reported, configured)| reported != configured),
            robot: c.robot,
            saturated_joints: fault_bits::joints(bits, fault_bits::TORQUE_SATURATED_SHIFT),
            missing_marks: if lost_target { !fresh_marks & ALL_MARKS } else { 0 },
            motion_nodes_healthy: c.motion_nodes_healthy,
            stream_taken: c.stream_taken,
            camera_stalled: c.camera_stalled,
            guard_stop: None,
        }
    }

    /// Why the cell cannot servo again now: every cause still present (empty: it may resume).
    pub fn causes(&self, c: &Conditions) -> Vec<Cause> {
        self.standing_now(c).causes()
    }

    /// One supervisor cycle: latches a new fault, or (automatic policy) says the cell may resume.
    pub fn cycle(&mut self, c: &Conditions) -> Decision {
        let found = self.seen_since_last_cycle(c).first_fault();
        self.seen_bits = 0;
        self.driver_fault_seen = None;
        self.guard_stop_seen = None;
        self.foreign_joint_count_seen = None;
        if self.latched.is_none() {
            return match found {
                Some(cause) => Decision::SafeStop(self.latch(cause, c.now_ns)),
                None => Decision::Same,
            };
        }
        // a held start and a stalled supervision wait for a resume on command, whatever the policy
        let on_command_only = self
            .latched
            .as_ref()
            .is_some_and(|f| matches!(f.code, Fault::StartHeld | Fault::SupervisionStalled));
        if self.settings.resume != ResumePolicy::Automatic || on_command_only {
            return Decision::Same;
        }
        // held, the servo no longer reports the marks: whether they are back is the features' to say (causes)
        let found_now = found.is_some_and(|cause| !matches!(cause, Cause::MarksMissing(_)));
        if found_now || !self.causes(c).is_empty() {
            self.clear_since_ns = None;
            return Decision::Same;
        }
        let since = *self.clear_since_ns.get_or_insert(c.now_ns);
        if vservo_time::seconds_between(c.now_ns, since) >= self.settings.resume_after.as_secs_f64() {
            Decision::ResumeAutomatically
        } else {
            Decision::Same
        }
    }

    /// Latches the fault `cause` is (a cause that is none latches nothing and is never passed).
    fn latch(&mut self, cause: Cause, now_ns: u64) -> LatchedFault {
        let fault = LatchedFault {
            code: cause.fault().unwrap_or(Fault::Requested),
            joints: cause.joints(),
            since_ns: now_ns,
            cause,
        };
        self.latched = Some(fault.clone());
        self.clear_since_ns = None;
        self.safe_stops += 1;
        fault
    }

    /// A safe stop a client asked for. Refused (with the fault in force) when the cell is already held.
    pub fn request_safe_stop(&mut self, now_ns: u64) -> Result<LatchedFault, AlreadyHeld> {
        if let Some(fault) = &self.latched {
            return Err(AlreadyHeld(fault.code));
        }
        Ok(self.latch(Cause::Requested, now_ns))
    }

    /// The daemon slept `silent_ms` (its cycle came that late): the nodes held the arm on their own, and the
    /// fault `supervision_stalled` latches unless the cell is held already (the fault in force stays).
    pub fn supervision_stalled(&mut self, silent_ms: u64, now_ns: u64) -> Option<LatchedFault> {
        if self.latched.is_some() {
            return None;
        }
        Some(self.latch(Cause::SupervisionStalled(silent_ms), now_ns))
    }

    /// Holds the cell from its start (`robot.start = "held"`): the fault `start_held`, which only a resume on
    /// command ends.
    pub fn hold_at_start(&mut self, now_ns: u64) -> LatchedFault {
        self.latch(Cause::StartHeld, now_ns)
    }

    /// Servo again: refused, naming every cause, while one is present; the fault it ends on success.
    pub fn resume(&mut self, c: &Conditions) -> Result<LatchedFault, ResumeRefused> {
        let fault = self.latched.clone().ok_or(ResumeRefused::NotHeld)?;
        let causes = self.causes(c);
        if !causes.is_empty() {
            return Err(ResumeRefused::CausesLeft { fault: fault.code, causes });
        }
        Ok(self.unlatch(fault))
    }

    /// Out of a stop into a joint move, which needs no marks: a `target_lost` stop, or a cell held by the user
    /// (`start_held`, `requested`: a joint move is the user's own motion, as the calibration's planned, slow
    /// moves are the first motion of a held cell). Refused, naming them, while any cause but the lost marks is
    /// present, or for another fault.
    pub fn resume_into_joint_move(&mut self, c: &Conditions) -> Result<LatchedFault, ResumeRefused> {
        let fault = self.latched.clone().ok_or(ResumeRefused::NotHeld)?;
        let causes: Vec<Cause> =
            self.causes(c).into_iter().filter(|k| !matches!(k, Cause::MarksMissing(_))).collect();
        if !JOINT_MOVE_ENDS.contains(&fault.code) || !causes.is_empty() {
            return Err(ResumeRefused::CausesLeft { fault: fault.code, causes });
        }
        Ok(self.unlatch(fault))
    }

    fn unlatch(&mut self, fault: LatchedFault) -> LatchedFault {
        self.latched = None;
        self.last = Some(fault.clone());
        // the persistence of saturation and lost marks counts afresh
        self.saturated = None;
        self.missing = None;
        self.clear_since_ns = None;
        fault
    }
}

#[cfg(test)]
mod tests;
