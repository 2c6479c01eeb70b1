//! Unit tests of `faults`.

use super::*;
use vservo_protocol::{CommandMode, SCHEMA_VERSION};

const MS: u64 = 1_000_000;

fn settings(resume: ResumePolicy) -> Faults {
    Faults {
        target_lost: std::time::Duration::from_secs(1),
        saturation: std::time::Duration::from_millis(500),
        resume,
        resume_after: std::time::Duration::from_secs(2),
        camera_timeout_periods: 6,
    }
}

fn state(stamp_ns: u64, faults: u32) -> JointStateMsg {
    JointStateMsg {
        faults,
        tick: stamp_ns / MS,
        stamp_ns,
        driver_epoch: 1,
        period_ns: MS,
        command_mode: CommandMode::Torque.into(),
        driver_status: DriverStatus::Following.into(),
        ..JointStateMsg::default()
    }
}

fn twist(stamp_ns: u64, verdict: Verdict, missing_mask: u32) -> CameraTwistMsg {
    CameraTwistMsg {
        verdict: verdict.into(),
        gains_version: 1,
        stamp_ns,
        feature_error_px: 0.0,
        missing_mask,
        ..CameraTwistMsg::default()
    }
}

fn running(now_ns: u64) -> Conditions {
    Conditions {
        now_ns,
        robot: RobotState::Running,
        external_robot: false,
        motion_nodes_healthy: true,
        stream_taken: false,
        camera_stalled: false,
    }
}

#[test]
fn a_limit_crossed_for_one_tick_between_two_cycles_stops_the_cell_and_names_the_joint() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    monitor.on_joint_state(&state(MS, 0));
    monitor.on_joint_state(&state(2 * MS, 1 << (fault_bits::VELOCITY_LIMIT_SHIFT + 2)));
    monitor.on_joint_state(&state(3 * MS, 0));
    match monitor.cycle(&running(3 * MS)) {
        Decision::SafeStop(fault) => {
            assert_eq!((fault.code, fault.joints), (Fault::VelocityLimit, 0b100));
            assert!(fault.cause.to_string().contains("joint 3"), "{}", fault.cause);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(monitor.safe_stops(), 1);
    // the cause is gone: a command resumes the cell
    assert_eq!(monitor.resume(&running(4 * MS)).map(|f| f.code), Ok(Fault::VelocityLimit));
    assert!(monitor.latched().is_none());
    assert_eq!(monitor.shown().map(|f| f.code), Some(Fault::VelocityLimit));
}

#[test]
fn saturation_is_a_fault_only_once_it_lasts() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
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
        Decision::SafeStop(fault) => assert_eq!((fault.code, fault.joints), (Fault::TorqueSaturated, 1)),
        other => panic!("{other:?}"),
    }
    // still saturated: no resume, the cause named
    let refused = monitor.resume(&running(1000 * MS)).expect_err("refused");
    assert_eq!(
        refused,
        ResumeRefused::CausesLeft { fault: Fault::TorqueSaturated, causes: vec![Cause::TorqueSaturated(1)] }
    );
    assert!(refused.to_string().contains("joint 1 torque is at its limit"), "{refused}");
}

#[test]
fn lost_marks_stop_the_cell_after_the_set_time_and_it_resumes_when_they_are_seen() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    monitor.on_twist(&twist(0, Verdict::MarksMissing, 0b0100));
    monitor.on_twist(&twist(900 * MS, Verdict::MarksMissing, 0b0100));
    assert_eq!(monitor.cycle(&running(900 * MS)), Decision::Same);
    monitor.on_twist(&twist(1000 * MS, Verdict::MarksMissing, 0b0100));
    match monitor.cycle(&running(1000 * MS)) {
        Decision::SafeStop(fault) => {
            assert_eq!(fault.code, Fault::TargetLost);
            assert!(fault.cause.to_string().contains("mark 3"), "{}", fault.cause);
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
        base_from_camera: [f64::NAN; 12],
        ..FeaturesMsg::default()
    };
    monitor.on_features(&features, 1100 * MS);
    let refused = monitor.resume(&running(1100 * MS)).expect_err("refused");
    assert_eq!(
        refused,
        ResumeRefused::CausesLeft { fault: Fault::TargetLost, causes: vec![Cause::MarksMissing(0b0100)] }
    );
    assert!(refused.to_string().contains("four marks"), "{refused}");
    // the way out it names: a joint move, which needs no marks
    assert!(refused.to_string().contains("vservoctl move-joints"), "{refused}");
    features.valid_mask = 0b1111;
    monitor.on_features(&features, 1200 * MS);
    assert!(monitor.resume(&running(1200 * MS)).is_ok());
    // a frame with marks again ends the run; losing them later counts afresh
    monitor.on_twist(&twist(1300 * MS, Verdict::Servoing, 0));
    monitor.on_twist(&twist(1400 * MS, Verdict::MarksMissing, 1));
    assert_eq!(monitor.cycle(&running(1400 * MS)), Decision::Same);
}

