//! The servo stage: the LQ law, and what it does with a frame it cannot use.

use vservo_control::{Gains, LawGains, ServoLaw, Twist};
use vservo_scene::FeatureVector;

/// Why the servo sent the twist it sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoVerdict {
    /// No frame has come through the pipeline yet: zero twist.
    Waiting,
    /// The law's twist for a frame with all four marks.
    Servoing,
    /// A frame with a mark missing (bit m set for mark m): zero twist.
    MarksMissing(u8),
}

/// The servo: the law and its command history.
#[derive(Debug, Clone)]
pub struct ServoStage {
    law: ServoLaw,
}

impl ServoStage {
    pub(crate) fn new(gains: &Gains) -> Self {
        Self { law: ServoLaw::new(gains) }
    }

    /// The desired features ξ_d.
    pub fn desired_features(&self) -> &FeatureVector {
        self.law.desired_features()
    }

    /// Swaps in new gains, keeping the command history (no twist jump beyond the new gain's own).
    pub fn set_gains(&mut self, gains: &LawGains) {
        self.law.set_law_gains(gains);
    }

    /// A frame while the cell is held in a safe stop: zero twist, and the law remembers that zero was sent
    /// (so that a delay-aware law resumes from what the arm really got).
    pub fn hold(&mut self) -> Twist {
        self.law.hold()
    }

    /// The twist for the frame leaving the pipeline now (`None` before the first one has).
    pub fn step(&mut self, delivered: Option<&FeatureVector>) -> (Twist, ServoVerdict) {
        match delivered {
            None => (Twist::zeros(), ServoVerdict::Waiting),
            Some(seen) => {
                let mut missing = 0u8;
                for mark in 0..seen.len() / 2 {
                    if !(seen[2 * mark].is_finite() && seen[2 * mark + 1].is_finite()) {
                        missing |= 1 << mark;
                    }
                }
                if missing == 0 {
                    (self.law.command(seen), ServoVerdict::Servoing)
                } else {
                    (self.law.hold(), ServoVerdict::MarksMissing(missing))
                }
            }
        }
    }
}
