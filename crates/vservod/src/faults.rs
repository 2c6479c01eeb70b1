//! The fault reaction's decisions, apart from any I/O: what the loop published goes in (every joint state,
//! twist and feature vector the supervisor drains), and out comes whether the cell must go to a safe stop,
//! which fault and since when, and whether it may servo again.
//!
//! At once: a joint beyond its position range or its velocity limit, a driver that reports a fault, an
//! external driver that stalled. Once they last: a torque cut to its limit (`faults.saturation_s`), marks
//! missing so that the servo cannot servo (`faults.target_lost_s`). The first fault is latched; the cell
//! resumes on a command, or by itself under `faults.resume = "automatic"`, only once no cause is left.

use vservo_config::{Faults, ResumePolicy};
use vservo_protocol::{
    CameraTwistMsg, FeaturesMsg, JointStateMsg, driver_status, fault, fault_bits, robot_state, verdict,
};

/// Six bits, one per joint.
const JOINT_BITS: u32 = 0x3f;

/// A latched fault.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    /// [`fault`] code.
    pub code: u32,
    /// The joints it concerns (bit j: joint j + 1).
    pub joints: u32,
    /// CLOCK_MONOTONIC (ns) when it was found.
    pub since_ns: u64,
    /// What was seen, for the log.
    pub detail: String,
}

/// What the supervisor knows besides the messages.
#[derive(Debug, Clone, Copy)]
pub struct Conditions {
    /// CLOCK_MONOTONIC now (ns).
    pub now_ns: u64,
    /// [`robot_state`].
    pub robot: u32,
    /// An external robot driver (its stall is a fault; the simulated plant's is a node restart).
    pub external_robot: bool,
    /// The nodes that bring the arm to rest and move it (rmrc; the plant when simulated) run healthy.
    pub motion_nodes_healthy: bool,
}

/// What a cycle decided.
#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    /// Nothing changes.
    Same,
    /// A new fault: go to a safe stop.
    SafeStop(Fault),
    /// `faults.resume = "automatic"` and no cause is left: servo again.
    ResumeAutomatically,
}

/// Follows the loop and latches faults.
#[derive(Debug)]
pub struct FaultMonitor {
    settings: Faults,
    /// The latest joint state: position, velocity, saturation and driver bits as they are now.
    latest_state: Option<JointStateMsg>,
    /// Position and velocity bits and driver faults seen in any state since the last cycle (a limit crossed
    /// for a tick between two cycles counts).
    seen_bits: u32,
    driver_fault_seen: bool,
    /// The stamp where the current run of saturated states began, and the last one.
    saturated: Option<(u64, u64, u32)>,
    /// The stamp where the current run of "marks missing" twists began, the last one, and which marks.
    missing: Option<(u64, u64, u32)>,
    /// Whether the latest features show all four marks, and when they came (ns).
    marks_seen: Option<(bool, u64)>,
    latched: Option<Fault>,
    /// The last fault, kept for the status after a resume.
    last: Option<Fault>,
    /// Since when no cause has been present (automatic resume).
    clear_since_ns: Option<u64>,
    safe_stops: u64,
}

fn joints_of(bits: u32, shift: u32) -> u32 {
    (bits >> shift) & JOINT_BITS
}

fn joint_list(joints: u32) -> String {
    (0..6).filter(|j| joints & (1 << j) != 0).map(|j| (j + 1).to_string()).collect::<Vec<_>>().join(", ")
}

