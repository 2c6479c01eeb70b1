//! Latency percentiles of a control loop (e.g. robot state received → command sent, per cycle).

use std::time::Duration;

/// Nearest-rank percentiles of a set of durations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LatencySummary {
    /// Number of samples.
    pub count: usize,
    /// Median.
    pub p50: Duration,
    /// 99th percentile.
    pub p99: Duration,
    /// Largest sample.
    pub max: Duration,
}

impl LatencySummary {
    /// Summarises `samples` (sorted in place); `None` if there are none.
    pub fn of(samples: &mut [Duration]) -> Option<Self> {
        samples.sort_unstable();
        Some(LatencySummary {
            count: samples.len(),
            p50: percentile(samples, 50)?,
            p99: percentile(samples, 99)?,
            max: *samples.last()?,
        })
    }
}

/// The nearest-rank `pct`-th percentile of sorted `samples`.
fn percentile(sorted: &[Duration], pct: usize) -> Option<Duration> {
    let rank = (pct * sorted.len()).div_ceil(100).max(1);
    sorted.get(rank - 1).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let mut samples: Vec<Duration> = (1..=100).rev().map(Duration::from_micros).collect();
        let s = LatencySummary::of(&mut samples);
        assert_eq!(
            s,
            Some(LatencySummary {
                count: 100,
                p50: Duration::from_micros(50),
                p99: Duration::from_micros(99),
                max: Duration::from_micros(100),
            })
        );
        assert_eq!(LatencySummary::of(&mut []), None);
        let one = LatencySummary::of(&mut [Duration::from_micros(7)]);
        assert_eq!(one.map(|s| (s.p50, s.p99)), Some((Duration::from_micros(7), Duration::from_micros(7))));
    }
}
