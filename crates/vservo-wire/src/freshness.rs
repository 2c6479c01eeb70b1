//! Which of the daemon's sealed messages is newer: the one rule the nodes follow for `cell_mode`, `gains` and
//! `object` (docs/PROTOCOL.md, "Seals"); and which sealed sample of a stream that moves the arm (`features`,
//! `camera_twist`) is fresh ([`stream_standing`]).
//!
//! A node takes the daemon's `cell_mode`, `gains` and `object` only when newer than the one in force, so that
//! a replayed older message (sealed: anyone of the daemon's user can record one and publish it again) is
//! refused. "Newer" must never let one message lock the daemon out: with a plain `counter > in force`, a
//! forged counter near 2⁶⁴ (which needs the key) would be obeyed and the daemon could never publish a greater
//! one. So:
//!
//! 1. A message stamped (CLOCK_MONOTONIC, ns — the daemon and its nodes share one host and one clock) more
//!    than [`FUTURE_TOLERANCE_NS`] after the node's own clock is refused: nothing the daemon sent can be from
//!    the future.
//! 2. The first message a node hears is taken (a node that starts or restarts runs what the daemon says now).
//! 3. A later stamp is newer, an earlier one older (a replay): whatever the counters say. A forged stamp can be
//!    ahead of the daemon's by at most the tolerance; the daemon's next message after that is newer.
//! 4. For equal stamps (and for the messages that carry no stamp, `gains` and `object`, where the stamp is
//!    taken as 0) the counters decide in serial-number arithmetic (RFC 1982) over a bounded window: a counter
//!    is newer when it is at most [`COUNTER_WINDOW`] ahead of the one in force, modulo 2⁶⁴. A counter far
//!    ahead (2⁶⁴ − 2 after 2) is refused, and when one was taken (the first message heard), the daemon's next
//!    small counter is again "just ahead" of it, modulo 2⁶⁴, and taken. The counters stay what people see
//!    (`gains v3`, the cell mode's sequence).
//!
//! Without a stamp (rule 4 alone) a key holder can still hold a node back for up to [`COUNTER_WINDOW`] of the
//! daemon's messages by forging a counter just inside the window; with the stamp (rule 3) for no longer than
//! the tolerance. The key is what keeps that out of reach (`seal`: the daemon and its nodes are not dumpable,
//! the key's text is wiped once parsed).

/// How far a stamp may be ahead of the receiving node's clock (ns): the daemon stamps a message before it
/// publishes it on the same host's CLOCK_MONOTONIC, so this is slack, not a delay.
pub const FUTURE_TOLERANCE_NS: u64 = 10_000_000;

/// How far ahead (modulo 2⁶⁴) a counter may be of the one in force and still be newer, when the stamps do not
/// decide: far more messages than a node can miss while it runs (one per reload, target or safe stop).
pub const COUNTER_WINDOW: u64 = 1 << 16;

/// What orders one of the daemon's sealed messages: its CLOCK_MONOTONIC stamp (0 for a message without one)
/// and its counter (sequence or version).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Issue {
    /// CLOCK_MONOTONIC when the daemon made it (ns); 0 when the message carries no stamp.
    pub stamp_ns: u64,
    /// Its sequence number or version.
    pub counter: u64,
}

/// A message's standing against the one in force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Standing {
    /// Newer: take it.
    Newer,
    /// The one in force again (a history sample, a repeat): nothing to do, nothing to count.
    Same,
    /// Older (a replay) or too far ahead: refuse it.
    Older,
    /// Stamped after the node's own clock by more than the tolerance: refuse it.
    FromTheFuture,
    /// A stream's sample stamped longer ago than the stream's bound (a recording played again): refuse it.
    Stale,
    /// A stream's sample not from the writer the daemon announces, of its run now (another process in the
    /// writer's slot, or a sample of an earlier run): refuse it, and hold (the stream is taken).
    Foreign,
}

impl Standing {
    /// Whether the message is to be taken.
    pub fn is_newer(self) -> bool {
        self == Standing::Newer
    }

    /// Whether the message is to be refused (and counted).
    pub fn is_refused(self) -> bool {
        matches!(self, Standing::Older | Standing::FromTheFuture | Standing::Stale | Standing::Foreign)
    }
}

/// Who a sealed sample of a stream that moves the arm comes from, as its consumer sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Origin {
    /// The writer's process the daemon announces (`cell_mode.writers`; 0: none runs, or none announced yet).
    pub announced: u32,
    /// The writer's run the sample carries under its seal (`writer_pid`).
    pub carried: u32,
    /// The process that sent it, from the sample's header (`None`: it cannot be told).
    pub sender: Option<i32>,
}

