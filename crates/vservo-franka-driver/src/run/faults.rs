//! The robot's faults and its going away, as the driver looks after them: a motion the robot ended (a reflex, or
//! silence) reported until the cell holds, then the robot's error recovery and a new motion on a resume; a robot
//! gone (its connection closed, or silent through its error recovery: a cable pulled) reported as
//! `robot_connection_lost` while a thread connects again, then a new motion on a resume.

use std::time::Duration;

use vservo_driver::Measured;
use vservo_franka::{Connection, RobotErrors, RobotState};
use vservo_protocol::{CellMode, DriverError, MAX_JOINTS};

use super::{Driver, FAULT_SHOWN_NS, Next, RECONNECT_EVERY, ROBOT_TIMEOUT, widen};
use crate::cell::CellPorts;
use vservo_time::monotonic_ns;

/// Where the robot's motion is.
#[derive(Debug, Clone, Copy)]
pub(super) enum Phase {
    /// A joint-velocity motion runs: every state is answered.
    Moving,
    /// The robot stopped the motion (a reflex), or went away: reported as a fault until the cell is held (the
    /// robot gone: until it is connected again), then held until a resume asks for the robot's recovery (a new
    /// motion, on a new connection).
    Faulted {
        /// The robot's errors (a reflex); none for a motion lost to silence.
        errors: RobotErrors,
        /// The robot's connection closed: `Some(false)` while it is made again, `Some(true)` once it is.
        reconnected: Option<bool>,
        since_ns: u64,
        /// The cell's mode sequence when it happened; `held_at`: the sequence of the safe stop that holds it.
        sequence: Option<u64>,
        held_at: Option<u64>,
        /// The robot's recovery, asked for on a resume (when, ns) and not answered yet.
        recovering: Option<(vservo_franka::RecoveryUnderWay, u64)>,
    },
}

/// A thread that connects to the robot at `address` again, every [`RECONNECT_EVERY`], until it answers (or the
/// driver no longer waits for it); the connection comes through the channel.
pub(super) fn reconnect(address: std::net::SocketAddr) -> std::sync::mpsc::Receiver<Connection> {
    let (connected, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        loop {
            std::thread::sleep(RECONNECT_EVERY);
            match Connection::connect(address, ROBOT_TIMEOUT) {
                Ok(connection) => {
                    let _ = connected.send(connection);
                    return;
                }
                Err(error) => tracing::debug!("the Franka at {address} does not answer yet: {error}"),
            }
        }
    });
    receiver
}

impl Driver {
    /// No robot state while moving (`why`: for how long, or the socket's error): the motion is taken as ended by
    /// the robot, a fault; with the robot's connection closed, the robot is gone ([`Driver::connection_lost`]).
    pub(super) fn motion_lost(&mut self, robot: &mut Connection, cell: &mut CellPorts, why: &str) {
        if robot.closed() {
            self.connection_lost(cell, &format!("{why} and the connection closed"));
            return;
        }
        tracing::error!(
            "{why} while moving: the Franka ended the motion (the driver or the network was away); the cell is \
             stopped safely (driver_fault)"
        );
        self.motion_aborted(robot, cell, RobotErrors::default(), monotonic_ns());
    }

    /// The robot (or its server) went away: a fault, `robot_connection_lost`, reported until it is connected again
    /// (the run's loop makes the connection again, every second); a resume then starts a new motion.
    pub(super) fn connection_lost(&mut self, cell: &mut CellPorts, why: &str) {
        if self.robot_gone() {
            return;
        }
        tracing::error!(
            "the connection to the Franka is lost ({why}): the cell is stopped safely (driver_fault: \
             robot_connection_lost); connecting again every {RECONNECT_EVERY:?}, then `vservoctl resume` starts a \
             new motion"
        );
        self.report.connections_lost += 1;
        self.fault_now(cell, RobotErrors::default(), Some(false), monotonic_ns());
    }

    /// A new fault from `now_ns`: the arm held, the guard reset, the fault shown until the cell holds after the
    /// cell's mode sequence now.
    fn fault_now(
        &mut self,
        cell: &mut CellPorts,
        errors: RobotErrors,
        reconnected: Option<bool>,
        now_ns: u64,
    ) {
        self.side.hold();
        self.shaper = None;
        let sequence = self.cell_mode(cell).map(|(_, sequence)| sequence);
        self.phase = Phase::Faulted {
            errors,
            reconnected,
            since_ns: now_ns,
            sequence,
            held_at: None,
            recovering: None,
        };
    }

    /// Whether the robot is gone and not connected again yet.
    pub(super) fn robot_gone(&self) -> bool {
        matches!(self.phase, Phase::Faulted { reconnected: Some(false), .. })
    }

    /// Whether the robot is connected again and no new motion runs yet.
    pub(super) fn connected_again(&self) -> bool {
        matches!(self.phase, Phase::Faulted { reconnected: Some(true), .. })
    }

    /// A state of the robot connected again, before its new motion: the arm's position and torques, at rest.
    pub(super) fn note_idle_state(&mut self, state: &RobotState) {
        if let Some((tick, stamp_ns, _)) = self.last {
            let measured = Measured {
                q_rad: widen(&state.q),
                qd_rad_s: [0.0; MAX_JOINTS],
                torque_nm: widen(&state.tau_J),
            };
            self.last = Some((tick, stamp_ns, measured));
        }
    }

    /// Connected again (the connection is `robot`'s): its states count from its own first, and the cell, held,
    /// may resume into a new motion.
    pub(super) fn reconnected(&mut self, robot: &Connection) {
        tracing::warn!(
            protocol = robot.server_version(),
            "connected to the Franka at {} again: `vservoctl resume` starts a new motion",
            robot.robot_addr()
        );
        self.origin_id = None;
        self.report.reconnections += 1;
        if let Phase::Faulted { reconnected, .. } = &mut self.phase {
            *reconnected = Some(true);
        }
        // the robot as it is now (a server started again puts its arm where it starts): published at rest until
        // its motion streams states
        self.note_idle_state(robot.first_state());
    }

