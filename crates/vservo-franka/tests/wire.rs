//! The v10 wire layouts against fixtures packed by Python's `struct` from the libfranka headers' field lists
//! (tests/fixtures/gen_fixtures.py), and malformed input refused without panicking.

use proptest::prelude::*;
use vservo_franka::wire::state_layout::{self, ROBOT_STATE_SIZE};
use vservo_franka::wire::tcp::{
    self, ConnectResponse, ConnectStatus, Header, MoveRequest, MoveStatus, encode_connect_request,
};
use vservo_franka::wire::{FieldLayout, WireType, command_layout};
use vservo_franka::{
    ControllerMode, DecodeError, JointVelocityCommand, MotionGeneratorMode, RobotCommand, RobotError,
    RobotMode, RobotState,
};

fn hex(text: &str) -> Vec<u8> {
    let digits: Vec<u8> = text.bytes().filter(u8::is_ascii_hexdigit).collect();
    digits
        .chunks(2)
        .map(|pair| u8::from_str_radix(std::str::from_utf8(pair).unwrap_or("zz"), 16).unwrap_or_default())
        .collect()
}

const STATE_HEX: &str = include_str!("fixtures/robot_state_v10.hex");
const COMMAND_HEX: &str = include_str!("fixtures/robot_command_v10.hex");
const LAYOUT_CSV: &str = include_str!("fixtures/layout_v10.csv");

fn check_layout(struct_name: &str, fields: &[FieldLayout]) {
    let rows: Vec<Vec<&str>> = LAYOUT_CSV
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|r| r.first() == Some(&struct_name))
        .collect();
    assert_eq!(rows.len(), fields.len(), "{struct_name}: field count");
    for (row, f) in rows.iter().zip(fields) {
        let expected = [struct_name, f.name, f.ty.name(), &f.count.to_string(), &f.offset.to_string()]
            .map(str::to_owned)
            .to_vec();
        let got: Vec<String> = row.iter().take(5).map(|s| (*s).to_owned()).collect();
        assert_eq!(got, expected, "{struct_name}.{}", f.name);
        assert_eq!(row.get(5).copied(), Some(f.bytes().to_string().as_str()));
    }
}

#[test]
fn layouts_match_the_header_derived_tables() {
    check_layout("RobotState", &state_layout::FIELDS);
    check_layout("RobotCommand", &command_layout::FIELDS);
    assert_eq!(ROBOT_STATE_SIZE, 1377);
    assert_eq!(command_layout::ROBOT_COMMAND_SIZE, 371);
    assert_eq!(state_layout::Q.offset, 596);
    assert_eq!(state_layout::ERRORS.offset, 1290);
    assert_eq!(command_layout::DQ_C.offset, 64);
    assert_eq!(command_layout::MOTION_GENERATION_FINISHED.offset, 313);
}

/// The f32 fields of a state by libfranka name, to check each against the fixture's k + j/64 pattern.
fn floats<'a>(s: &'a RobotState, name: &str) -> Option<&'a [f64]> {
    Some(match name {
        "O_T_EE" => &s.O_T_EE,
        "O_T_EE_d" => &s.O_T_EE_d,
        "F_T_EE" => &s.F_T_EE,
        "EE_T_K" => &s.EE_T_K,
        "F_T_NE" => &s.F_T_NE,
        "NE_T_EE" => &s.NE_T_EE,
        "m_ee" => std::slice::from_ref(&s.m_ee),
        "I_ee" => &s.I_ee,
        "F_x_Cee" => &s.F_x_Cee,
        "m_load" => std::slice::from_ref(&s.m_load),
        "I_load" => &s.I_load,
        "F_x_Cload" => &s.F_x_Cload,
        "elbow" => &s.elbow,
        "elbow_d" => &s.elbow_d,
        "tau_J" => &s.tau_J,
        "tau_J_d" => &s.tau_J_d,
        "dtau_J" => &s.dtau_J,
        "q" => &s.q,
        "q_d" => &s.q_d,
        "dq" => &s.dq,
        "dq_d" => &s.dq_d,
        "ddq_d" => &s.ddq_d,
        "joint_contact" => &s.joint_contact,
        "cartesian_contact" => &s.cartesian_contact,
        "joint_collision" => &s.joint_collision,
        "cartesian_collision" => &s.cartesian_collision,
        "tau_ext_hat_filtered" => &s.tau_ext_hat_filtered,
        "O_F_ext_hat_K" => &s.O_F_ext_hat_K,
        "K_F_ext_hat_K" => &s.K_F_ext_hat_K,
        "O_dP_EE_d" => &s.O_dP_EE_d,
        "O_ddP_O" => &s.O_ddP_O,
        "elbow_c" => &s.elbow_c,
        "delbow_c" => &s.delbow_c,
        "ddelbow_c" => &s.ddelbow_c,
        "O_T_EE_c" => &s.O_T_EE_c,
        "O_dP_EE_c" => &s.O_dP_EE_c,
        "O_ddP_EE_c" => &s.O_ddP_EE_c,
        "theta" => &s.theta,
        "dtheta" => &s.dtheta,
        "accelerometer_top" => &s.accelerometer_top,
        "accelerometer_bottom" => &s.accelerometer_bottom,
        _ => return None,
    })
}