impl Origin {
    /// Whether the sample is the announced writer's, of its run now: sent by that process and sealed in its run.
    pub fn is_the_writers(&self) -> bool {
        let sender = self.sender.and_then(|pid| u32::try_from(pid).ok());
        self.announced != 0 && self.carried == self.announced && sender == Some(self.announced)
    }
}

/// The standing of a sealed sample of a stream that moves the arm (a `features` or a `camera_twist`, stamped by
/// its node as it publishes: `stamp_ns`) for the node that takes it: refused when it is not the announced
/// writer's of its run now (`Foreign`: another process in the writer's slot, or a sample of the writer's
/// earlier run), stamped more than [`FUTURE_TOLERANCE_NS`] after `now_ns` or longer than `max_age_ns` before it
/// (`Stale`: the seal proves who made a message, not when; a recording of sealed samples played again into a
/// writer slot taken while the node restarts is stale), or not after the last one taken (`Older`: a sample
/// again, or out of order); else newer.
pub fn stream_standing(
    origin: Origin,
    last_taken_ns: Option<u64>,
    stamp_ns: u64,
    now_ns: u64,
    max_age_ns: u64,
) -> Standing {
    if !origin.is_the_writers() {
        return Standing::Foreign;
    }
    if stamp_ns > now_ns.saturating_add(FUTURE_TOLERANCE_NS) {
        return Standing::FromTheFuture;
    }
    if now_ns.saturating_sub(stamp_ns) > max_age_ns {
        return Standing::Stale;
    }
    match last_taken_ns {
        Some(last) if stamp_ns <= last => Standing::Older,
        _ => Standing::Newer,
    }
}