    /// The robot ended the motion itself: a fault, named with the robot's errors.
    pub(super) fn motion_aborted(
        &mut self,
        robot: &mut Connection,
        cell: &mut CellPorts,
        errors: RobotErrors,
        now_ns: u64,
    ) {
        let outcome = robot.motion_result(Duration::from_millis(5));
        let why = if errors.iter().next().is_some() {
            format!("the Franka stopped the motion (a reflex): {errors}")
        } else {
            "the Franka's motion ended, no error named (no answer yet to why)".to_string()
        };
        tracing::error!(
            errors = %errors,
            outcome = ?outcome.ok(),
            "{why}; the cell is stopped safely (driver_fault), `vservoctl resume` runs the robot's error recovery"
        );
        self.report.reflexes.extend(errors.names().into_iter().map(str::to_string));
        self.fault_now(cell, errors, None, now_ns);
    }

    /// A fault's progress: the safe stop that holds it, and the robot's recovery under way.
    fn set_fault_progress(
        &mut self,
        held: Option<u64>,
        under_way: Option<(vservo_franka::RecoveryUnderWay, u64)>,
    ) {
        if let Phase::Faulted { held_at, recovering, .. } = &mut self.phase {
            *held_at = held;
            *recovering = under_way;
        }
    }

    /// Faulted: once the fault has been shown and the cell holds, the driver holds too; a resume (the cell
    /// servoing or moving again after that safe stop) starts the robot's recovery, which the driver waits for
    /// cycle by cycle (it can take most of a second), then a new motion.
    pub(super) fn look_after_fault(
        &mut self,
        robot: &mut Connection,
        cell: &mut CellPorts,
        now_ns: u64,
    ) -> anyhow::Result<Next> {
        let Phase::Faulted { errors, reconnected, since_ns, sequence, held_at, recovering } = self.phase
        else {
            return Ok(Next::Go);
        };
        if let Some((under_way, asked_ns)) = recovering {
            match robot.recovery_done(&under_way) {
                // a robot gone without a word (a cable pulled, the robot switched off: its connection still looks
                // open): given up, and connected again as a robot whose connection closed
                None if now_ns.saturating_sub(asked_ns) > ROBOT_TIMEOUT.as_nanos() as u64 => {
                    robot.give_up();
                    self.connection_lost(
                        cell,
                        &format!(
                            "no answer to its error recovery within {ROBOT_TIMEOUT:?}: the robot is silent (a cable \
                             pulled, the robot switched off or FCI deactivated)"
                        ),
                    );
                }
                None => {}
                Some(Ok(())) => self.start_motion(robot, held_at)?,
                Some(Err(error)) => {
                    tracing::error!("the Franka's error recovery failed: {error}; the cell stays stopped");
                    self.fault_now(cell, errors, None, now_ns);
                }
            }
            return Ok(Next::Go);
        }
        let Some((mode, current)) = self.cell_mode(cell) else { return Ok(Next::Go) };
        let shown = now_ns.saturating_sub(since_ns) >= FAULT_SHOWN_NS;
        match held_at {
            None if mode == CellMode::SafeStop && shown && sequence.is_none_or(|at| current >= at) => {
                self.set_fault_progress(Some(current), None);
            }
            // on a new connection the robot has no error to recover from: a new motion
            Some(held) if mode != CellMode::SafeStop && current > held && reconnected == Some(true) => {
                tracing::warn!("a resume: a new motion on the Franka connected again");
                self.start_motion(robot, held_at)?;
            }
            Some(held) if mode != CellMode::SafeStop && current > held && reconnected.is_none() => {
                tracing::warn!("a resume: running the Franka's automatic error recovery after {errors}");
                if robot.motion_active() {
                    // the stopped motion's answer, if it has not been read yet
                    let _ = robot.motion_result(Duration::from_millis(5));
                }
                if robot.motion_active() {
                    // a robot that ends a motion answers it: this one has said nothing since its states stopped
                    robot.give_up();
                    self.connection_lost(
                        cell,
                        "no answer to the motion it stopped: the robot is silent (a cable pulled, the robot \
                         switched off or FCI deactivated)",
                    );
                    return Ok(Next::Go);
                }
                match robot.begin_automatic_error_recovery() {
                    Ok(under_way) => self.set_fault_progress(Some(current), Some((under_way, now_ns))),
                    Err(error) => {
                        tracing::error!(
                            "the Franka's error recovery could not be asked for: {error}; the cell stays stopped"
                        );
                        self.fault_now(cell, errors, None, now_ns);
                    }
                }
            }
            _ => {}
        }
        Ok(Next::Go)
    }
}

/// The cell's reason for the robot's errors: the first of them, as the protocol numbers the Franka's (1000 + its
/// flag); none when the robot named none (a motion lost to silence).
pub(super) fn driver_error(errors: RobotErrors) -> DriverError {
    errors
        .iter()
        .next()
        .and_then(|error| DriverError::try_from(1000 + u32::from(error.to_wire())).ok())
        .unwrap_or(DriverError::None)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every error flag of the Franka's is a reason of the protocol's, under the same name.
    #[test]
    fn each_franka_error_is_the_protocols_driver_error_of_the_same_name() {
        for error in vservo_franka::RobotError::ALL {
            let reason = driver_error(RobotErrors::from_iter([*error]));
            assert_eq!(reason.name(), error.name(), "{error:?}");
        }
        assert_eq!(driver_error(RobotErrors::default()), DriverError::None);
    }
}
