//! Whether a driver's joint states come at its configured period.

/// How many gaps between joint states the period is judged on (their median).
pub const PERIOD_CHECK_GAPS: usize = 64;

/// Whether the states come at `[robot] period_s`: a wrong period would make every tick a period the arm did not
/// live (the rmrc's reference would run ahead of time, or behind it). Judged on the median of the last
/// [`PERIOD_CHECK_GAPS`] gaps between stamps, which a late state or a lost one does not move; the configured
/// period is taken within −25 % and +50 %.
#[derive(Debug, Clone)]
pub struct PeriodCheck {
    gaps_ns: [u64; PERIOD_CHECK_GAPS],
    count: usize,
}

impl Default for PeriodCheck {
    fn default() -> Self {
        Self { gaps_ns: [0; PERIOD_CHECK_GAPS], count: 0 }
    }
}

impl PeriodCheck {
    /// One gap between two states' stamps (ns).
    pub fn add(&mut self, gap_ns: u64) {
        self.gaps_ns[self.count % PERIOD_CHECK_GAPS] = gap_ns;
        self.count += 1;
    }

    /// The median gap (ns) once enough were seen, if it is not `period_ns`'s.
    pub fn mismatch(&self, period_ns: u64) -> Option<u64> {
        if self.count < PERIOD_CHECK_GAPS {
            return None;
        }
        let mut sorted = self.gaps_ns;
        sorted.sort_unstable();
        let median_ns = sorted[PERIOD_CHECK_GAPS / 2];
        let period = period_ns as f64;
        (!(0.75 * period..=1.5 * period).contains(&(median_ns as f64))).then_some(median_ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_late_or_lost_state_does_not_move_the_median_but_another_period_does() {
        let mut check = PeriodCheck::default();
        for i in 0..PERIOD_CHECK_GAPS {
            check.add(if i == 10 { 5_000_000 } else { 1_000_000 });
        }
        assert_eq!(check.mismatch(1_000_000), None);
        for _ in 0..PERIOD_CHECK_GAPS {
            check.add(2_000_000);
        }
        assert_eq!(check.mismatch(1_000_000), Some(2_000_000));
        assert_eq!(PeriodCheck::default().mismatch(1_000_000), None, "too few gaps to judge");
    }
}