#[test]
fn a_joint_move_ends_a_target_lost_stop_that_only_the_lost_marks_keep() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    monitor.on_twist(&twist(0, Verdict::MarksMissing, 0b1111));
    monitor.on_twist(&twist(1000 * MS, Verdict::MarksMissing, 0b1111));
    assert!(matches!(
        monitor.cycle(&running(1000 * MS)),
        Decision::SafeStop(LatchedFault { code: Fault::TargetLost, .. })
    ));
    // another cause present: refused, naming it (and not the marks, which a joint move does not need)
    let camera_stalled = Conditions { camera_stalled: true, ..running(1100 * MS) };
    assert_eq!(
        monitor.resume_into_joint_move(&camera_stalled),
        Err(ResumeRefused::CausesLeft { fault: Fault::TargetLost, causes: vec![Cause::CameraStalled] })
    );
    assert!(monitor.latched().is_some());
    assert_eq!(monitor.resume_into_joint_move(&running(1100 * MS)).map(|f| f.code), Ok(Fault::TargetLost));
    assert!(monitor.latched().is_none());
    // a cell held by the user is left this way too (the daemon asks only for a move out of the hold)
    assert!(monitor.request_safe_stop(1200 * MS).is_ok());
    assert_eq!(monitor.resume_into_joint_move(&running(1200 * MS)).map(|f| f.code), Ok(Fault::Requested));
    let mut held = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    held.hold_at_start(0);
    assert_eq!(held.resume_into_joint_move(&running(MS)).map(|f| f.code), Ok(Fault::StartHeld));
    // another fault is not left this way
    let stalled = Conditions { robot: RobotState::Stalled, external_robot: true, ..running(2000 * MS) };
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    assert!(matches!(monitor.cycle(&stalled), Decision::SafeStop(_)));
    assert!(monitor.resume_into_joint_move(&running(2100 * MS)).is_err());
}

#[test]
fn a_stalled_driver_is_a_fault_of_an_external_one_only() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    let stalled = Conditions { robot: RobotState::Stalled, ..running(MS) };
    assert_eq!(monitor.cycle(&stalled), Decision::Same, "the simulated plant's restart is no fault");
    let external = Conditions { external_robot: true, ..stalled };
    assert!(matches!(
        monitor.cycle(&external),
        Decision::SafeStop(LatchedFault { code: Fault::RobotStalled, .. })
    ));
    let refused = monitor.resume(&external).expect_err("refused while stalled");
    assert!(refused.to_string().contains("do not arrive"), "{refused}");
    assert!(monitor.resume(&Conditions { robot: RobotState::Running, ..external }).is_ok());
}

/// A driver of another arm (seven joints where the configuration has six) stops the cell, saying so, and
/// keeps it from resuming while its states say so.
#[test]
fn a_driver_of_another_joint_count_is_a_driver_fault_that_says_so() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    monitor.on_joint_state(&JointStateMsg { joint_count: 7, ..state(MS, 0) });
    let Decision::SafeStop(latched) = monitor.cycle(&running(MS)) else { panic!("a safe stop") };
    assert_eq!(latched.code, Fault::DriverFault);
    let refused = monitor.resume(&running(2 * MS)).expect_err("refused while it reports 7");
    assert!(refused.to_string().contains("reports 7 joints; the configured arm has 6"), "{refused}");
    monitor.on_joint_state(&state(3 * MS, 0));
    assert!(monitor.resume(&running(3 * MS)).is_ok());
}

/// A driver's fault with the robot's reason (a Franka reflex) is latched with that reason, which the
/// fault's message names; the first reason given is the one kept.
#[test]
fn a_driver_fault_keeps_the_robots_reason() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    let mut faulted = state(MS, 0);
    faulted.driver_status = DriverStatus::Fault.into();
    faulted.driver_error = DriverError::FrankaCommunicationConstraintsViolation.into();
    monitor.on_joint_state(&faulted);
    faulted.driver_error = DriverError::FrankaJointReflex.into();
    monitor.on_joint_state(&faulted);
    let Decision::SafeStop(latched) = monitor.cycle(&running(MS)) else { panic!("a safe stop") };
    assert_eq!(latched.cause, Cause::DriverFault(DriverError::FrankaCommunicationConstraintsViolation));
    assert_eq!(
        latched.cause.to_string(),
        "the robot driver reports a fault: communication_constraints_violation"
    );
    // a number that is no reason still faults
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    faulted.driver_error = 7;
    monitor.on_joint_state(&faulted);
    let Decision::SafeStop(latched) = monitor.cycle(&running(MS)) else { panic!("a safe stop") };
    assert_eq!(latched.cause, Cause::DriverFault(DriverError::None));
}

