//! The client against a scripted in-process robot: version refusals, a malformed first state, franka-sim's
//! padded 16-byte responses interleaved with another id, newest-state selection, and an abort.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::thread;
use std::time::Duration;

use vservo_franka::client::ConnectError;
use vservo_franka::{
    Connection, ControllerMode, DecodeError, Dropped, JointVelocityCommand, MotionGeneratorMode,
    MotionOutcome, MotionPhase, MoveStatus, RecvStateError, RobotCommand, RobotError, RobotErrors, RobotMode,
    RobotState, SendCommandError,
};

const T: Duration = Duration::from_secs(2);

/// The robot's side of one connection: its TCP stream, its UDP socket, the client's UDP address.
struct Robot {
    tcp: TcpStream,
    udp: UdpSocket,
    client_udp: SocketAddr,
}

impl Robot {
    fn read_frame(&mut self) -> (u32, u32, Vec<u8>) {
        let mut header = [0u8; 12];
        self.tcp.read_exact(&mut header).expect("robot reads a header");
        let word = |i: usize| u32::from_le_bytes([header[i], header[i + 1], header[i + 2], header[i + 3]]);
        let mut body = vec![0u8; word(8) as usize - 12];
        self.tcp.read_exact(&mut body).expect("robot reads a body");
        (word(0), word(4), body)
    }

    fn respond(&mut self, command: u32, id: u32, body: &[u8]) {
        let size = (12 + body.len()) as u32;
        let mut frame = Vec::new();
        for w in [command, id, size] {
            frame.extend_from_slice(&w.to_le_bytes());
        }
        frame.extend_from_slice(body);
        self.tcp.write_all(&frame).expect("robot writes a response");
    }

    fn send_state(&self, state: &RobotState) {
        self.udp.send_to(&state.encode(), self.client_udp).expect("robot sends a state");
    }
}

/// Accepts one client, reads its Connect, answers `status`/`version`, and hands the robot to `script`.
fn fake_robot(
    status: u8,
    version: u16,
    script: impl FnOnce(&mut Robot) + Send + 'static,
) -> (SocketAddr, thread::JoinHandle<()>) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind TCP");
    let addr = listener.local_addr().expect("local addr");
    let handle = thread::spawn(move || {
        let (tcp, peer) = listener.accept().expect("accept");
        tcp.set_nodelay(true).expect("no Nagle: each response goes out at once");
        let udp = UdpSocket::bind("127.0.0.1:0").expect("bind UDP");
        let mut robot = Robot { tcp, udp, client_udp: peer };
        let (command, id, body) = robot.read_frame();
        assert_eq!((command, body.len()), (0, 4), "Connect request");
        assert_eq!(u16::from_le_bytes([body[0], body[1]]), 10, "client announces version 10");
        robot.client_udp = SocketAddr::new(peer.ip(), u16::from_le_bytes([body[2], body[3]]));
        let v = version.to_le_bytes();
        robot.respond(0, id, &[status, v[0], v[1]]);
        script(&mut robot);
    });
    (addr, handle)
}

/// A robot that refuses the client's version is an error naming both; a success is taken as libfranka takes it,
/// whatever version comes beside it — franky-sim's reply (status and version as two u16, then 4 bytes) reads as
/// version 2560 — and the client goes on to the robot's states.
#[test]
fn a_refused_version_is_an_error_naming_both_and_a_success_is_taken_as_libfranka_takes_it() {
    let (addr, robot) = fake_robot(0, 2560, |r| r.send_state(&RobotState::idle(1)));
    let conn = Connection::connect(addr, T).expect("a success is taken");
    assert_eq!(conn.server_version(), 2560);
    robot.join().expect("robot thread");

    let (addr, robot) = fake_robot(1, 11, |_| {});
    let err = Connection::connect(addr, T).expect_err("incompatible refused");
    assert!(matches!(err, ConnectError::IncompatibleVersion { server: 11, client: 10, .. }), "{err:?}");
    robot.join().expect("robot thread");
}

