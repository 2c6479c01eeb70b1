//! The safe-stop path as the daemon hears it (docs/PROTOCOL.md, "The safe-stop path"): the FIFO
//! `safe_stop` in the instance's directory, drained without blocking every supervisor cycle. Any byte asks
//! for a safe stop (fault `requested`); the log says so once per burst of requests (bytes in cycles less
//! than [`QUIET`] apart) and, when a burst of more than one cycle ends, how many requests it held. A flood
//! can only keep the cell stopped, which is safe.

use std::time::{Duration, Instant};

/// Requests this far apart belong to separate bursts.
pub const QUIET: Duration = Duration::from_secs(1);

/// What a cycle's bytes mean for the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BurstEvent {
    /// The first requests after a quiet time: log them.
    Began,
    /// A burst ended (quiet for [`QUIET`]) after more than its first cycle: how many bytes it held.
    Ended {
        /// Bytes (requests) in the whole burst.
        requests: u64,
    },
}

/// Groups the requests into bursts.
#[derive(Debug, Clone, Default)]
pub struct Bursts {
    /// The latest cycle with bytes, and the bytes of the burst so far.
    current: Option<(Instant, u64, u32)>,
}

impl Bursts {
    /// Takes one cycle's `bytes` at `now`; what to log, if anything.
    pub fn on_cycle(&mut self, bytes: usize, now: Instant) -> Option<BurstEvent> {
        let bytes = bytes as u64;
        match (self.current, bytes) {
            (None, 0) => None,
            (None, n) => {
                self.current = Some((now, n, 1));
                Some(BurstEvent::Began)
            }
            (Some((last, total, cycles)), 0) => {
                if now.duration_since(last) < QUIET {
                    return None;
                }
                self.current = None;
                (cycles > 1).then_some(BurstEvent::Ended { requests: total })
            }
            (Some((_, total, cycles)), n) => {
                self.current = Some((now, total + n, cycles + 1));
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CYCLE: Duration = Duration::from_millis(50);

    #[test]
    fn a_burst_is_logged_once_when_it_begins_and_counted_when_it_ends() {
        let t0 = Instant::now();
        let mut bursts = Bursts::default();
        assert_eq!(bursts.on_cycle(0, t0), None, "quiet");
        assert_eq!(bursts.on_cycle(1, t0 + CYCLE), Some(BurstEvent::Began));
        // a flood: bytes every cycle for 2 s, not one more line
        for k in 2..42 {
            assert_eq!(bursts.on_cycle(4096, t0 + CYCLE * k), None);
        }
        // quiet, but not yet long enough
        assert_eq!(bursts.on_cycle(0, t0 + CYCLE * 50), None);
        assert_eq!(
            bursts.on_cycle(0, t0 + CYCLE * 62),
            Some(BurstEvent::Ended { requests: 1 + 40 * 4096 }),
            "the count at the end"
        );
        assert_eq!(bursts.on_cycle(0, t0 + CYCLE * 63), None);
        // a new request after the quiet time is a new burst; a single one ends without a count
        assert_eq!(bursts.on_cycle(1, t0 + CYCLE * 70), Some(BurstEvent::Began));
        assert_eq!(bursts.on_cycle(0, t0 + CYCLE * 70 + QUIET), None);
        assert_eq!(bursts.on_cycle(1, t0 + CYCLE * 71 + QUIET), Some(BurstEvent::Began));
    }
}
