//! CLOCK_MONOTONIC time and a periodic timer with absolute deadlines that skips (and counts) missed periods.

use nix::sys::time::TimeSpec;
use nix::time::{ClockId, ClockNanosleepFlags, clock_nanosleep};

use vservo_time::monotonic_ns;

/// Sleeps until CLOCK_MONOTONIC reaches `deadline_ns` (absolute, so a late wake-up never shifts the next).
pub fn sleep_until_ns(deadline_ns: u64) {
    let (seconds, nanos) = vservo_time::Nanos(deadline_ns).split();
    let request = TimeSpec::new(seconds as i64, i64::from(nanos));
    // EINTR (a signal) returns early: sleep again unless the deadline has passed
    while clock_nanosleep(ClockId::CLOCK_MONOTONIC, ClockNanosleepFlags::TIMER_ABSTIME, &request).is_err() {
        if monotonic_ns() >= deadline_ns {
            break;
        }
    }
}

/// One wake-up of a [`PeriodicTimer`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wake {
    /// The deadline this wake-up was for (ns).
    pub deadline_ns: u64,
    /// How late after it the thread ran (ns).
    pub lateness_ns: u64,
    /// Whole periods that had already passed: skipped, not replayed (docs/ARCHITECTURE.md).
    pub skipped_periods: u64,
}

/// A periodic timer on absolute CLOCK_MONOTONIC deadlines.
#[derive(Debug, Clone)]
pub struct PeriodicTimer {
    period_ns: u64,
    next_ns: u64,
}

impl PeriodicTimer {
    /// The first deadline one period from now.
    pub fn start(period_ns: u64) -> Self {
        let period_ns = period_ns.max(1);
        Self { period_ns, next_ns: monotonic_ns() + period_ns }
    }

    /// The next deadline (ns).
    pub fn next_deadline_ns(&self) -> u64 {
        self.next_ns
    }

    /// Sleeps until the next deadline. After a stall the periods that passed are skipped, so the loop does
    /// not send a burst to catch up.
    pub fn wait(&mut self) -> Wake {
        sleep_until_ns(self.next_ns);
        let now = monotonic_ns();
        let deadline_ns = self.next_ns;
        let lateness_ns = now.saturating_sub(deadline_ns);
        let skipped_periods = lateness_ns / self.period_ns;
        self.next_ns = deadline_ns + (skipped_periods + 1) * self.period_ns;
        Wake { deadline_ns, lateness_ns, skipped_periods }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deadlines_advance_by_whole_periods_and_never_fire_early() {
        let period = 2_000_000;
        let mut timer = PeriodicTimer::start(period);
        let first = timer.next_deadline_ns();
        for _ in 0..5 {
            let wake = timer.wait();
            // a lower bound only: how late it is depends on the machine
            assert!(monotonic_ns() >= wake.deadline_ns);
            assert_eq!((timer.next_deadline_ns() - first) % period, 0);
            assert!(timer.next_deadline_ns() > wake.deadline_ns);
        }
    }

    #[test]
    fn a_stall_skips_the_missed_periods_instead_of_replaying_them() {
        let period = 1_000_000;
        let mut timer = PeriodicTimer::start(period);
        sleep_until_ns(timer.next_deadline_ns() + 5 * period + period / 2);
        let wake = timer.wait();
        assert!(wake.skipped_periods >= 5, "{wake:?}");
        assert!(timer.next_deadline_ns() > monotonic_ns() - period);
    }
}