#[test]
fn a_short_first_state_is_dropped_and_named_when_no_state_follows() {
    let (addr, robot) = fake_robot(0, 10, |r| {
        r.udp.send_to(&[0u8; 1376], r.client_udp).expect("send");
    });
    let err = Connection::connect(addr, Duration::from_millis(300)).expect_err("no state came");
    match &err {
        ConnectError::FirstState(RecvStateError::Timeout { dropped, .. }) => {
            assert_eq!(dropped.malformed, 1);
            let wrong_size = DecodeError::WrongSize { what: "RobotState", got: 1376, expected: 1377 };
            assert_eq!(dropped.last, Some(Dropped::Malformed(wrong_size)));
        }
        other => panic!("unexpected {other:?}"),
    }
    let text = err.to_string();
    assert!(text.contains("1376") && text.contains("1377"), "{text}");
    robot.join().expect("robot thread");
}

/// The attacks of issue 46 on the state stream, by a local process that found the client's UDP port: one
/// 10-byte datagram, then 200 well-formed states numbered far ahead of the robot's. The robot (this fake one,
/// the robot's side of the measurement) gets an answer to each of its own states, and only to them; the
/// robot's own malformed datagram and an id jump from its own address are dropped too. Nothing ends the
/// motion.
#[test]
fn datagrams_not_from_the_robot_or_jumping_ahead_are_dropped_and_counted_and_the_motion_goes_on() {
    const CYCLES: u64 = 300;
    let (addr, robot) = fake_robot(0, 10, |r| {
        r.send_state(&RobotState::idle(1));
        let (command, move_id, _) = r.read_frame();
        assert_eq!(command, 1, "Move");
        r.respond(1, move_id, &[1, 0, 0, 0]);
        r.udp.set_read_timeout(Some(T)).expect("a read timeout");
        for id in 2..2 + CYCLES {
            if id == 100 {
                r.udp.send_to(&[0u8; 10], r.client_udp).expect("the robot's own bad datagram");
                r.send_state(&running(id + 100_000));
            }
            r.send_state(&running(id));
            let mut buf = [0u8; 2048];
            let (n, from) = r.udp.recv_from(&mut buf).expect("an answer to each of the robot's states");
            let command = RobotCommand::decode(&buf[..n]).expect("a 371-byte command");
            assert_eq!(command.message_id, id, "the answer answers the robot's own state (from {from})");
        }
    });
    let mut conn = Connection::connect(addr, T).expect("connect");
    assert_eq!(
        conn.udp_local().ip(),
        addr.ip(),
        "bound on the interface that reaches the robot, not 0.0.0.0"
    );
    let attacker = UdpSocket::bind("127.0.0.1:0").expect("the attacker's socket");
    let client = conn.udp_local();
    let mut state = conn.start_joint_velocity_motion(T).expect("motion starts");
    for cycle in 0..CYCLES {
        if cycle == 10 {
            attacker.send_to(&[0u8; 10], client).expect("a 10-byte datagram");
        }
        if (20..220).contains(&cycle) {
            attacker.send_to(&running(1_000_000 + cycle).encode(), client).expect("a spoofed state");
        }
        assert!(state.message_id < 100_000, "only the robot's states: {}", state.message_id);
        conn.send_command(&state, &JointVelocityCommand::new([0.0; 7])).expect("the answer goes out");
        if cycle + 1 < CYCLES {
            state = conn.recv_state(T).expect("the robot's next state");
        }
    }
    robot.join().expect("the robot got an answer to each of its states");
    let dropped = conn.dropped();
    println!("dropped: {dropped:?}");
    assert_eq!((dropped.foreign, dropped.malformed, dropped.id_jumps), (201, 1, 1));
}

fn running(id: u64) -> RobotState {
    RobotState {
        robot_mode: RobotMode::Move,
        motion_generator_mode: MotionGeneratorMode::JointVelocity,
        controller_mode: ControllerMode::JointImpedance,
        control_command_success_rate: 1.0,
        ..RobotState::idle(id)
    }
}