#[test]
fn the_automatic_policy_resumes_once_the_cause_has_been_gone_long_enough() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Automatic), 6);
    let mut faulted = state(MS, 0);
    faulted.driver_status = DriverStatus::Fault.into();
    monitor.on_joint_state(&faulted);
    assert!(matches!(
        monitor.cycle(&running(MS)),
        Decision::SafeStop(LatchedFault { code: Fault::DriverFault, .. })
    ));
    // still faulted: no resume however long
    monitor.on_joint_state(&faulted);
    assert_eq!(monitor.cycle(&running(5000 * MS)), Decision::Same);
    monitor.on_joint_state(&state(5001 * MS, 0));
    assert_eq!(monitor.cycle(&running(5001 * MS)), Decision::Same);
    assert_eq!(monitor.cycle(&running(6000 * MS)), Decision::Same);
    assert_eq!(monitor.cycle(&running(7001 * MS)), Decision::ResumeAutomatically);
    // a command policy never resumes by itself
    let mut manual = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    assert!(manual.request_safe_stop(0).is_ok());
    assert_eq!(manual.request_safe_stop(1), Err(AlreadyHeld(Fault::Requested)), "already held");
    assert_eq!(manual.cycle(&running(100_000 * MS)), Decision::Same);
    assert!(manual.latched().is_some());
    assert_eq!(manual.resume(&running(0)).map(|f| f.code), Ok(Fault::Requested));
    assert_eq!(manual.resume(&running(0)), Err(ResumeRefused::NotHeld));
}

#[test]
fn a_stalled_supervision_latches_unless_held_and_only_a_resume_on_command_ends_it() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Automatic), 6);
    let latched = monitor.supervision_stalled(1200, MS).expect("latched");
    assert_eq!((latched.code, latched.cause), (Fault::SupervisionStalled, Cause::SupervisionStalled(1200)));
    assert!(latched.cause.to_string().contains("1200 ms"), "{}", latched.cause);
    // the cause is gone at once, but even the automatic policy waits for a resume on command
    monitor.on_joint_state(&state(2 * MS, 0));
    assert_eq!(monitor.cycle(&running(100_000 * MS)), Decision::Same);
    assert_eq!(monitor.resume(&running(0)).map(|f| f.code), Ok(Fault::SupervisionStalled));
    // held already: the fault in force stays
    assert!(monitor.request_safe_stop(0).is_ok());
    assert_eq!(monitor.supervision_stalled(1500, MS), None);
    assert_eq!(monitor.latched().map(|f| f.code), Some(Fault::Requested));
}

#[test]
fn each_condition_finds_its_cause_and_only_faults_stop_the_cell() {
    let calm = Evidence {
        fault_bits: 0,
        driver_fault: None,
        foreign_joint_count: None,
        robot: RobotState::Running,
        saturated_joints: 0,
        missing_marks: 0,
        motion_nodes_healthy: true,
        stream_taken: false,
        camera_stalled: false,
        guard_stop: None,
    };
    assert_eq!(calm.causes(), vec![]);
    let cases = [
        (Evidence { motion_nodes_healthy: false, ..calm }, Cause::MotionNodesDown, None),
        (Evidence { robot: RobotState::Waiting, ..calm }, Cause::RobotWaiting, None),
        (
            Evidence { fault_bits: 0b10_0000, ..calm },
            Cause::PositionLimit(0b10_0000),
            Some(Fault::PositionLimit),
        ),
        (
            Evidence { fault_bits: 0b1 << fault_bits::VELOCITY_LIMIT_SHIFT, ..calm },
            Cause::VelocityLimit(1),
            Some(Fault::VelocityLimit),
        ),
        (
            Evidence { driver_fault: Some(DriverError::None), ..calm },
            Cause::DriverFault(DriverError::None),
            Some(Fault::DriverFault),
        ),
        (
            Evidence { foreign_joint_count: Some((7, 6)), ..calm },
            Cause::JointCount { reported: 7, configured: 6 },
            Some(Fault::DriverFault),
        ),
        (
            Evidence { fault_bits: fault_bits::DRIVER_FAILED, ..calm },
            Cause::DriverFault(DriverError::None),
            Some(Fault::DriverFault),
        ),
        (Evidence { robot: RobotState::Stalled, ..calm }, Cause::RobotStalled, Some(Fault::RobotStalled)),
        (Evidence { stream_taken: true, ..calm }, Cause::StreamTaken, Some(Fault::StreamTaken)),
        (Evidence { camera_stalled: true, ..calm }, Cause::CameraStalled, Some(Fault::CameraStalled)),
        (
            Evidence { saturated_joints: 0b11, ..calm },
            Cause::TorqueSaturated(0b11),
            Some(Fault::TorqueSaturated),
        ),
        (Evidence { missing_marks: 0b1000, ..calm }, Cause::MarksMissing(0b1000), Some(Fault::TargetLost)),
        (Evidence { guard_stop: Some(0b1110), ..calm }, Cause::Collision(0b1110), Some(Fault::Collision)),
    ];
    for (evidence, cause, fault) in cases {
        assert_eq!(evidence.causes(), vec![cause], "{evidence:?}");
        assert_eq!(cause.fault(), fault);
        assert_eq!(evidence.first_fault(), fault.map(|_| cause));
    }
    // several at once: the position limit is the fault, every cause is named
    let many = Evidence { motion_nodes_healthy: false, robot: RobotState::Stalled, fault_bits: 1, ..calm };
    assert_eq!(many.first_fault(), Some(Cause::PositionLimit(1)));
    assert_eq!(many.causes(), vec![Cause::MotionNodesDown, Cause::PositionLimit(1), Cause::RobotStalled]);
    assert_eq!(Cause::PositionLimit(0b101).to_string(), "joint 1, 3 is beyond its position range");
}

