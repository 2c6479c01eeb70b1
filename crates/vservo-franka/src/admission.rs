//! Which UDP datagrams are the robot's states (docs/DRIVERS.md, "The Franka's network"): from the robot's own
//! address only, a well-formed 1377-byte state, and a `message_id` that advances plausibly from the robot's
//! last one. Everything else is dropped and counted, never fatal: a local process that finds the client's UDP
//! port (it is listed in `/proc/net/udp`) can neither end the motion with one bad datagram nor take the stream
//! over with states numbered ahead of the robot's.
//!
//! The robot's address is the TCP peer's host; its UDP source port is the one of the first state that came from
//! that host, and from then on only that exact address is the robot. libfranka answers whoever sent the newest
//! state: here commands go to the robot's address only. A host on the robot's network segment that forges the
//! robot's own address is not stopped by this (nor by libfranka): the robot wants a dedicated link.

use std::net::{IpAddr, SocketAddr};
use std::time::Instant;

use crate::wire::DecodeError;
use crate::wire::state::RobotState;

/// A state's `message_id` may run ahead of the last one by the robot's cycles since then (one per millisecond)
/// times this percentage, plus [`ID_SLACK`]: room for a clock that runs a little fast and for a burst queued
/// behind a late read, and none for a jump.
pub const ID_RATE_PERCENT: u64 = 110;

/// The `message_id`s a state may run ahead of the robot's cycles since the last one, whatever the time.
pub const ID_SLACK: u64 = 50;

/// The robot's cycle: one state per millisecond.
const CYCLE_US: u64 = 1_000;

/// Why a datagram was not taken as a robot state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Dropped {
    /// It did not come from the robot's address.
    #[error("a datagram from {from}, not the robot ({robot})")]
    Foreign {
        /// Its sender.
        from: SocketAddr,
        /// The robot's address: its host, and its UDP port once known (0 before).
        robot: SocketAddr,
    },
    /// It is not a v10 robot state (wrong size, a bad bool, an unknown mode).
    #[error("a datagram from the robot that is not a robot state: {0}")]
    Malformed(DecodeError),
    /// Its `message_id` runs further ahead of the last state's than the robot's cycles since then allow.
    #[error(
        "a state numbered {found}, {} ahead of the last ({last}) where the {elapsed_ms} ms since allow at most {allowed}",
        found.saturating_sub(*last)
    )]
    IdJump {
        /// Its `message_id`.
        found: u64,
        /// The last state's.
        last: u64,
        /// The milliseconds since the last state was taken.
        elapsed_ms: u64,
        /// The advance those allow.
        allowed: u64,
    },
}

/// The datagrams dropped so far, by kind, and the last one's reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DroppedCounts {
    /// Not from the robot's address.
    pub foreign: u64,
    /// From the robot, not a state.
    pub malformed: u64,
    /// A `message_id` jump.
    pub id_jumps: u64,
    /// Why the last one was dropped.
    pub last: Option<Dropped>,
}

impl DroppedCounts {
    /// Every datagram dropped.
    pub fn total(&self) -> u64 {
        self.foreign + self.malformed + self.id_jumps
    }

    fn count(&mut self, dropped: Dropped) {
        match dropped {
            Dropped::Foreign { .. } => self.foreign += 1,
            Dropped::Malformed(_) => self.malformed += 1,
            Dropped::IdJump { .. } => self.id_jumps += 1,
        }
        self.last = Some(dropped);
    }
}

/// The rule, with what it has learnt of the robot: its address and its last state.
#[derive(Debug, Clone)]
pub(crate) struct StateAdmission {
    robot_host: IpAddr,
    robot: Option<SocketAddr>,
    /// The last state taken: its `message_id` and when.
    last: Option<(u64, Instant)>,
    dropped: DroppedCounts,
}

impl StateAdmission {
    /// The rule for the robot on `robot_host` (the TCP peer's address).
    pub(crate) fn new(robot_host: IpAddr) -> Self {
        Self { robot_host, robot: None, last: None, dropped: DroppedCounts::default() }
    }

    /// The robot's UDP address, once a state came from it.
    pub(crate) fn robot(&self) -> Option<SocketAddr> {
        self.robot
    }

    /// What was dropped so far.
    pub(crate) fn dropped(&self) -> &DroppedCounts {
        &self.dropped
    }

    /// The datagram `bytes` from `from`, received `at`: the robot's state, or `None` (dropped and counted). A
    /// state taken is not yet the newest: [`StateAdmission::taken`] says which one the caller kept.
    pub(crate) fn admit(&mut self, bytes: &[u8], from: SocketAddr, at: Instant) -> Option<RobotState> {
        match self.judge(bytes, from, at) {
            Ok(state) => {
                self.robot.get_or_insert(from);
                Some(state)
            }
            Err(dropped) => {
                self.dropped.count(dropped);
                None
            }
        }
    }