#[test]
fn the_state_fixture_decodes_field_by_field_and_encodes_back_to_the_same_bytes() {
    let bytes = hex(STATE_HEX);
    assert_eq!(bytes.len(), 1377);
    let state = RobotState::decode(&bytes).expect("fixture decodes");
    assert_eq!(state.message_id, 0x0102_0304_0506_0708);
    let mut float_fields = 0;
    for (k, f) in state_layout::FIELDS.iter().enumerate() {
        if f.ty != WireType::F32 || f.name == "control_command_success_rate" {
            continue;
        }
        let values = floats(&state, f.name).unwrap_or_else(|| panic!("no accessor for {}", f.name));
        assert_eq!(values.len(), f.count, "{}", f.name);
        for (j, v) in values.iter().enumerate() {
            assert_eq!(*v, k as f64 + j as f64 / 64.0, "{}[{j}]", f.name);
        }
        float_fields += 1;
    }
    assert_eq!(float_fields, 41);
    assert_eq!(state.motion_generator_mode, MotionGeneratorMode::JointVelocity);
    assert_eq!(state.controller_mode, ControllerMode::JointImpedance);
    assert_eq!(state.robot_mode, RobotMode::Move);
    assert_eq!(
        state.errors.names(),
        [
            "joint_motion_generator_acceleration_discontinuity",
            "communication_constraints_violation",
            "base_acceleration_invalid_reading"
        ]
    );
    assert!(state.reflex_reason.contains(RobotError::JointPositionLimitsViolation));
    assert!(state.reflex_reason.contains(RobotError::JointMotionGeneratorAccelerationDiscontinuity));
    assert_eq!(state.reflex_reason.len(), 2);
    assert_eq!(state.control_command_success_rate, 0.75);
    assert!((state.time_s() - 0x0102_0304_0506_0708u64 as f64 * 1e-3).abs() < 1.0);
    assert_eq!(state.encode().to_vec(), bytes);
}

#[test]
fn the_command_fixture_round_trips_and_a_joint_velocity_command_sets_only_its_fields() {
    let bytes = hex(COMMAND_HEX);
    assert_eq!(bytes.len(), 371);
    let command = RobotCommand::decode(&bytes).expect("fixture decodes");
    assert_eq!(command.message_id, 0x1122_3344_5566_7788);
    assert_eq!(command.q_c[0], -1.0);
    assert_eq!(command.dq_c[6], -(2.0 + 6.0 / 8.0));
    assert_eq!(command.O_T_EE_c[15], -(3.0 + 15.0 / 8.0));
    assert_eq!(command.tau_J_d[0], -8.0);
    assert!(command.valid_elbow && command.motion_generation_finished && !command.torque_command_finished);
    assert_eq!(command.encode().to_vec(), bytes);

    let dq = [0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7];
    let wire = JointVelocityCommand::new(dq).encode(42);
    assert_eq!(wire.len(), 371);
    assert_eq!(wire[0..8], 42u64.to_le_bytes());
    assert_eq!(wire[64..72], 0.1f64.to_le_bytes());
    let back = RobotCommand::decode(&wire).expect("decodes");
    assert_eq!(back, JointVelocityCommand::new(dq).to_robot_command(42));
    assert_eq!(back, RobotCommand { dq_c: dq, ..RobotCommand::zeroed(42) });
    let finish = RobotCommand::decode(&JointVelocityCommand::finish([0.0; 7]).encode(43)).expect("decodes");
    assert!(finish.motion_generation_finished && !finish.torque_command_finished);
    assert_eq!(
        JointVelocityCommand::new([0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]).first_non_finite(),
        Some(1)
    );
}

#[test]
fn tcp_requests_match_the_fixtures() {
    assert_eq!(
        encode_connect_request(0, 0xBEEF).to_vec(),
        hex(include_str!("fixtures/connect_request_v10.hex"))
    );
    assert_eq!(
        MoveRequest::joint_velocity().encode(5).to_vec(),
        hex(include_str!("fixtures/move_request_v10.hex"))
    );
    assert_eq!(
        tcp::encode_empty_request(tcp::Command::StopMove, 7).to_vec(),
        [2, 0, 0, 0, 7, 0, 0, 0, 12, 0, 0, 0]
    );
}