/// The standing of `candidate` against `in_force` (none yet: the node has taken nothing), with `now_ns` the
/// receiving node's CLOCK_MONOTONIC.
pub fn standing(in_force: Option<Issue>, candidate: Issue, now_ns: u64) -> Standing {
    if candidate.stamp_ns > now_ns.saturating_add(FUTURE_TOLERANCE_NS) {
        return Standing::FromTheFuture;
    }
    let Some(in_force) = in_force else {
        return Standing::Newer;
    };
    match candidate.stamp_ns.cmp(&in_force.stamp_ns) {
        std::cmp::Ordering::Greater => Standing::Newer,
        std::cmp::Ordering::Less => Standing::Older,
        std::cmp::Ordering::Equal => match candidate.counter.wrapping_sub(in_force.counter) {
            0 => Standing::Same,
            ahead if ahead <= COUNTER_WINDOW => Standing::Newer,
            _ => Standing::Older,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NOW: u64 = 5_000_000_000_000;

    fn issue(stamp_ns: u64, counter: u64) -> Issue {
        Issue { stamp_ns, counter }
    }

    #[test]
    fn the_first_message_is_taken_and_a_newer_one_after_it() {
        assert_eq!(standing(None, issue(NOW - 10, 1), NOW), Standing::Newer);
        assert_eq!(standing(Some(issue(NOW - 10, 1)), issue(NOW - 5, 2), NOW), Standing::Newer);
        assert_eq!(standing(Some(issue(NOW - 10, 1)), issue(NOW - 10, 1), NOW), Standing::Same);
    }

    #[test]
    fn a_replayed_older_message_is_refused() {
        // stamped: the earlier stamp is older, whatever its counter
        let in_force = issue(NOW - 10, 7);
        assert_eq!(standing(Some(in_force), issue(NOW - 20, 6), NOW), Standing::Older);
        assert_eq!(standing(Some(in_force), issue(NOW - 20, 8), NOW), Standing::Older);
        // unstamped (gains, object): the smaller counter
        assert_eq!(standing(Some(issue(0, 7)), issue(0, 6), NOW), Standing::Older);
        assert_eq!(standing(Some(issue(0, 7)), issue(0, 1), NOW), Standing::Older);
    }

    #[test]
    fn a_counter_of_2_pow_64_minus_2_locks_nobody_out() {
        let forged = u64::MAX - 1;
        // stamped (cell_mode): a forged mode with the greatest counter and a stamp as late as allowed …
        let in_force = issue(NOW - 1_000, 2);
        let forgery = issue(NOW + FUTURE_TOLERANCE_NS, forged);
        assert_eq!(standing(Some(in_force), forgery, NOW), Standing::Newer);
        // … is overtaken by the daemon's next mode, sequence 3, once the tolerance has passed
        let later = NOW + FUTURE_TOLERANCE_NS + 1;
        assert_eq!(standing(Some(forgery), issue(later, 3), later), Standing::Newer);
        // a forged stamp further ahead is refused outright
        assert_eq!(
            standing(Some(in_force), issue(NOW + 3_600_000_000_000, forged), NOW),
            Standing::FromTheFuture
        );
        // unstamped (gains, object): refused by a node that has taken version 2 …
        assert_eq!(standing(Some(issue(0, 2)), issue(0, forged), NOW), Standing::Older);
        // … and when taken as the first message heard, the daemon's next small version is newer modulo 2⁶⁴
        assert_eq!(standing(None, issue(0, forged), NOW), Standing::Newer);
        assert_eq!(standing(Some(issue(0, forged)), issue(0, 3), NOW), Standing::Newer);
        assert_eq!(standing(Some(issue(0, u64::MAX)), issue(0, 1), NOW), Standing::Newer);
    }

    #[test]
    fn counters_newer_within_the_window_only() {
        let in_force = Some(issue(0, 10));
        assert_eq!(standing(in_force, issue(0, 10 + COUNTER_WINDOW), NOW), Standing::Newer);
        assert_eq!(standing(in_force, issue(0, 11 + COUNTER_WINDOW), NOW), Standing::Older);
        assert_eq!(standing(in_force, issue(0, 9), NOW), Standing::Older);
    }

    #[test]
    fn a_stamp_from_the_future_is_refused_even_as_the_first_message() {
        let ahead = NOW + FUTURE_TOLERANCE_NS + 1;
        assert_eq!(standing(None, issue(ahead, 1), NOW), Standing::FromTheFuture);
        assert!(standing(None, issue(ahead, 1), NOW).is_refused());
        assert!(!standing(Some(issue(NOW, 1)), issue(NOW, 1), NOW).is_refused());
        // the node's clock near its end: no overflow
        assert_eq!(standing(None, issue(u64::MAX, 1), u64::MAX - 1), Standing::Newer);
    }

    /// The security review's replay: sealed twists recorded earlier and played again into a taken slot.
    #[test]
    fn a_streams_stale_repeated_or_future_sample_is_refused_and_a_fresh_one_taken() {
        let frame = 85_000_000;
        const WRITER: Origin = Origin { announced: 7, carried: 7, sender: Some(7) };
        assert_eq!(stream_standing(WRITER, None, NOW - 1_000, NOW, frame), Standing::Newer);
        assert_eq!(stream_standing(WRITER, Some(NOW - 90_000_000), NOW - 1_000, NOW, frame), Standing::Newer);
        // recorded a second ago
        assert_eq!(stream_standing(WRITER, None, NOW - 1_000_000_000, NOW, frame), Standing::Stale);
        // the one taken, again; or one before it
        assert_eq!(stream_standing(WRITER, Some(NOW - 1_000), NOW - 1_000, NOW, frame), Standing::Older);
        assert_eq!(stream_standing(WRITER, Some(NOW - 1_000), NOW - 2_000, NOW, frame), Standing::Older);
        assert_eq!(
            stream_standing(WRITER, None, NOW + 2 * FUTURE_TOLERANCE_NS, NOW, frame),
            Standing::FromTheFuture
        );
        assert!(Standing::Stale.is_refused());
    }

    #[test]
    fn a_streams_sample_is_taken_from_its_announced_writer_of_its_run_now_only() {
        let writer = Origin { announced: 4242, carried: 4242, sender: Some(4242) };
        let stream = |origin: Origin| stream_standing(origin, Some(NOW - 50), NOW - 10, NOW, 100);
        assert_eq!(stream(writer), Standing::Newer);
        // another process in the writer's slot, replaying the writer's own sealed samples
        assert_eq!(stream(Origin { sender: Some(999), ..writer }), Standing::Foreign);
        // the writer's earlier run (sealed with its old pid), however it is sent
        assert_eq!(stream(Origin { carried: 4100, ..writer }), Standing::Foreign);
        // no writer announced (none runs, or the daemon has not said yet), or a sender that cannot be told
        assert_eq!(stream(Origin { announced: 0, carried: 0, sender: Some(0) }), Standing::Foreign);
        assert_eq!(stream(Origin { sender: None, ..writer }), Standing::Foreign);
        assert!(Standing::Foreign.is_refused());
        // the writer's own: the other rules as before
        assert_eq!(stream_standing(writer, Some(NOW - 10), NOW - 10, NOW, 100), Standing::Older);
        assert_eq!(stream_standing(writer, None, NOW - 200, NOW, 100), Standing::Stale);
    }
}