#[test]
fn a_stalled_camera_stops_the_cell_and_keeps_a_resume_back_until_frames_come_again() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Automatic), 6);
    let stalled = Conditions { camera_stalled: true, ..running(MS) };
    match monitor.cycle(&stalled) {
        Decision::SafeStop(fault) => {
            assert_eq!(fault.code, Fault::CameraStalled);
            assert!(fault.cause.to_string().contains("no frame"), "{}", fault.cause);
        }
        other => panic!("{other:?}"),
    }
    let refused = monitor.resume(&stalled).expect_err("still no frame");
    assert_eq!(
        refused,
        ResumeRefused::CausesLeft { fault: Fault::CameraStalled, causes: vec![Cause::CameraStalled] }
    );
    // frames again: the automatic policy resumes once they have come for resume_after_s
    assert_eq!(monitor.cycle(&running(2 * MS)), Decision::Same);
    assert_eq!(monitor.cycle(&running(2003 * MS)), Decision::ResumeAutomatically);
}

#[test]
fn the_nodes_that_move_the_arm_keep_a_resume_back_until_they_run() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    assert!(monitor.request_safe_stop(0).is_ok());
    let down = Conditions { motion_nodes_healthy: false, ..running(MS) };
    assert_eq!(monitor.cycle(&down), Decision::Same, "a node down is no fault of its own");
    assert!(matches!(
        monitor.resume(&down),
        Err(ResumeRefused::CausesLeft { causes, .. }) if causes == vec![Cause::MotionNodesDown]
    ));
    let waiting = Conditions { robot: RobotState::Waiting, ..running(MS) };
    assert!(monitor.resume(&waiting).expect_err("no state yet").to_string().contains("no joint state"));
    assert!(monitor.resume(&running(MS)).is_ok());
}

/// The collision guard's stop: the first command whose guard holds the arm stops the cell, naming the distance;
/// the commands that still hold it before the rmrc hears the resume do not stop it again, nor keep it from
/// resuming (the guard itself refuses motions towards); a new hold after a release is a new stop.
#[test]
fn the_guard_beginning_to_hold_the_arm_is_a_collision_stop_that_a_resume_clears() {
    let mut monitor = FaultMonitor::new(settings(ResumePolicy::Command), 6);
    let command = |guard: u32| JointCommandMsg { guard, ..Default::default() };
    let holding = guard_bits::word(false, true, Some(guard_bits::Distance::Pair(3)));
    monitor.on_joint_state(&state(MS, 0));
    monitor.on_joint_command(&command(guard_bits::SLOWING));
    assert_eq!(monitor.cycle(&running(2 * MS)), Decision::Same, "slowing is no stop");
    monitor.on_joint_command(&command(holding));
    match monitor.cycle(&running(3 * MS)) {
        Decision::SafeStop(fault) => {
            assert_eq!((fault.code, fault.cause), (Fault::Collision, Cause::Collision(holding)));
            assert_eq!(guard_bits::distance(holding), Some(guard_bits::Distance::Pair(3)));
        }
        other => panic!("{other:?}"),
    }
    monitor.on_joint_command(&command(holding));
    assert_eq!(monitor.causes(&running(4 * MS)), vec![], "nothing keeps the cell from resuming");
    assert_eq!(monitor.resume(&running(4 * MS)).map(|f| f.code), Ok(Fault::Collision));
    // the rmrc has not heard the resume yet: still holding, no new stop
    monitor.on_joint_command(&command(holding));
    assert_eq!(monitor.cycle(&running(5 * MS)), Decision::Same);
    // released, then holding again: a new stop
    monitor.on_joint_command(&command(0));
    monitor.on_joint_command(&command(holding));
    assert!(matches!(monitor.cycle(&running(6 * MS)), Decision::SafeStop(_)));
}