    /// The state the caller kept as the newest, received `at`: the next ones are numbered from it.
    pub(crate) fn taken(&mut self, message_id: u64, at: Instant) {
        self.last = Some((message_id, at));
    }

    fn judge(&self, bytes: &[u8], from: SocketAddr, at: Instant) -> Result<RobotState, Dropped> {
        let robot = self.robot.unwrap_or(SocketAddr::new(self.robot_host, 0));
        let from_robot = match self.robot {
            Some(robot) => from == robot,
            None => from.ip() == self.robot_host,
        };
        if !from_robot {
            return Err(Dropped::Foreign { from, robot });
        }
        let state = RobotState::decode(bytes).map_err(Dropped::Malformed)?;
        if let Some((last, last_at)) = self.last {
            let elapsed = at.saturating_duration_since(last_at);
            let elapsed_us = u64::try_from(elapsed.as_micros()).unwrap_or(u64::MAX);
            let allowed =
                elapsed_us.saturating_mul(ID_RATE_PERCENT).div_ceil(100 * CYCLE_US).saturating_add(ID_SLACK);
            if state.message_id > last.saturating_add(allowed) {
                let elapsed_ms = elapsed.as_millis() as u64;
                return Err(Dropped::IdJump { found: state.message_id, last, elapsed_ms, allowed });
            }
        }
        Ok(state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn robot_at(port: u16) -> SocketAddr {
        SocketAddr::from(([10, 0, 0, 2], port))
    }

    #[test]
    fn only_the_robots_host_then_its_exact_address_is_taken() {
        let mut rule = StateAdmission::new(robot_at(1337).ip());
        let now = Instant::now();
        let stranger = SocketAddr::from(([10, 0, 0, 3], 1338));
        assert!(rule.admit(&RobotState::idle(1).encode(), stranger, now).is_none());
        assert!(rule.robot().is_none(), "a stranger teaches nothing");
        assert!(rule.admit(&RobotState::idle(1).encode(), robot_at(5000), now).is_some());
        rule.taken(1, now);
        assert_eq!(rule.robot(), Some(robot_at(5000)));
        // the robot's host, another port: another process on the robot's host is not the robot's stream
        assert!(rule.admit(&RobotState::idle(2).encode(), robot_at(5001), now).is_none());
        assert_eq!(rule.dropped().foreign, 2);
        assert!(
            matches!(rule.dropped().last, Some(Dropped::Foreign { robot, .. }) if robot == robot_at(5000))
        );
    }

    #[test]
    fn a_datagram_of_another_size_is_counted_with_both_sizes_never_fatal() {
        let mut rule = StateAdmission::new(robot_at(1337).ip());
        let now = Instant::now();
        assert!(rule.admit(&[0u8; 10], robot_at(5000), now).is_none());
        assert_eq!(rule.dropped().malformed, 1);
        let text = rule.dropped().last.expect("a reason").to_string();
        assert!(text.contains("10") && text.contains("1377"), "{text}");
        assert!(rule.robot().is_none(), "a datagram that is no state does not fix the robot's port");
        assert!(rule.admit(&RobotState::idle(1).encode(), robot_at(5000), now).is_some());
    }

    #[test]
    fn ids_advance_by_the_robots_cycles_and_a_jump_is_refused_not_followed() {
        let mut rule = StateAdmission::new(robot_at(1337).ip());
        let start = Instant::now();
        let robot = robot_at(5000);
        assert!(rule.admit(&RobotState::idle(1_000).encode(), robot, start).is_some(), "any first id");
        rule.taken(1_000, start);
        let later = start + Duration::from_millis(100);
        // 100 ms: up to 110 cycles + the slack
        assert!(rule.admit(&RobotState::idle(1_000 + 160).encode(), robot, later).is_some());
        assert!(rule.admit(&RobotState::idle(1_000 + 161).encode(), robot, later).is_none());
        assert!(rule.admit(&RobotState::idle(u64::MAX).encode(), robot, later).is_none());
        assert_eq!(rule.dropped().id_jumps, 2);
        let text = rule.dropped().last.expect("a reason").to_string();
        assert!(text.contains("100 ms") && text.contains("160"), "{text}");
        // after a long silence (a motion stopped), the robot's count since is taken
        let much_later = start + Duration::from_secs(10);
        assert!(rule.admit(&RobotState::idle(1_000 + 10_000).encode(), robot, much_later).is_some());
    }
}
