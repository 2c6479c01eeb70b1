//! The joints as they were at a past instant: the last joint states heard, for an external camera's frame,
//! whose camera pose is the arm's pose when the image was exposed (its `capture_stamp_ns`), not when the
//! frame reaches the vision node tens of milliseconds later.
//!
//! A ring of the states heard, sized at start (no allocation after); the joints between two states are
//! interpolated linearly (a driver period apart, so the error is second order in the joint speed's change
//! over a period). No joints are made up across a gap (a stall) or a new driver epoch.

use vservo_arm::JointVector;

/// States kept at the least, whatever the driver's period.
pub const LEAST_KEPT_STATES: usize = 64;
/// An instant may lie this many driver periods after the newest state and still take it (a frame exposed
/// after the last state arrived, before the next).
pub const NEWEST_REACH_PERIODS: u64 = 2;
/// Two neighbouring states further apart than this many periods are a gap (a stall, lost states): no
/// joints are made up between them.
pub const LARGEST_GAP_PERIODS: u64 = 4;

/// One state heard: when it was measured, its tick and driver epoch, its joints.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PastState {
    stamp_ns: u64,
    tick: u64,
    epoch: u64,
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

/// Why there are no joints at an instant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoJoints {
    /// No state heard yet.
    Empty,
    /// Before the oldest state kept.
    BeforeHistory,
    /// Further than [`NEWEST_REACH_PERIODS`] after the newest state (a clock ahead of the robot's).
    AfterNewest,
    /// In a gap of more than [`LARGEST_GAP_PERIODS`] between two states.
    InGap,
}

/// The last joint states, oldest overwritten first; the ring is sized once, at start.
#[derive(Debug, Clone)]
pub struct JointHistory {
    ring: Box<[PastState]>,
    /// Index of the next slot to write.
    next: usize,
    len: usize,
    period_ns: u64,
}

impl JointHistory {
    /// An empty history for a driver with this period, keeping at least `span_s` of states (and at least
    /// [`LEAST_KEPT_STATES`]).
    pub fn new(period_s: f64, span_s: f64) -> Self {
        let period_ns = vservo_time::nanos(period_s).max(1);
        let states =
            ((span_s / period_s).ceil() as usize).saturating_add(2).clamp(LEAST_KEPT_STATES, 1 << 20);
        let empty = PastState { stamp_ns: 0, tick: 0, epoch: 0, q: JointVector::zeros() };
        Self { ring: vec![empty; states].into_boxed_slice(), next: 0, len: 0, period_ns }
    }

    /// Takes in a state. One stamped as the newest replaces it (a clock too coarse to tell them apart); one
    /// stamped before it, or of another driver epoch, starts the history anew; one with joints that are not
    /// finite is not kept.
    pub fn push(&mut self, stamp_ns: u64, tick: u64, epoch: u64, q: &JointVector) {
        if !q.iter().all(|v| v.is_finite()) {
            return;
        }
        let heard = PastState { stamp_ns, tick, epoch, q: *q };
        match self.newest() {
            Some(newest) if newest.epoch != epoch || stamp_ns < newest.stamp_ns => self.len = 0,
            Some(newest) if stamp_ns == newest.stamp_ns => {
                let last = self.slot_back(0);
                self.ring[last] = heard;
                return;
            }
            _ => {}
        }
        self.ring[self.next] = heard;
        self.next = (self.next + 1) % self.ring.len();
        self.len = (self.len + 1).min(self.ring.len());
    }

    /// The joints at `stamp_ns`, interpolated between the two states around it (the newest within its reach
    /// after it); none before the oldest state kept, further after the newest, or in a gap (but within a period of a
    /// state around it: that state's).
    pub fn at(&self, stamp_ns: u64) -> Result<JointsAt, NoJoints> {
        let newest = self.newest().ok_or(NoJoints::Empty)?;
        if stamp_ns >= newest.stamp_ns {
            return if stamp_ns - newest.stamp_ns <= NEWEST_REACH_PERIODS * self.period_ns {
                Ok(JointsAt { tick: newest.tick, q: newest.q })
            } else {
                Err(NoJoints::AfterNewest)
            };
        }
        // newest first: the first state at or before the instant, and the one after it
        let mut after = newest;
        for back in 1..self.len {
            let state = self.ring[self.slot_back(back)];
            if state.stamp_ns <= stamp_ns {
                let span_ns = after.stamp_ns - state.stamp_ns;
                if span_ns > LARGEST_GAP_PERIODS * self.period_ns {
                    // an instant within a period of either state around the gap is that state's (a camera stamps
                    // its frame with the joint state it shows; the next one may come late)
                    return match (stamp_ns - state.stamp_ns, after.stamp_ns - stamp_ns) {
                        (before, _) if before <= self.period_ns => {
                            Ok(JointsAt { tick: state.tick, q: state.q })
                        }
                        (_, until) if until <= self.period_ns => {
                            Ok(JointsAt { tick: after.tick, q: after.q })
                        }
                        _ => Err(NoJoints::InGap),
                    };
                }
                let s = (stamp_ns - state.stamp_ns) as f64 / span_ns as f64;
                return Ok(JointsAt { tick: state.tick, q: state.q + (after.q - state.q) * s });
            }
            after = state;
        }
        Err(NoJoints::BeforeHistory)
    }