impl FaultMonitor {
    /// A monitor under `settings`.
    pub fn new(settings: Faults) -> Self {
        Self {
            settings,
            latest_state: None,
            seen_bits: 0,
            driver_fault_seen: false,
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
        self.driver_fault_seen |= state.driver_status == driver_status::FAULT;
        let saturated = joints_of(state.faults, fault_bits::TORQUE_SATURATED_SHIFT);
        self.saturated = match (self.saturated, saturated) {
            (_, 0) => None,
            (Some((first, _, joints)), now) => Some((first, state.stamp_ns, joints | now)),
            (None, now) => Some((state.stamp_ns, state.stamp_ns, now)),
        };
        self.latest_state = Some(*state);
    }

    /// Takes one twist of the servo.
    pub fn on_twist(&mut self, twist: &CameraTwistMsg) {
        // servoing on three marks is servoing; reacquiring is not: the target is lost until it is back
        let lost = matches!(twist.verdict, verdict::MARKS_MISSING | verdict::REACQUIRING);
        self.missing = match (self.missing, twist.verdict) {
            (Some((first, _, _)), _) if lost => Some((first, twist.stamp_ns, twist.missing_mask)),
            (None, _) if lost => Some((twist.stamp_ns, twist.stamp_ns, twist.missing_mask)),
            // held in a safe stop, the servo does not look at the marks: the run goes on
            (run, verdict::SAFE_STOP) => run,
            _ => None,
        };
    }

    /// Takes one feature vector.
    pub fn on_features(&mut self, features: &FeaturesMsg, now_ns: u64) {
        self.marks_seen = Some((features.valid_mask == 0b1111, now_ns));
    }

    /// The latched fault, if the cell is in a safe stop.
    pub fn latched(&self) -> Option<&Fault> {
        self.latched.as_ref()
    }

    /// The latched fault, or the last one since the start.
    pub fn shown(&self) -> Option<&Fault> {
        self.latched.as_ref().or(self.last.as_ref())
    }

    /// Safe stops since the start.
    pub fn safe_stops(&self) -> u64 {
        self.safe_stops
    }

    /// The fault found this cycle, if any (the first in the order below).
    fn detect(&self, c: &Conditions) -> Option<(u32, u32, String)> {
        let position = joints_of(self.seen_bits, fault_bits::POSITION_LIMIT_SHIFT);
        if position != 0 {
            return Some((
                fault::POSITION_LIMIT,
                position,
                format!("joint {} beyond its position range", joint_list(position)),
            ));
        }
        let velocity = joints_of(self.seen_bits, fault_bits::VELOCITY_LIMIT_SHIFT);
        if velocity != 0 {
            return Some((
                fault::VELOCITY_LIMIT,
                velocity,
                format!("joint {} faster than its velocity limit", joint_list(velocity)),
            ));
        }
        if self.driver_fault_seen || self.seen_bits & fault_bits::DRIVER_FAILED != 0 {
            return Some((fault::DRIVER_FAULT, 0, "the robot driver reports a fault".into()));
        }
        if c.external_robot && c.robot == robot_state::STALLED {
            return Some((
                fault::ROBOT_STALLED,
                0,
                "no joint state from the robot driver within its deadline".into(),
            ));
        }
        if let Some((first, last, joints)) = self.saturated {
            let lasted_s = last.saturating_sub(first) as f64 / 1e9;
            if lasted_s >= self.settings.saturation_s {
                return Some((
                    fault::TORQUE_SATURATED,
                    joints,
                    format!("joint {} torque at its limit for {lasted_s:.2} s", joint_list(joints)),
                ));
            }
        }
        if let Some((first, last, marks)) = self.missing {
            let lasted_s = last.saturating_sub(first) as f64 / 1e9;
            if lasted_s >= self.settings.target_lost_s {
                let list =
                    (0..4).filter(|m| marks & (1 << m) != 0).map(|m| (m + 1).to_string()).collect::<Vec<_>>();
                return Some((
                    fault::TARGET_LOST,
                    0,
                    format!("mark {} missing for {lasted_s:.2} s", list.join(", ")),
                ));
            }
        }
        None
    }

    /// Why the cell cannot servo again now: every cause still present (empty: it may resume).
    pub fn causes(&self, c: &Conditions) -> Vec<String> {
        let mut causes = Vec::new();
        if !c.motion_nodes_healthy {
            causes.push("the nodes that move the arm are not all running".to_string());
        }
        match c.robot {
            robot_state::RUNNING => {}
            robot_state::STALLED => causes.push("the robot driver's joint states do not arrive".into()),
            _ => causes.push("no joint state from the robot driver yet".into()),
        }
        if let Some(state) = &self.latest_state {
            let position = joints_of(state.faults, fault_bits::POSITION_LIMIT_SHIFT);
            if position != 0 {
                causes.push(format!("joint {} is beyond its position range", joint_list(position)));
            }
            let velocity = joints_of(state.faults, fault_bits::VELOCITY_LIMIT_SHIFT);
            if velocity != 0 {
                causes.push(format!("joint {} is over its velocity limit", joint_list(velocity)));
            }
            if state.driver_status == driver_status::FAULT || state.faults & fault_bits::DRIVER_FAILED != 0 {
                causes.push("the robot driver reports a fault".into());
            }
            let saturated = joints_of(state.faults, fault_bits::TORQUE_SATURATED_SHIFT);
            if saturated != 0 {
                causes.push(format!("joint {} torque is at its limit", joint_list(saturated)));
            }
        }
        if self.latched.as_ref().is_some_and(|f| f.code == fault::TARGET_LOST) {
            // fresh features (within a second) with all four marks
            let seen =
                self.marks_seen.is_some_and(|(all, at)| all && c.now_ns.saturating_sub(at) < 1_000_000_000);
            if !seen {
                causes.push("the camera does not see all four marks".into());
            }
        }
        causes
    }

    /// One supervisor cycle: latches a new fault, or (automatic policy) says the cell may resume.
    pub fn cycle(&mut self, c: &Conditions) -> Decision {
        let found = self.detect(c);
        self.seen_bits = 0;
        self.driver_fault_seen = false;
        if self.latched.is_none() {
            return match found {
                Some((code, joints, detail)) => {
                    let fault = Fault { code, joints, since_ns: c.now_ns, detail };
                    self.latch(fault.clone());
                    Decision::SafeStop(fault)
                }
                None => Decision::Same,
            };
        }
        if self.settings.resume != ResumePolicy::Automatic {
            return Decision::Same;
        }
        // held, the servo no longer reports the marks: whether they are back is the features' to say (causes)
        let found_now = found.is_some_and(|(code, _, _)| code != fault::TARGET_LOST);
        if found_now || !self.causes(c).is_empty() {
            self.clear_since_ns = None;
            return Decision::Same;
        }
        let since = *self.clear_since_ns.get_or_insert(c.now_ns);
        if c.now_ns.saturating_sub(since) as f64 / 1e9 >= self.settings.resume_after_s {
            Decision::ResumeAutomatically
        } else {
            Decision::Same
        }
    }

    fn latch(&mut self, fault: Fault) {
        self.latched = Some(fault);
        self.clear_since_ns = None;
        self.safe_stops += 1;
    }

    /// A safe stop a client asked for. Refused (with the fault in force) when the cell is already held.
    pub fn request_safe_stop(&mut self, now_ns: u64) -> Result<Fault, String> {
        if let Some(fault) = &self.latched {
            return Err(format!("the cell is already in a safe stop ({})", fault::name(fault.code)));
        }
        let fault = Fault {
            code: fault::REQUESTED,
            joints: 0,
            since_ns: now_ns,
            detail: "asked for by a client".into(),
        };
        self.latch(fault.clone());
        Ok(fault)
    }

    /// Servo again: refused, naming every cause, while one is present; the fault it ends on success.
    pub fn resume(&mut self, c: &Conditions) -> Result<Fault, String> {
        let Some(fault) = self.latched.clone() else {
            return Err("the cell is not in a safe stop".into());
        };
        let causes = self.causes(c);
        if !causes.is_empty() {
            return Err(format!("cannot resume after {}: {}", fault::name(fault.code), causes.join("; ")));
        }
        self.latched = None;
        self.last = Some(fault.clone());
        // the persistence of saturation and lost marks counts afresh
        self.saturated = None;
        self.missing = None;
        self.clear_since_ns = None;
        Ok(fault)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_protocol::{SCHEMA_VERSION, command_mode};

    const MS: u64 = 1_000_000;

    fn settings(resume: ResumePolicy) -> Faults {
        Faults { target_lost_s: 1.0, saturation_s: 0.5, resume, resume_after_s: 2.0 }
    }

    fn state(stamp_ns: u64, faults: u32) -> JointStateMsg {
        JointStateMsg {
            schema: SCHEMA_VERSION,
            faults,
            tick: stamp_ns / MS,
            stamp_ns,
            driver_epoch: 1,
            period_ns: MS,
            command_mode: command_mode::TORQUE,
            driver_status: driver_status::FOLLOWING,
            q_rad: [0.0; 6],
            qd_rad_s: [0.0; 6],
            torque_nm: [0.0; 6],
            applied_command_tick: u64::MAX,
        }
    }

    fn twist(stamp_ns: u64, verdict_code: u32, missing_mask: u32) -> CameraTwistMsg {
        CameraTwistMsg {
            schema: SCHEMA_VERSION,
            verdict: verdict_code,
            frame: 0,
            capture_tick: 0,
            gains_version: 1,
            stamp_ns,
            twist: [0.0; 6],
            feature_error_px: 0.0,
            missing_mask,
            law_flags: 0,
        }
    }

    fn running(now_ns: u64) -> Conditions {
        Conditions { now_ns, robot: robot_state::RUNNING, external_robot: false, motion_nodes_healthy: true }
    }

    #[test]
    fn a_limit_crossed_for_one_tick_between_two_cycles_stops_the_cell_and_names_the_joint() {
        let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command));
        monitor.on_joint_state(&state(MS, 0));
        monitor.on_joint_state(&state(2 * MS, 1 << (fault_bits::VELOCITY_LIMIT_SHIFT + 2)));
        monitor.on_joint_state(&state(3 * MS, 0));
        match monitor.cycle(&running(3 * MS)) {
            Decision::SafeStop(fault) => {
                assert_eq!((fault.code, fault.joints), (fault::VELOCITY_LIMIT, 0b100));
                assert!(fault.detail.contains("joint 3"), "{}", fault.detail);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(monitor.safe_stops(), 1);
        // the cause is gone: a command resumes the cell
        assert_eq!(monitor.resume(&running(4 * MS)).map(|f| f.code), Ok(fault::VELOCITY_LIMIT));
        assert!(monitor.latched().is_none());
        assert_eq!(monitor.shown().map(|f| f.code), Some(fault::VELOCITY_LIMIT));
    }

    #[test]
    fn saturation_is_a_fault_only_once_it_lasts() {
        let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command));
        let saturated = 1 << fault_bits::TORQUE_SATURATED_SHIFT;
        // 0.4 s of saturation, a tick free, 0.4 s again: no fault
        for t in 0..400 {
            monitor.on_joint_state(&state(t * MS, saturated));
        }
        monitor.on_joint_state(&state(400 * MS, 0));
        for t in 401..800 {
            monitor.on_joint_state(&state(t * MS, saturated));
        }
        assert_eq!(monitor.cycle(&running(800 * MS)), Decision::Same);
        for t in 800..1000 {
            monitor.on_joint_state(&state(t * MS, saturated));
        }
        match monitor.cycle(&running(1000 * MS)) {
            Decision::SafeStop(fault) => assert_eq!((fault.code, fault.joints), (fault::TORQUE_SATURATED, 1)),
            other => panic!("{other:?}"),
        }
        // still saturated: no resume, the cause named
        let refused = monitor.resume(&running(1000 * MS)).expect_err("refused");
        assert!(refused.contains("joint 1 torque is at its limit"), "{refused}");
    }

