//! When the daemon frees what dead processes left in the instance's shared memory: at once after a node
//! was lost, and every [`CLEANUP_EVERY`] for clients that died (a client killed while it held a command
//! slot, a subscriber of a crashed `vservoctl echo`). Pure: time is passed in.

use std::time::{Duration, Instant};

/// How often the daemon frees what processes that died left behind.
pub const CLEANUP_EVERY: Duration = Duration::from_secs(2);

/// Why a cleanup is due.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cleanup {
    /// A node was lost this cycle.
    NodeLost,
    /// The periodic sweep for dead clients.
    Periodic,
}

/// The cleanup's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CleanupClock {
    last: Instant,
}

impl CleanupClock {
    /// The last cleanup at `now` (the daemon's start does one).
    pub fn new(now: Instant) -> Self {
        Self { last: now }
    }

    /// Whether a cleanup is due at `now`, a node having been lost this cycle or not; a due one counts as
    /// done.
    pub fn due(&mut self, now: Instant, node_lost: bool) -> Option<Cleanup> {
        let due = if node_lost {
            Cleanup::NodeLost
        } else if now.duration_since(self.last) >= CLEANUP_EVERY {
            Cleanup::Periodic
        } else {
            return None;
        };
        self.last = now;
        Some(due)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lost_node_is_cleaned_up_at_once_and_dead_clients_every_two_seconds() {
        let t0 = Instant::now();
        let mut clock = CleanupClock::new(t0);
        assert_eq!(clock.due(t0 + CLEANUP_EVERY / 2, false), None);
        assert_eq!(clock.due(t0 + CLEANUP_EVERY / 2, true), Some(Cleanup::NodeLost));
        assert_eq!(clock.due(t0 + CLEANUP_EVERY, false), None, "counted from the last one");
        assert_eq!(clock.due(t0 + CLEANUP_EVERY * 3 / 2, false), Some(Cleanup::Periodic));
        assert_eq!(clock.due(t0 + CLEANUP_EVERY * 3 / 2, false), None);
    }
}