    /// The tick of the newest state kept.
    pub fn newest_tick(&self) -> Option<u64> {
        self.newest().map(|newest| newest.tick)
    }

    /// From the oldest state kept to the newest (ns).
    pub fn span_ns(&self) -> u64 {
        match self.newest() {
            Some(newest) => newest.stamp_ns - self.ring[self.slot_back(self.len - 1)].stamp_ns,
            None => 0,
        }
    }

    /// The slot `back` states before the newest.
    fn slot_back(&self, back: usize) -> usize {
        (self.next + 2 * self.ring.len() - 1 - back) % self.ring.len()
    }

    fn newest(&self) -> Option<PastState> {
        (self.len > 0).then(|| self.ring[self.slot_back(0)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(v: f64) -> JointVector {
        JointVector::from_fn(|j, _| v * (j as f64 + 1.0))
    }

    const T0: u64 = 1_000_000_000;

    /// A 1 kHz driver's states, joints linear in time, kept for 0.2 s (202 states).
    fn heard(states: u64) -> JointHistory {
        let mut history = JointHistory::new(0.001, 0.2);
        for tick in 0..states {
            history.push(T0 + tick * 1_000_000, tick, 7, &q(tick as f64 * 0.01));
        }
        history
    }

    #[test]
    fn the_joints_between_two_states_are_interpolated_and_the_tick_is_the_earlier_one() {
        let history = heard(100);
        let at = history.at(T0 + 40_250_000).expect("within the history");
        assert_eq!(at.tick, 40);
        assert!((at.q - q(0.4025)).amax() < 1e-12, "{}", at.q);
        let at = history.at(T0 + 7_000_000).expect("within");
        assert_eq!(at.tick, 7);
        assert!((at.q - q(0.07)).amax() < 1e-12);
        assert_eq!(history.span_ns(), 99_000_000);
    }

    #[test]
    fn instants_outside_the_history_have_no_joints_except_just_after_the_newest() {
        let history = heard(300);
        // 202 kept: the oldest is tick 98
        assert_eq!(history.at(T0 + 97_500_000), Err(NoJoints::BeforeHistory));
        assert_eq!(history.at(T0 + 98_000_000).map(|a| a.tick), Ok(98));
        let newest = T0 + 299_000_000;
        assert_eq!(history.at(newest + 1_500_000).map(|a| a.tick), Ok(299));
        assert_eq!(history.at(newest + 2_500_000), Err(NoJoints::AfterNewest));
        assert_eq!(JointHistory::new(0.001, 0.2).at(5), Err(NoJoints::Empty));
        // a slow driver (8 ms) reaches 16 ms past its newest state
        let mut slow = JointHistory::new(0.008, 0.2);
        slow.push(T0, 0, 1, &q(0.0));
        assert!(slow.at(T0 + 15_000_000).is_ok());
    }

    #[test]
    fn no_joints_are_made_up_across_a_stall() {
        let mut history = heard(50);
        // the driver falls silent for 10 ms
        history.push(T0 + 59_000_000, 59, 7, &q(0.59));
        assert_eq!(history.at(T0 + 55_000_000), Err(NoJoints::InGap));
        assert!(history.at(T0 + 48_500_000).is_ok(), "before the stall");
        // within a period of a state around the gap: that state's joints (a frame stamped with the state it shows)
        assert_eq!(history.at(T0 + 49_000_000).map(|a| (a.tick, a.q)), Ok((49, q(0.49))));
        assert_eq!(history.at(T0 + 49_900_000).map(|a| a.tick), Ok(49));
        assert_eq!(history.at(T0 + 58_200_000).map(|a| (a.tick, a.q)), Ok((59, q(0.59))));
        assert_eq!(history.at(T0 + 51_100_000), Err(NoJoints::InGap));
    }

    #[test]
    fn a_state_stamped_as_the_newest_replaces_it_and_keeps_the_history() {
        let mut history = heard(50);
        let newest = T0 + 49_000_000;
        history.push(newest, 50, 7, &q(7.0));
        assert_eq!(history.at(newest).map(|a| (a.tick, a.q)), Ok((50, q(7.0))));
        assert_eq!(history.at(T0 + 10_000_000).map(|a| a.tick), Ok(10), "the older states stay");
    }

    #[test]
    fn an_earlier_stamp_or_a_new_epoch_starts_the_history_anew_and_bad_joints_are_not_kept() {
        let mut history = heard(50);
        history.push(10, 0, 7, &q(9.0));
        assert_eq!(history.at(T0 + 20_000_000), Err(NoJoints::AfterNewest), "the old states are gone");
        assert_eq!(history.at(10).map(|a| a.q), Ok(q(9.0)));
        history.push(1_000_010, 1, 7, &JointVector::from_element(f64::NAN));
        assert_eq!(history.at(20).map(|a| a.tick), Ok(0), "the state at 10 ns is still the newest");
        let mut history = heard(50);
        history.push(T0 + 50_000_000, 0, 8, &q(1.0));
        assert_eq!(history.at(T0 + 40_000_000), Err(NoJoints::BeforeHistory), "a new driver epoch");
    }
}
