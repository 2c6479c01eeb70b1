//! The one admission of a sealed stream that moves the arm (the vision node's `features` to the servo, the servo's
//! `camera_twist` to the rmrc): a sample taken off its subscriber is taken only if it is of this schema
//! ([`crate::inbox`]), sealed with the instance's key ([`crate::seal`]), sent by the writer the daemon announces
//! and sealed in its run now, and fresh ([`crate::freshness::stream_standing`]), all in one call,
//! [`SealedStream::admit`]. The consumer decides what a refusal does (hold the arm, or keep what is in force);
//! no node writes these checks again (tests/tests/architecture.rs holds it).

use crate::freshness::{Origin, Standing, stream_standing};
use crate::inbox::{Payload, Refused};
use crate::seal::{SealKey, Sealed, sealed_by};
use crate::{CameraTwistMsg, FeaturesMsg};

/// A sample of a sealed stream: stamped by its writer as it publishes, and naming the writer's run.
pub trait StreamSample: Payload + Sealed {
    /// When its writer published it (ns, CLOCK_MONOTONIC).
    fn published_ns(&self) -> u64;
    /// The writer's process id, under the seal.
    fn writer_run(&self) -> u32;
}

impl StreamSample for FeaturesMsg {
    fn published_ns(&self) -> u64 {
        self.stamp_ns
    }
    fn writer_run(&self) -> u32 {
        self.writer_pid
    }
}

impl StreamSample for CameraTwistMsg {
    fn published_ns(&self) -> u64 {
        self.stamp_ns
    }
    fn writer_run(&self) -> u32 {
        self.writer_pid
    }
}

/// Why a sample of a sealed stream was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotTaken {
    /// Of another schema.
    Schema(Refused),
    /// Without the instance's seal: not the writer's.
    Unsealed,
    /// Sealed, but not to be taken now: not the announced writer's of its run now (`Foreign`: the stream is
    /// taken), stale, older than the last taken, from the future, or the one in force again.
    Standing(Standing),
}

impl NotTaken {
    /// Whether the refusal shows that the stream is not the writer's any more (another schema or another
    /// process in the writer's slot): the arm is to be brought to rest, not left on what is in force.
    pub fn stream_taken(self) -> bool {
        matches!(self, NotTaken::Schema(_) | NotTaken::Standing(Standing::Foreign))
    }
}

/// A consumer's side of one sealed stream: the newest sample it took, and how old a sample may be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SealedStream {
    last_taken_ns: Option<u64>,
    max_age_ns: u64,
}

impl SealedStream {
    /// A stream whose samples are refused once older than `max_age_ns` (its writer's period, or what the
    /// consumer allows).
    pub fn new(max_age_ns: u64) -> Self {
        Self { last_taken_ns: None, max_age_ns }
    }

    /// Admits a sample as a subscriber gave it (`taken`, and the process that sent it): of this schema, sealed
    /// with `key`, from the writer `announced` (its process id, 0: none announced) of its run now, and fresh at
    /// `now_ns`. A sample taken becomes the newest; a refused one changes nothing.
    pub fn admit<M: StreamSample>(
        &mut self,
        (taken, sender): (Result<M, Refused>, Option<i32>),
        key: Option<&SealKey>,
        announced: u32,
        now_ns: u64,
    ) -> Result<M, NotTaken> {
        let sample = taken.map_err(NotTaken::Schema)?;
        if !sealed_by(key, &sample) {
            return Err(NotTaken::Unsealed);
        }
        let origin = Origin { announced, carried: sample.writer_run(), sender };
        match stream_standing(origin, self.last_taken_ns, sample.published_ns(), now_ns, self.max_age_ns) {
            Standing::Newer => {
                self.last_taken_ns = Some(sample.published_ns());
                Ok(sample)
            }
            standing => Err(NotTaken::Standing(standing)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seal::{SealKey, sign_with};

    const WRITER: u32 = 4242;
    const NOW: u64 = 50_000_000_000;
    const PERIOD: u64 = 85_000_000;

    fn twist(key: &SealKey, stamp_ns: u64, writer_pid: u32) -> CameraTwistMsg {
        // every field a number (a NaN would make two equal twists unequal)
        let mut message =
            CameraTwistMsg { stamp_ns, writer_pid, feature_error_px: 0.0, ..CameraTwistMsg::default() };
        sign_with(Some(key), &mut message);
        message
    }

    #[test]
    fn a_sample_is_taken_only_sealed_from_the_announced_writer_fresh_and_newer() {
        let key = SealKey::from_hex("ab".repeat(16).as_bytes()).expect("a key");
        let other_key = SealKey::from_hex("cd".repeat(16).as_bytes()).expect("a key");
        let mut stream = SealedStream::new(PERIOD);
        let sent = Some(WRITER as i32);
        let fresh = twist(&key, NOW - 1_000, WRITER);
        assert_eq!(stream.admit((Ok(fresh), sent), Some(&key), WRITER, NOW), Ok(fresh));
        // the same again, an older one, one of another key, a stale one: refused, the newest kept
        assert_eq!(
            stream.admit((Ok(fresh), sent), Some(&key), WRITER, NOW),
            Err(NotTaken::Standing(Standing::Older))
        );
        let older = twist(&key, NOW - 2_000, WRITER);
        assert_eq!(
            stream.admit((Ok(older), sent), Some(&key), WRITER, NOW),
            Err(NotTaken::Standing(Standing::Older))
        );
        let forged = twist(&other_key, NOW, WRITER);
        assert_eq!(stream.admit((Ok(forged), sent), Some(&key), WRITER, NOW), Err(NotTaken::Unsealed));
        assert_eq!(stream.admit((Ok(fresh), sent), None, WRITER, NOW), Err(NotTaken::Unsealed));
        let replayed = twist(&key, NOW - 2 * PERIOD, WRITER);
        let mut replay_stream = SealedStream::new(PERIOD);
        assert_eq!(
            replay_stream.admit((Ok(replayed), sent), Some(&key), WRITER, NOW),
            Err(NotTaken::Standing(Standing::Stale))
        );
        // another process in the writer's slot, or a sample of the writer's earlier run: the stream is taken
        let newer = twist(&key, NOW, WRITER);
        let foreign = stream.admit((Ok(newer), Some(777)), Some(&key), WRITER, NOW).expect_err("foreign");
        assert_eq!(foreign, NotTaken::Standing(Standing::Foreign));
        assert!(foreign.stream_taken());
        let earlier_run = twist(&key, NOW, 4241);
        assert!(
            stream
                .admit((Ok(earlier_run), sent), Some(&key), WRITER, NOW)
                .expect_err("old run")
                .stream_taken()
        );
        let schema = Err(Refused::Schema { found: 1 });
        let refused =
            stream.admit::<CameraTwistMsg>((schema, sent), Some(&key), WRITER, NOW).expect_err("schema");
        assert!(refused.stream_taken() && !NotTaken::Unsealed.stream_taken());
        // the newer one of the writer's is taken after all that
        assert_eq!(stream.admit((Ok(newer), sent), Some(&key), WRITER, NOW), Ok(newer));
    }
}
