//! The capture stamp: a buffer's presentation timestamp mapped to CLOCK_MONOTONIC.
//!
//! GStreamer stamps a buffer with its PTS in the stream's segment. The segment turns it into running time,
//! and running time plus the pipeline's base time is the pipeline clock's time at which the frame was
//! captured (a live source stamps the capture in running time: `v4l2src` from the kernel's buffer stamp,
//! `aravissrc` from the camera's, a source with `do-timestamp=true` at the buffer's arrival in GStreamer).
//! The driver makes the pipeline clock GStreamer's system clock with `clock-type` monotonic, which reads
//! `clock_gettime(CLOCK_MONOTONIC)`: the offset between the two clocks is then zero, and
//! [`ClockMapping::clock_minus_monotonic_ns`] carries it for any other clock.
//!
//! A buffer without a PTS (a source that does not timestamp) gets its arrival at the appsink, and so does a
//! stamp later than the arrival (a non-live source running ahead of the clock); each is counted.

/// How pipeline clock time relates to CLOCK_MONOTONIC.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClockMapping {
    /// The pipeline's base time: the clock time at running time 0 (ns).
    pub base_time_ns: u64,
    /// The pipeline clock's time minus CLOCK_MONOTONIC's at the same instant (ns): 0 with the monotonic
    /// system clock.
    pub clock_minus_monotonic_ns: i64,
}

/// Where a capture stamp came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StampSource {
    /// The buffer's PTS, mapped to CLOCK_MONOTONIC.
    Buffer,
    /// The buffer had no PTS (or no running time): its arrival.
    ArrivalNoTimestamp,
    /// The mapped PTS lay after the arrival: the arrival instead.
    ArrivalClamped,
}

/// A frame's capture stamp on CLOCK_MONOTONIC (ns) and where it came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CaptureStamp {
    /// CLOCK_MONOTONIC at capture (ns); never later than the arrival.
    pub monotonic_ns: u64,
    /// Its origin.
    pub source: StampSource,
}

/// The capture stamp of a frame whose PTS is `running_time_ns` in running time (None: no timestamp),
/// taken from the appsink at `arrival_ns` (CLOCK_MONOTONIC).
pub fn capture_stamp(mapping: ClockMapping, running_time_ns: Option<u64>, arrival_ns: u64) -> CaptureStamp {
    let arrival = |source| CaptureStamp { monotonic_ns: arrival_ns, source };
    let Some(running_time_ns) = running_time_ns else { return arrival(StampSource::ArrivalNoTimestamp) };
    let clock_time_ns = i128::from(mapping.base_time_ns) + i128::from(running_time_ns);
    let monotonic_ns = clock_time_ns - i128::from(mapping.clock_minus_monotonic_ns);
    match u64::try_from(monotonic_ns) {
        Ok(ns) if ns <= arrival_ns => CaptureStamp { monotonic_ns: ns, source: StampSource::Buffer },
        Ok(_) => arrival(StampSource::ArrivalClamped),
        // before CLOCK_MONOTONIC's zero: not a capture time
        Err(_) => arrival(StampSource::ArrivalNoTimestamp),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MONOTONIC: ClockMapping = ClockMapping { base_time_ns: 5_000_000_000, clock_minus_monotonic_ns: 0 };

    #[test]
    fn base_time_plus_running_time_on_the_monotonic_clock() {
        let stamp = capture_stamp(MONOTONIC, Some(1_500_000), 5_010_000_000);
        assert_eq!(stamp, CaptureStamp { monotonic_ns: 5_001_500_000, source: StampSource::Buffer });
    }

    #[test]
    fn another_clock_is_shifted_by_its_offset() {
        let ahead = ClockMapping { base_time_ns: 7_000_000_000, clock_minus_monotonic_ns: 2_000_000_000 };
        let stamp = capture_stamp(ahead, Some(1_000), 5_000_010_000);
        assert_eq!(stamp.monotonic_ns, 5_000_001_000);
        let behind = ClockMapping { base_time_ns: 1_000, clock_minus_monotonic_ns: -3_000 };
        assert_eq!(capture_stamp(behind, Some(0), 10_000).monotonic_ns, 4_000);
    }

    #[test]
    fn no_timestamp_gets_the_arrival_flagged() {
        let stamp = capture_stamp(MONOTONIC, None, 42);
        assert_eq!(stamp, CaptureStamp { monotonic_ns: 42, source: StampSource::ArrivalNoTimestamp });
    }

    #[test]
    fn a_stamp_after_the_arrival_is_clamped_to_it() {
        let stamp = capture_stamp(MONOTONIC, Some(20_000_000), 5_010_000_000);
        assert_eq!(stamp, CaptureStamp { monotonic_ns: 5_010_000_000, source: StampSource::ArrivalClamped });
    }

    #[test]
    fn extreme_values_neither_overflow_nor_panic() {
        let far = ClockMapping { base_time_ns: u64::MAX, clock_minus_monotonic_ns: i64::MIN };
        assert_eq!(capture_stamp(far, Some(u64::MAX), 7).monotonic_ns, 7);
        let early = ClockMapping { base_time_ns: 0, clock_minus_monotonic_ns: i64::MAX };
        assert_eq!(capture_stamp(early, Some(0), 7).source, StampSource::ArrivalNoTimestamp);
    }
}
