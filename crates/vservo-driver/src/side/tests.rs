//! The driver side's rules, each tried against what breaks it.

use super::*;

const MS: u64 = 1_000_000;

fn key() -> SealKey {
    SealKey::from_hex(b"000102030405060708090a0b0c0d0e0f").expect("a key")
}

fn side() -> DriverSide {
    let settings = DriverSettings {
        mode: CommandMode::Velocity,
        joint_count: 7,
        period_ns: MS,
        hold_after_ns: 20 * MS,
        position_min_rad: [-2.0; MAX_JOINTS],
        position_max_rad: [2.0; MAX_JOINTS],
        velocity_max_rad_s: [1.0; MAX_JOINTS],
        braking_gain_rad_s: [speed_gained_braking(10.0, 5000.0); MAX_JOINTS],
    };
    DriverSide::new(settings, 42, Some(key()))
}

fn sealed(mut command: JointCommandMsg) -> JointCommandMsg {
    key().sign(&mut command);
    command
}

fn mode(mode: CellMode, sequence: u64) -> CellModeMsg {
    let mut message =
        CellModeMsg { schema: SCHEMA_VERSION, mode: mode.code(), sequence, ..CellModeMsg::default() };
    key().sign(&mut message);
    message
}

fn at_rest() -> Measured {
    Measured { q_rad: [0.0; MAX_JOINTS], qd_rad_s: [0.0; MAX_JOINTS], torque_nm: [f64::NAN; MAX_JOINTS] }
}

fn command(answers_tick: u64, qd: f64) -> JointCommandMsg {
    sealed(JointCommandMsg {
        schema: SCHEMA_VERSION,
        mode: CommandMode::Velocity.code(),
        joint_count: 7,
        answers_tick,
        driver_epoch: 42,
        qd_ref_rad_s: [qd; MAX_JOINTS],
        ..JointCommandMsg::default()
    })
}

#[test]
fn a_command_is_taken_only_within_the_one_age_window_and_of_this_run() {
    let mut side = side();
    assert_eq!(
        side.take_command(&command(0, 0.1), 0),
        Err(CommandRefused::NotPublished { answers: 0, last_tick: None })
    );
    for tick in 0..10 {
        side.joint_state(tick, tick * MS, &at_rest(), None);
    }
    assert!(side.take_command(&command(9, 0.1), 10 * MS).is_ok());
    assert!(side.take_command(&command(7, 0.1), 10 * MS).is_ok(), "two ticks old");
    assert_eq!(
        side.take_command(&command(6, 0.1), 0),
        Err(CommandRefused::TooOld { answers: 6, last_tick: 9 })
    );
    assert!(matches!(side.take_command(&command(10, 0.1), 0), Err(CommandRefused::NotPublished { .. })));
    let other_run = sealed(JointCommandMsg { driver_epoch: 41, ..command(9, 0.1) });
    assert_eq!(side.take_command(&other_run, 0), Err(CommandRefused::Epoch { found: 41, expected: 42 }));
    let position = sealed(JointCommandMsg { mode: CommandMode::Position.code(), ..command(9, 0.1) });
    assert!(matches!(side.take_command(&position, 0), Err(CommandRefused::Mode { .. })));
    let six = sealed(JointCommandMsg { joint_count: 6, ..command(9, 0.1) });
    assert!(matches!(side.take_command(&six, 0), Err(CommandRefused::JointCount { found: 6, .. })));
    let mut nan = command(9, 0.1);
    nan.qd_ref_rad_s[3] = f64::NAN;
    let nan = sealed(nan);
    assert_eq!(side.take_command(&nan, 0), Err(CommandRefused::NotFinite { joint: 3 }));
    let old = sealed(JointCommandMsg { schema: SCHEMA_VERSION - 1, ..command(9, 0.1) });
    assert!(matches!(side.take_command(&old, 0), Err(CommandRefused::Schema { .. })));
    assert_eq!(side.counts.commands_taken, 2);
    assert_eq!(side.counts.commands_refused, 8);
    // after the driver's own silence a command is as old as its tick says
    side.joint_state(60, 60 * MS, &at_rest(), None);
    assert!(matches!(side.take_command(&command(9, 0.1), 61 * MS), Err(CommandRefused::TooOld { .. })));
}

#[test]
fn an_unsealed_command_is_refused_and_holds_the_arm_at_once() {
    let mut side = side();
    side.joint_state(0, 0, &at_rest(), None);
    side.take_command(&command(0, 0.3), 0).expect("the rmrc's");
    assert!(side.apply(0).is_some(), "in force");
    let mut rogue = command(0, 0.3);
    rogue.seal ^= 1;
    assert_eq!(side.take_command(&rogue, MS / 2), Err(CommandRefused::Unsealed));
    assert!(side.apply(MS / 2).is_none(), "held now, not after hold_after");
    let mut without_a_key = DriverSide::new(side.settings().clone(), 42, None);
    without_a_key.published(0, 0);
    assert_eq!(without_a_key.take_command(&command(0, 0.0), 0), Err(CommandRefused::Unsealed));
}

