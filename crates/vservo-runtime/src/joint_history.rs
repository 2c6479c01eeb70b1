//! The joints as they were at a past instant: the last joint states heard, for an external camera's frame,
//! whose camera pose is the arm's pose when the image was exposed (its `capture_stamp_ns`), not when the
//! frame reaches the vision node tens of milliseconds later.
//!
//! A fixed ring of the states heard (no allocation); the joints between two states are interpolated
//! linearly (1 ms apart at the robot's rate, so the error is second order in the joint speed's change
//! over a millisecond).

use vservo_arm::JointVector;

/// States kept: at 1 kHz, the last quarter second (an external camera's frame older than a vision
/// period is dropped before it is looked up).
pub const KEPT_STATES: usize = 256;

/// One state heard: when it was measured, its tick, its joints.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Heard {
    stamp_ns: u64,
    tick: u64,
    q: JointVector,
}

/// The joints at a past instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointsAt {
    /// The tick of the last state measured at or before the instant.
    pub tick: u64,
    /// The joints (rad), interpolated between the states around the instant.
    pub q: JointVector,
}

/// The last [`KEPT_STATES`] joint states, oldest overwritten first.
#[derive(Debug, Clone)]
pub struct JointHistory {
    ring: [Heard; KEPT_STATES],
    /// Index of the next slot to write.
    next: usize,
    len: usize,
    /// How far past the newest state an instant may lie and still take it (ns).
    newest_reach_ns: u64,
}

impl JointHistory {
    /// An empty history. An instant up to `newest_reach_ns` after the newest state takes that state (a
    /// frame exposed after the last state arrived, before the next).
    pub fn new(newest_reach_ns: u64) -> Self {
        Self {
            ring: [Heard { stamp_ns: 0, tick: 0, q: JointVector::zeros() }; KEPT_STATES],
            next: 0,
            len: 0,
            newest_reach_ns,
        }
    }

    /// Takes in a state. One stamped as the newest replaces it (a clock too coarse to tell them apart); one
    /// stamped before it (a driver restarted with another clock origin) starts the history anew; one with
    /// joints that are not finite is not kept.
    pub fn push(&mut self, stamp_ns: u64, tick: u64, q: &JointVector) {
        if !q.iter().all(|v| v.is_finite()) {
            return;
        }
        match self.newest() {
            Some(newest) if stamp_ns == newest.stamp_ns => {
                self.ring[(self.next + KEPT_STATES - 1) % KEPT_STATES] = Heard { stamp_ns, tick, q: *q };
                return;
            }
            Some(newest) if stamp_ns < newest.stamp_ns => self.len = 0,
            _ => {}
        }
        self.ring[self.next] = Heard { stamp_ns, tick, q: *q };
        self.next = (self.next + 1) % KEPT_STATES;
        self.len = (self.len + 1).min(KEPT_STATES);
    }

    /// The joints at `stamp_ns`: interpolated between the two states around it, the newest within its
    /// reach after it; `None` before the oldest state kept, further after the newest, or with none.
    pub fn at(&self, stamp_ns: u64) -> Option<JointsAt> {
        let newest = self.newest()?;
        if stamp_ns >= newest.stamp_ns {
            return (stamp_ns - newest.stamp_ns <= self.newest_reach_ns)
                .then_some(JointsAt { tick: newest.tick, q: newest.q });
        }
        // newest first: the first state at or before the instant, and the one after it
        let mut after = newest;
        for back in 1..self.len {
            let state = self.ring[(self.next + KEPT_STATES - 1 - back) % KEPT_STATES];
            if state.stamp_ns <= stamp_ns {
                let span = (after.stamp_ns - state.stamp_ns) as f64;
                let s = (stamp_ns - state.stamp_ns) as f64 / span;
                return Some(JointsAt { tick: state.tick, q: state.q + (after.q - state.q) * s });
            }
            after = state;
        }
        None
    }

    /// The tick of the newest state kept.
    pub fn newest_tick(&self) -> Option<u64> {
        self.newest().map(|newest| newest.tick)
    }

    fn newest(&self) -> Option<Heard> {
        (self.len > 0).then(|| self.ring[(self.next + KEPT_STATES - 1) % KEPT_STATES])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(v: f64) -> JointVector {
        JointVector::from_fn(|j, _| v * (j as f64 + 1.0))
    }

    /// States 1 ms apart with joints linear in time.
    fn heard(states: u64) -> JointHistory {
        let mut history = JointHistory::new(2_000_000);
        for tick in 0..states {
            history.push(1_000_000_000 + tick * 1_000_000, tick, &q(tick as f64 * 0.01));
        }
        history
    }

    #[test]
    fn the_joints_between_two_states_are_interpolated_and_the_tick_is_the_earlier_one() {
        let history = heard(100);
        // 40.25 ms after the first state: between ticks 40 and 41
        let at = history.at(1_000_000_000 + 40_250_000).expect("within the history");
        assert_eq!(at.tick, 40);
        assert!((at.q - q(0.4025)).amax() < 1e-12, "{}", at.q);
        // exactly on a state
        let at = history.at(1_000_000_000 + 7_000_000).expect("within");
        assert_eq!(at.tick, 7);
        assert!((at.q - q(0.07)).amax() < 1e-12);
    }

    #[test]
    fn instants_outside_the_history_have_no_joints_except_just_after_the_newest() {
        let history = heard(300);
        // the oldest kept is tick 300 − 256 = 44
        assert!(history.at(1_000_000_000 + 43_500_000).is_none());
        assert_eq!(history.at(1_000_000_000 + 44_000_000).map(|a| a.tick), Some(44));
        let newest = 1_000_000_000 + 299_000_000;
        assert_eq!(history.at(newest + 1_500_000).map(|a| a.tick), Some(299));
        assert!(history.at(newest + 2_500_000).is_none());
        assert!(JointHistory::new(2_000_000).at(5).is_none());
    }

    #[test]
    fn a_state_stamped_as_the_newest_replaces_it_and_keeps_the_history() {
        let mut history = heard(50);
        let newest = 1_000_000_000 + 49_000_000;
        history.push(newest, 50, &q(7.0));
        assert_eq!(history.at(newest).map(|a| (a.tick, a.q)), Some((50, q(7.0))));
        assert_eq!(history.at(1_000_000_000 + 10_000_000).map(|a| a.tick), Some(10), "the older states stay");
    }

    #[test]
    fn a_state_from_before_the_newest_starts_the_history_anew_and_bad_joints_are_not_kept() {
        let mut history = heard(50);
        history.push(10, 0, &q(9.0));
        assert!(history.at(1_000_000_000 + 20_000_000).is_none(), "the old states are gone");
        assert_eq!(history.at(10).map(|a| a.q), Some(q(9.0)));
        history.push(1_000_010, 1, &JointVector::from_element(f64::NAN));
        assert_eq!(history.at(20).map(|a| a.tick), Some(0), "the state at 10 ns is still the newest");
        assert_eq!(history.at(10 + 2_500_000), None, "out of its reach");
    }
}
