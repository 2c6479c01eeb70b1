//! One log line per command, up to a rate that journald's burst limit keeps (its default: 10000 lines per
//! 30 s per service); beyond it, the commands of the window are counted and said in one summary line.

use std::time::{Duration, Instant};

/// A window and how many lines it may hold.
#[derive(Debug)]
pub struct LogLimit {
    window: Duration,
    lines_per_window: u32,
    started: Option<Instant>,
    logged: u32,
    /// Commands not logged one by one in this window: accepted, refused.
    quiet: (u64, u64),
}

impl LogLimit {
    /// At most `lines_per_window` lines per `window`.
    pub fn new(window: Duration, lines_per_window: u32) -> Self {
        Self { window, lines_per_window, started: None, logged: 0, quiet: (0, 0) }
    }

    /// Whether the command handled at `now` gets its own line; if not, it is counted for the summary.
    pub fn admit(&mut self, now: Instant, accepted: bool) -> bool {
        let started = *self.started.get_or_insert(now);
        if now.duration_since(started) >= self.window && self.quiet == (0, 0) {
            self.started = Some(now);
            self.logged = 0;
        }
        if self.logged < self.lines_per_window {
            self.logged += 1;
            return true;
        }
        if accepted {
            self.quiet.0 += 1;
        } else {
            self.quiet.1 += 1;
        }
        false
    }

    /// Once the window is over: the line that says what was not logged in it, if anything was not.
    pub fn summary(&mut self, now: Instant) -> Option<String> {
        let started = self.started?;
        let elapsed = now.duration_since(started);
        if elapsed < self.window {
            return None;
        }
        self.started = Some(now);
        self.logged = 0;
        let (accepted, refused) = std::mem::take(&mut self.quiet);
        (accepted + refused > 0).then(|| {
            format!(
                "command flood: {} more commands in {:.1} s not logged one by one ({accepted} accepted, {refused} refused)",
                accepted + refused,
                elapsed.as_secs_f64()
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flood_gets_its_first_lines_and_one_summary_per_window() {
        let mut limit = LogLimit::new(Duration::from_secs(1), 10);
        let t0 = Instant::now();
        let admitted = (0..500).filter(|i| limit.admit(t0 + Duration::from_millis(*i), i % 5 != 0)).count();
        assert_eq!(admitted, 10);
        assert_eq!(limit.summary(t0 + Duration::from_millis(900)), None, "the window is not over");
        let summary = limit.summary(t0 + Duration::from_millis(1000)).expect("a summary");
        assert!(summary.contains("490 more commands"), "{summary}");
        assert!(summary.contains("392 accepted, 98 refused"), "{summary}");
        // a quiet window: every command its line, no summary
        let t1 = t0 + Duration::from_secs(5);
        assert!((0..3).all(|i| limit.admit(t1 + Duration::from_millis(i), true)));
        assert_eq!(limit.summary(t1 + Duration::from_secs(2)), None);
    }
}
