//! The per-frame control law, run by the servo on every feature vector. No allocation.

use vservo_scene::FeatureVector;

use crate::{FeatureGain, Gains, MAX_DELAY_FRAMES, Twist};

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
        self.feature_gain = gains.feature_gain;
        self.past_input_gains = gains.past_input_gains;
        self.used_past_gains = gains.active_past_input_gains().len();
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