#[test]
fn a_held_cell_takes_only_a_ramp_to_rest_and_only_the_daemons_mode_counts() {
    let mut side = side();
    side.joint_state(0, 0, &at_rest(), None);
    side.cell_mode(&mode(CellMode::Servoing, 1));
    side.take_command(&command(0, 0.3), 0).expect("servoing: any speed within the contract");
    side.cell_mode(&mode(CellMode::SafeStop, 2));
    assert_eq!(side.mode(), Some((CellMode::SafeStop, 2)));
    for (tick, v) in [(1, 0.305), (2, 0.2), (3, 0.0)] {
        side.joint_state(tick, tick * MS, &at_rest(), None);
        side.take_command(&command(tick, v), tick * MS).expect("the ramp to rest");
    }
    side.joint_state(4, 4 * MS, &at_rest(), None);
    assert!(matches!(
        side.take_command(&command(4, 0.3), 4 * MS),
        Err(CommandRefused::NotTowardsRest { joint: 0, .. })
    ));
    // a forged mode (not sealed by the daemon) changes nothing
    let mut forged = mode(CellMode::Servoing, 3);
    forged.seal ^= 1;
    side.cell_mode(&forged);
    assert_eq!(side.counts.modes_refused, 1);
    assert!(side.take_command(&command(4, 0.3), 4 * MS).is_err(), "still held");
    side.cell_mode(&mode(CellMode::Servoing, 1));
    assert!(side.take_command(&command(4, 0.3), 4 * MS).is_err(), "an older mode: still held");
    side.cell_mode(&mode(CellMode::Servoing, 3));
    assert!(side.take_command(&command(4, 0.3), 4 * MS).is_ok(), "resumed");
}

#[test]
fn the_applied_command_is_reported_with_the_next_state_and_a_silence_holds() {
    let mut side = side();
    let first = side.joint_state(0, 0, &at_rest(), None);
    assert_eq!(first.applied_command_tick, u64::MAX);
    assert_eq!(DriverStatus::try_from(first.driver_status), Ok(DriverStatus::Holding));
    side.take_command(&command(0, 0.5), MS / 2).expect("taken");
    let applied = side.apply(MS / 2).expect("in force");
    assert_eq!(applied.values[0], 0.5);
    let second = side.joint_state(1, MS, &at_rest(), None);
    assert_eq!(second.applied_command_tick, 0);
    assert_eq!(DriverStatus::try_from(second.driver_status), Ok(DriverStatus::Following));
    // no command for longer than hold_after: hold
    assert!(side.apply(MS / 2 + 21 * MS).is_none());
    let held = side.joint_state(2, 22 * MS, &at_rest(), None);
    assert_eq!(held.applied_command_tick, u64::MAX);
    assert_eq!(DriverStatus::try_from(held.driver_status), Ok(DriverStatus::Holding));
    let fault = side.joint_state(3, 23 * MS, &at_rest(), Some(DriverError::FrankaJointReflex));
    assert_eq!(DriverStatus::try_from(fault.driver_status), Ok(DriverStatus::Fault));
    assert_eq!(DriverError::try_from(fault.driver_error), Ok(DriverError::FrankaJointReflex));
    assert_eq!(held.driver_error, 0, "no fault, no reason");
}

#[test]
fn limits_give_their_bits_and_nan_counts_as_outside() {
    let mut side = side();
    let mut measured = at_rest();
    measured.q_rad[1] = 2.5;
    measured.qd_rad_s[6] = f64::NAN;
    let state = side.joint_state(0, 0, &measured, None);
    assert_eq!(fault_bits::joints(state.faults, fault_bits::POSITION_LIMIT_SHIFT), 0b10);
    assert_eq!(fault_bits::joints(state.faults, fault_bits::VELOCITY_LIMIT_SHIFT), 0b100_0000);
}

#[test]
fn a_wrong_period_is_a_fault() {
    let mut side = side();
    for tick in 0..100 {
        side.joint_state(tick, tick * 2 * MS, &at_rest(), None);
    }
    assert_eq!(side.period_mismatch_ns(), Some(2 * MS));
    let state = side.joint_state(100, 200 * MS, &at_rest(), None);
    assert_eq!(DriverStatus::try_from(state.driver_status), Ok(DriverStatus::Fault));
    assert_eq!(DriverError::try_from(state.driver_error), Ok(DriverError::PeriodMismatch), "named");
}

#[test]
fn the_dynamics_override_is_the_daemons_sealed_one_in_force() {
    let mut side = side();
    assert_eq!(side.speed_scale(), 1.0, "none taken: the arm's own limits");
    let quarter = |sequence| {
        let mut message = CellModeMsg { speed_scale: 0.25, ..mode(CellMode::Servoing, sequence) };
        key().sign(&mut message);
        message
    };
    side.cell_mode(&quarter(1));
    assert_eq!(side.speed_scale(), 0.25);
    // a forged one, an older one and one out of (0, 1] leave it
    let mut forged = CellModeMsg { speed_scale: 1.0, ..quarter(2) };
    forged.seal ^= 1;
    side.cell_mode(&forged);
    let mut older = CellModeMsg { speed_scale: 1.0, ..mode(CellMode::Servoing, 0) };
    key().sign(&mut older);
    side.cell_mode(&older);
    let mut beyond = CellModeMsg { speed_scale: 1.5, ..mode(CellMode::Servoing, 3) };
    key().sign(&mut beyond);
    side.cell_mode(&beyond);
    assert_eq!(side.speed_scale(), 0.25);
}
