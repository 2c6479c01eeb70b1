//! # vservo-time — the one clock and the one conversion
//!
//! Every stamp vservo writes is the host's CLOCK_MONOTONIC in whole nanoseconds ([`monotonic_ns`]; the daemon,
//! its nodes and the drivers share one host), and every period or timeout the configuration gives in seconds
//! becomes nanoseconds here, rounded to the nearest, never truncated ([`Nanos::from_seconds`]), and back
//! ([`Nanos::seconds`], [`seconds_between`]). No other code multiplies or divides by 10⁹
//! (tests/tests/architecture.rs holds it).

/// Nanoseconds in a second.
pub const NANOS_PER_SECOND: u64 = 1_000_000_000;

/// A span of time (or a stamp on CLOCK_MONOTONIC) in whole nanoseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Nanos(pub u64);

impl Nanos {
    /// `seconds` in nanoseconds, rounded to the nearest; a negative or NaN span is none, one beyond `u64` (585
    /// years) the largest.
    pub fn from_seconds(seconds: f64) -> Self {
        let ns = (seconds * NANOS_PER_SECOND as f64).round();
        // `as` saturates: NaN to 0, beyond the range to its ends
        Self(if ns > 0.0 { ns as u64 } else { 0 })
    }

    /// The span of `periods` of `seconds` each (a timeout counted in periods), rounded once.
    pub fn from_periods(periods: f64, seconds: f64) -> Self {
        Self::from_seconds(periods * seconds)
    }

    /// A rate's period: one over `hertz`, rounded (none for a rate that is not positive and finite).
    pub fn period_of_hz(hertz: f64) -> Self {
        if hertz > 0.0 && hertz.is_finite() { Self::from_seconds(1.0 / hertz) } else { Self(0) }
    }

    /// In seconds.
    pub fn seconds(self) -> f64 {
        self.0 as f64 / NANOS_PER_SECOND as f64
    }

    /// The nanoseconds.
    pub fn get(self) -> u64 {
        self.0
    }

    /// Whole seconds and the nanoseconds past them (a `timespec`, a ROS `Time`).
    pub fn split(self) -> (u64, u32) {
        (self.0 / NANOS_PER_SECOND, (self.0 % NANOS_PER_SECOND) as u32)
    }

    /// From whole seconds and the nanoseconds past them (saturating).
    pub fn from_parts(seconds: u64, nanos: u32) -> Self {
        Self(seconds.saturating_mul(NANOS_PER_SECOND).saturating_add(u64::from(nanos)))
    }
}

/// The seconds from `earlier_ns` to `later_ns` (two stamps; none when `later_ns` is earlier).
pub fn seconds_between(later_ns: u64, earlier_ns: u64) -> f64 {
    Nanos(later_ns.saturating_sub(earlier_ns)).seconds()
}

/// A signed count of nanoseconds (a difference of two clocks, a time since 1970) as whole seconds, rounded down,
/// and the nanoseconds past them.
pub fn split_signed(ns: i128) -> (i128, u32) {
    let per_second = i128::from(NANOS_PER_SECOND);
    (ns.div_euclid(per_second), ns.rem_euclid(per_second) as u32)
}

/// A signed count of nanoseconds (an age that may be negative) in seconds.
pub fn signed_seconds(ns: i128) -> f64 {
    ns as f64 / NANOS_PER_SECOND as f64
}

/// Whole seconds and the nanoseconds past them as one signed count of nanoseconds.
pub fn join_signed(seconds: i128, nanos: u32) -> i128 {
    seconds * i128::from(NANOS_PER_SECOND) + i128::from(nanos)
}

/// `seconds` in nanoseconds ([`Nanos::from_seconds`]).
pub fn nanos(seconds: f64) -> u64 {
    Nanos::from_seconds(seconds).0
}

/// CLOCK_MONOTONIC now (ns).
pub fn monotonic_ns() -> u64 {
    // clock_gettime(CLOCK_MONOTONIC) cannot fail on Linux with a valid clock id
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .map(|t| Nanos::from_parts(t.tv_sec() as u64, t.tv_nsec() as u32).0)
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn seconds_become_the_nearest_nanosecond_never_truncated() {
        assert_eq!(Nanos::from_seconds(0.001), Nanos(1_000_000));
        assert_eq!(Nanos::from_seconds(0.085), Nanos(85_000_000));
        // 0.0029999999999 s is 2,999,999.9999 ns: truncation would give 2,999,999
        assert_eq!(Nanos::from_seconds(0.002_999_999_999_9), Nanos(3_000_000));
        assert_eq!(Nanos::from_seconds(-1.0), Nanos(0));
        assert_eq!(Nanos::from_seconds(f64::NAN), Nanos(0));
        assert_eq!(Nanos::from_seconds(f64::INFINITY), Nanos(u64::MAX));
        assert_eq!(Nanos::period_of_hz(100.0), Nanos(10_000_000));
        assert_eq!(Nanos::period_of_hz(0.0), Nanos(0));
        assert_eq!(Nanos::from_periods(2.0, 0.085), Nanos(170_000_000));
        assert_eq!(seconds_between(3_500_000_000, 1_000_000_000), 2.5);
        assert_eq!(seconds_between(1, 2), 0.0);
        assert_eq!(Nanos(12_345_678_901).split(), (12, 345_678_901));
        assert_eq!(split_signed(-1), (-1, 999_999_999));
        assert_eq!(join_signed(-1, 999_999_999), -1);
        assert_eq!(signed_seconds(-1_500_000_000), -1.5);
    }

    #[test]
    fn the_clock_runs_forwards() {
        let (first, second) = (monotonic_ns(), monotonic_ns());
        assert!(first > 0 && second >= first);
    }

    proptest! {
        #[test]
        fn a_whole_nanosecond_span_goes_to_seconds_and_back_unchanged(ns in 0u64..(1u64 << 48)) {
            prop_assert_eq!(Nanos::from_seconds(Nanos(ns).seconds()), Nanos(ns));
            let (seconds, nanos) = Nanos(ns).split();
            prop_assert_eq!(Nanos::from_parts(seconds, nanos), Nanos(ns));
        }
    }
}
