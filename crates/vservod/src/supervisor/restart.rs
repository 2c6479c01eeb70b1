//! The restart policy: a node that ended waits a backoff before its restart, twice as long after each end
//! up to `runtime.restart_backoff_max_s`, and from `runtime.restart_backoff_initial_s` again once it had run
//! [`STABLE_AFTER`]. Pure: time is passed in.

use std::time::{Duration, Instant};

/// A node that ran this long before it ended has its restart backoff reset.
pub const STABLE_AFTER: Duration = Duration::from_secs(10);

/// When a node starts again, and how often it did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestartPolicy {
    initial: Duration,
    max: Duration,
    /// The wait before the next restart.
    backoff: Duration,
    /// When the node is due to start again (none while it runs).
    restart_at: Option<Instant>,
    started_at: Instant,
    restarts: u64,
}

impl RestartPolicy {
    /// A node started at `started_at`, with backoffs from `initial` doubling up to `max`.
    pub fn new(initial: Duration, max: Duration, started_at: Instant) -> Self {
        Self { initial, max, backoff: initial, restart_at: None, started_at, restarts: 0 }
    }

    /// The node ended at `now`: schedules its restart and says how long until then.
    pub fn ended(&mut self, now: Instant) -> Duration {
        if now.duration_since(self.started_at) > STABLE_AFTER {
            self.backoff = self.initial;
        }
        let wait = self.backoff;
        self.restart_at = Some(now + wait);
        self.backoff = (self.backoff * 2).min(self.max);
        wait
    }

    /// Whether the node is due to start again at `now`.
    pub fn due(&self, now: Instant) -> bool {
        self.restart_at.is_some_and(|at| now >= at)
    }

    /// The node started again at `now`.
    pub fn restarted(&mut self, now: Instant) {
        self.restarts += 1;
        self.restart_at = None;
        self.started_at = now;
    }

    /// Its start at `now` failed: it is tried again after the current backoff.
    pub fn start_failed(&mut self, now: Instant) {
        self.restart_at = Some(now + self.backoff);
    }

    /// Restarts so far.
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    /// When the node's process last started.
    pub fn started_at(&self) -> Instant {
        self.started_at
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    fn policy(t0: Instant) -> RestartPolicy {
        RestartPolicy::new(100 * MS, 500 * MS, t0)
    }

    #[test]
    fn each_quick_end_doubles_the_wait_up_to_the_maximum() {
        let t0 = Instant::now();
        let mut policy = policy(t0);
        let mut now = t0;
        let mut waits = Vec::new();
        for _ in 0..5 {
            now += 50 * MS;
            let wait = policy.ended(now);
            waits.push(wait);
            assert!(!policy.due(now + wait - MS), "not before its backoff");
            assert!(policy.due(now + wait));
            now += wait;
            policy.restarted(now);
        }
        assert_eq!(waits, [100 * MS, 200 * MS, 400 * MS, 500 * MS, 500 * MS]);
        assert_eq!(policy.restarts(), 5);
        assert_eq!(policy.started_at(), now);
    }

    #[test]
    fn a_node_that_ran_stable_starts_again_from_the_initial_backoff() {
        let t0 = Instant::now();
        let mut policy = policy(t0);
        assert_eq!(policy.ended(t0 + MS), 100 * MS);
        policy.restarted(t0 + 101 * MS);
        assert_eq!(policy.ended(t0 + 102 * MS), 200 * MS);
        let restarted = t0 + 302 * MS;
        policy.restarted(restarted);
        // ran just the stable time: not yet reset
        assert_eq!(policy.ended(restarted + STABLE_AFTER), 400 * MS);
        let restarted = restarted + STABLE_AFTER + 400 * MS;
        policy.restarted(restarted);
        assert_eq!(policy.ended(restarted + STABLE_AFTER + MS), 100 * MS, "reset after a stable run");
    }

    #[test]
    fn a_failed_start_is_tried_again_after_the_current_backoff_and_a_running_node_is_not_due() {
        let t0 = Instant::now();
        let mut policy = policy(t0);
        assert!(!policy.due(t0 + STABLE_AFTER * 100), "running: never due");
        let wait = policy.ended(t0);
        policy.start_failed(t0 + wait);
        assert!(!policy.due(t0 + wait + 199 * MS));
        assert!(policy.due(t0 + wait + 200 * MS));
        assert_eq!(policy.restarts(), 0);
    }
}
