//! The per-frame control law, run by the servo on every feature vector. No allocation.

use vservo_scene::FeatureVector;

use crate::{FeatureGain, Gains, MAX_DELAY_FRAMES, Twist};

/// What the law needs of a design: the gain on the feature error, the gains on past commands and ξ_d. This
/// is what crosses from the process that designs gains (off the hot path) to the one that runs the law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawGains {
    /// K_ξ (K for the paper's law).
    pub feature_gain: FeatureGain,
    /// K_j on the command sent j + 1 frames ago.
    pub past_input_gains: [nalgebra::Matrix6<f64>; MAX_DELAY_FRAMES],
    /// How many of `past_input_gains` are used.
    pub used_past_gains: usize,
    /// ξ_d.
    pub desired_features: FeatureVector,
}

impl From<&Gains> for LawGains {
    fn from(gains: &Gains) -> Self {
        Self {
            feature_gain: gains.feature_gain,
            past_input_gains: gains.past_input_gains,
            used_past_gains: gains.active_past_input_gains().len(),
            desired_features: gains.desired_features,
        }
    }
}

/// The servo's state: its gains and the commands it sent in the last frames.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoLaw {
    feature_gain: FeatureGain,
    past_input_gains: [nalgebra::Matrix6<f64>; MAX_DELAY_FRAMES],
    used_past_gains: usize,
    desired_features: FeatureVector,
    /// Commands sent, most recent first.
    history: [Twist; MAX_DELAY_FRAMES],
}

impl ServoLaw {
    /// A law at rest (no command sent yet) with these gains.
    pub fn new(gains: &Gains) -> Self {
        let mut law = Self {
            feature_gain: gains.feature_gain,
            past_input_gains: gains.past_input_gains,
            used_past_gains: 0,
            desired_features: gains.desired_features,
            history: [Twist::zeros(); MAX_DELAY_FRAMES],
        };
        law.set_gains(gains);
        law
    }

    /// Swaps in new gains (and their ξ_d), keeping the command history so that the twist does not jump
    /// beyond what the new gain itself implies.
    pub fn set_gains(&mut self, gains: &Gains) {
        self.set_law_gains(&LawGains::from(gains));
    }

    /// [`ServoLaw::set_gains`] from the law's part of a design.
    pub fn set_law_gains(&mut self, gains: &LawGains) {
        self.feature_gain = gains.feature_gain;
        self.past_input_gains = gains.past_input_gains;
        self.used_past_gains = gains.used_past_gains.min(MAX_DELAY_FRAMES);
        self.desired_features = gains.desired_features;
    }

    /// The desired features ξ_d.
    pub fn desired_features(&self) -> &FeatureVector {
        &self.desired_features
    }

    /// The twist for a measured feature vector: u = −K_ξ (ξ − ξ_d) − Σ K_j u(k − j).
    pub fn command(&mut self, measured: &FeatureVector) -> Twist {
        let error = measured - self.desired_features;
        let mut twist = -(self.feature_gain * error);
        for (gain, past) in self.past_input_gains.iter().zip(&self.history).take(self.used_past_gains) {
            twist -= gain * past;
        }
        self.remember(twist);
        twist
    }

    /// No usable features this frame: command zero, and remember that zero was sent.
    pub fn hold(&mut self) -> Twist {
        let twist = Twist::zeros();
        self.remember(twist);
        twist
    }

    fn remember(&mut self, twist: Twist) {
        self.history.rotate_right(1);
        self.history[0] = twist;
    }
}