    #[test]
    fn lost_marks_stop_the_cell_after_the_set_time_and_it_resumes_when_they_are_seen() {
        let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command));
        monitor.on_twist(&twist(0, verdict::MARKS_MISSING, 0b0100));
        monitor.on_twist(&twist(900 * MS, verdict::MARKS_MISSING, 0b0100));
        assert_eq!(monitor.cycle(&running(900 * MS)), Decision::Same);
        monitor.on_twist(&twist(1000 * MS, verdict::MARKS_MISSING, 0b0100));
        match monitor.cycle(&running(1000 * MS)) {
            Decision::SafeStop(fault) => {
                assert_eq!(fault.code, fault::TARGET_LOST);
                assert!(fault.detail.contains("mark 3"), "{}", fault.detail);
            }
            other => panic!("{other:?}"),
        }
        let mut features = FeaturesMsg {
            schema: SCHEMA_VERSION,
            valid_mask: 0b1011,
            frame: 1,
            capture_tick: 0,
            capture_stamp_ns: 0,
            stamp_ns: 0,
            features_px: [0.0; 8],
            mark_status: [0; 4],
            reserved: [0; 4],
            base_from_camera: [f64::NAN; 12],
        };
        monitor.on_features(&features, 1100 * MS);
        assert!(monitor.resume(&running(1100 * MS)).expect_err("refused").contains("four marks"));
        features.valid_mask = 0b1111;
        monitor.on_features(&features, 1200 * MS);
        assert!(monitor.resume(&running(1200 * MS)).is_ok());
        // a frame with marks again ends the run; losing them later counts afresh
        monitor.on_twist(&twist(1300 * MS, verdict::SERVOING, 0));
        monitor.on_twist(&twist(1400 * MS, verdict::MARKS_MISSING, 1));
        assert_eq!(monitor.cycle(&running(1400 * MS)), Decision::Same);
    }

    #[test]
    fn a_stalled_driver_is_a_fault_of_an_external_one_only() {
        let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command));
        let stalled = Conditions { robot: robot_state::STALLED, ..running(MS) };
        assert_eq!(monitor.cycle(&stalled), Decision::Same, "the simulated plant's restart is no fault");
        let external = Conditions { external_robot: true, ..stalled };
        assert!(matches!(
            monitor.cycle(&external),
            Decision::SafeStop(Fault { code: fault::ROBOT_STALLED, .. })
        ));
        let refused = monitor.resume(&external).expect_err("refused while stalled");
        assert!(refused.contains("do not arrive"), "{refused}");
        assert!(monitor.resume(&Conditions { robot: robot_state::RUNNING, ..external }).is_ok());
    }

    #[test]
    fn the_automatic_policy_resumes_once_the_cause_has_been_gone_long_enough() {
        let mut monitor = FaultMonitor::new(settings(ResumePolicy::Automatic));
        let mut faulted = state(MS, 0);
        faulted.driver_status = driver_status::FAULT;
        monitor.on_joint_state(&faulted);
        assert!(matches!(
            monitor.cycle(&running(MS)),
            Decision::SafeStop(Fault { code: fault::DRIVER_FAULT, .. })
        ));
        // still faulted: no resume however long
        monitor.on_joint_state(&faulted);
        assert_eq!(monitor.cycle(&running(5000 * MS)), Decision::Same);
        monitor.on_joint_state(&state(5001 * MS, 0));
        assert_eq!(monitor.cycle(&running(5001 * MS)), Decision::Same);
        assert_eq!(monitor.cycle(&running(6000 * MS)), Decision::Same);
        assert_eq!(monitor.cycle(&running(7001 * MS)), Decision::ResumeAutomatically);
        // a command policy never resumes by itself
        let mut manual = FaultMonitor::new(settings(ResumePolicy::Command));
        assert!(manual.request_safe_stop(0).is_ok());
        assert!(manual.request_safe_stop(1).is_err(), "already held");
        assert_eq!(manual.cycle(&running(100_000 * MS)), Decision::Same);
        assert!(manual.latched().is_some());
    }
}