#[test]
fn every_other_datagram_size_is_refused_naming_both_sizes() {
    let bytes = hex(STATE_HEX);
    for len in (0..=1400).chain([2373, 65_507]) {
        if len == 1377 {
            continue;
        }
        let mut data = bytes.clone();
        data.resize(len, 0);
        let err = RobotState::decode(&data).expect_err("wrong size refused");
        assert_eq!(err, DecodeError::WrongSize { what: "RobotState", got: len, expected: 1377 });
        let text = err.to_string();
        assert!(text.contains(&len.to_string()) && text.contains("1377"), "{text}");
    }
    for len in [0, 370, 372] {
        assert!(matches!(
            RobotCommand::decode(&vec![0; len]),
            Err(DecodeError::WrongSize { got, expected: 371, .. }) if got == len
        ));
    }
}

#[test]
fn bad_bools_and_undefined_modes_are_refused_naming_field_and_offset() {
    let good = hex(STATE_HEX);
    let mut bad = good.clone();
    bad[1290 + 3] = 2;
    assert_eq!(
        RobotState::decode(&bad),
        Err(DecodeError::InvalidBool { what: "RobotState", field: "errors", offset: 1293, value: 2 })
    );
    let mut bad = good.clone();
    bad[1372] = 7;
    let err = RobotState::decode(&bad).expect_err("robot_mode 7 refused");
    assert!(err.to_string().contains("robot_mode") && err.to_string().contains("1372"), "{err}");
    let mut bad = good;
    bad[1288] = 6;
    assert!(matches!(
        RobotState::decode(&bad),
        Err(DecodeError::UnknownValue { field: "motion_generator_mode", value: 6, .. })
    ));
}

#[test]
fn tcp_frames_and_responses_are_read_by_size_and_refused_when_malformed() {
    assert_eq!(Header::peek(&[1, 0, 0]), Ok(None));
    let header = Header { command: 1, command_id: 9, size: 16 };
    assert_eq!(Header::peek(&header.encode()), Ok(Some(header)));
    let tiny = Header { command: 1, command_id: 9, size: 11 }.encode();
    assert!(matches!(Header::peek(&tiny), Err(DecodeError::InvalidFrameSize { size: 11, .. })));
    let huge = Header { command: 1, command_id: 9, size: u32::MAX }.encode();
    assert!(matches!(Header::peek(&huge), Err(DecodeError::InvalidFrameSize { .. })));

    // franka-sim's Move response: status then 3 pad bytes (16-byte frame, libfranka's struct has 13).
    assert_eq!(
        tcp::decode_status(&[8, 0, 0, 0], "Move response", MoveStatus::from_wire),
        Ok(MoveStatus::ReflexAborted)
    );
    assert!(matches!(
        tcp::decode_status(&[], "Move response", MoveStatus::from_wire),
        Err(DecodeError::TooShort { needed: 1, .. })
    ));
    assert!(matches!(
        tcp::decode_status(&[12], "Move response", MoveStatus::from_wire),
        Err(DecodeError::UnknownValue { value: 12, .. })
    ));
    assert_eq!(
        ConnectResponse::decode(&[0, 10, 0]),
        Ok(ConnectResponse { status: ConnectStatus::Success, version: 10 })
    );
    assert!(matches!(
        ConnectResponse::decode(&[0, 10]),
        Err(DecodeError::TooShort { got: 2, needed: 3, .. })
    ));
    assert!(matches!(ConnectResponse::decode(&[2, 10, 0]), Err(DecodeError::UnknownValue { .. })));
}

/// Zeroes NaN f32 slots (f32 → f64 → f32 need not keep a NaN's payload) and makes bool/enum bytes valid.
fn sanitise(mut bytes: Vec<u8>) -> Vec<u8> {
    for f in state_layout::FIELDS {
        for i in 0..f.count {
            let at = f.offset + i * f.ty.size();
            match f.ty {
                WireType::F32 => {
                    let v = f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
                    if v.is_nan() {
                        bytes[at..at + 4].fill(0);
                    }
                }
                WireType::Bool => bytes[at] &= 1,
                WireType::U8 => bytes[at] %= 4,
                _ => {}
            }
        }
    }
    bytes
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic(data in proptest::collection::vec(any::<u8>(), 0..3000)) {
        let _ = RobotState::decode(&data);
        let _ = RobotCommand::decode(&data);
        let _ = Header::peek(&data);
        let _ = ConnectResponse::decode(&data);
    }

    #[test]
    fn valid_states_round_trip_bit_for_bit(data in proptest::collection::vec(any::<u8>(), 1377)) {
        let bytes = sanitise(data);
        let state = RobotState::decode(&bytes).expect("sanitised bytes decode");
        prop_assert_eq!(state.encode().to_vec(), bytes);
    }

    #[test]
    fn commands_round_trip(id in any::<u64>(), dq in proptest::array::uniform7(-10.0f64..10.0), fin in any::<bool>()) {
        let command = JointVelocityCommand { dq_c: dq, motion_generation_finished: fin };
        let back = RobotCommand::decode(&command.encode(id)).expect("decodes");
        prop_assert_eq!(back, command.to_robot_command(id));
    }
}