#[test]
fn a_motion_with_padded_interleaved_responses_newest_state_and_an_abort() {
    let (addr, robot) = fake_robot(0, 10, |r| {
        r.send_state(&RobotState::idle(1));
        let (command, move_id, body) = r.read_frame();
        assert_eq!((command, body.len()), (1, 113), "Move request");
        assert_eq!(&body[0..8], &[0, 0, 0, 0, 1, 0, 0, 0], "joint impedance, joint velocity");
        r.respond(2, move_id + 100, &[0, 0, 0, 0]); // a frame for another id first
        r.respond(1, move_id, &[1, 0, 0, 0]); // kMotionStarted, padded to 16 bytes like franka-sim
        thread::sleep(Duration::from_millis(20));
        r.send_state(&running(2));
        let mut buf = [0u8; 2048];
        let (n, _) = r.udp.recv_from(&mut buf).expect("command");
        let command = RobotCommand::decode(&buf[..n]).expect("a 371-byte command");
        assert_eq!(command.message_id, 2);
        assert_eq!(command.dq_c[0], 0.01);
        r.send_state(&running(3));
        r.send_state(&running(4));
        thread::sleep(Duration::from_millis(100));
        let errors = RobotErrors::NONE.with(RobotError::JointMotionGeneratorAccelerationDiscontinuity);
        r.send_state(&RobotState {
            robot_mode: RobotMode::Reflex,
            motion_generator_mode: MotionGeneratorMode::Idle,
            controller_mode: ControllerMode::Other,
            errors,
            reflex_reason: errors,
            ..RobotState::idle(5)
        });
        r.respond(1, move_id, &[8, 0, 0, 0]); // kReflexAborted
        let (command, aer_id, body) = r.read_frame();
        assert_eq!((command, body.len()), (10, 0), "AutomaticErrorRecovery request");
        r.respond(10, aer_id, &[0, 0, 0, 0]);
        r.send_state(&RobotState::idle(6));
    });

    let mut conn = Connection::connect(addr, T).expect("connect");
    assert_eq!(conn.server_version(), 10);
    assert_eq!(conn.first_state().message_id, 1);
    let idle = conn.first_state().clone();
    assert!(matches!(
        conn.send_command(&idle, &JointVelocityCommand::new([0.0; 7])),
        Err(SendCommandError::NoActiveMotion)
    ));
    let state = conn.start_joint_velocity_motion(T).expect("motion starts");
    assert_eq!(state.message_id, 2);
    assert_eq!(MotionPhase::of(&state), MotionPhase::Running);
    let bad = JointVelocityCommand::new([f64::INFINITY, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(matches!(conn.send_command(&state, &bad), Err(SendCommandError::NonFinite { joint: 0, .. })));
    let dq = [0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    conn.send_command(&state, &JointVelocityCommand::new(dq)).expect("command sent");
    thread::sleep(Duration::from_millis(50));
    let newest = conn.recv_state(T).expect("state");
    assert_eq!(newest.message_id, 4, "state 3 was queued behind 4 and dropped");
    assert!(matches!(
        conn.send_command(&state, &JointVelocityCommand::new(dq)),
        Err(SendCommandError::StaleState { answered: 2, newest: 4 })
    ));
    let aborted = conn.recv_state(T).expect("state");
    assert_eq!(
        MotionPhase::of(&aborted),
        MotionPhase::Aborted {
            errors: RobotErrors::NONE.with(RobotError::JointMotionGeneratorAccelerationDiscontinuity)
        }
    );
    let outcome = conn.motion_result(T).expect("Move final response");
    match outcome {
        MotionOutcome::Aborted { status, errors, .. } => {
            assert_eq!(status, MoveStatus::ReflexAborted);
            assert_eq!(errors.names(), ["joint_motion_generator_acceleration_discontinuity"]);
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(!conn.motion_active());
    conn.automatic_error_recovery(T).expect("recovery");
    // A huge timeout saturates instead of overflowing `Instant` (no panic).
    assert_eq!(conn.recv_state(Duration::MAX).expect("state").robot_mode, RobotMode::Idle);
    robot.join().expect("robot thread");
}
