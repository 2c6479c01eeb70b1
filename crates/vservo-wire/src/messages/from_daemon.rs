//! What the daemon sends its nodes beyond the cell mode: the servo's gains and the simulated board's motion.

use crate::codes::*;
use crate::declare::wire_message;
use crate::messages::{FEATURES, MARKS};
use iceoryx2::prelude::ZeroCopySend;

/// Most past-command gains a [`GainsMsg`] carries.
pub const MAX_PAST_GAINS: usize = 4;

wire_message! {
    /// vservod → servo (history 1): the gains to swap in at the next frame, designed off the hot path.
    payload GainsMsg = "vservo::Gains" {
        /// schema version
        schema: u32,
        /// how many of `past_input_gains` the law uses (0 for the paper's law)
        used_past_gains: u32,
        /// 1 at start, +1 per accepted reload or target
        version: u64,
        /// K_ξ, 6×8 row-major (m/s and rad/s per px)
        feature_gain: [f64; 48],
        /// K_j on the command sent j + 1 frames ago, four 6×6 row-major
        past_input_gains: [f64; 36 * MAX_PAST_GAINS],
        /// ξ_d (px)
        desired_features_px: [f64; FEATURES],
        /// Z_d, the marks' depths at the desired pose (m)
        desired_depths_m: [f64; MARKS],
        /// Q, 8×8 row-major (for the gains on three marks and a scheduled gain, designed by the servo)
        q: [f64; FEATURES * FEATURES],
        /// R in SI units, 6×6 row-major
        r_si: [f64; 36],
        /// where B is evaluated (desired: at ξ_d, the fixed gain; mean: the mean of ξ_d's and the current;
        /// current: the current)
        interaction: u32 as Interaction,
        /// 1: the target's image motion is fed forward
        feedforward: u32,
        /// the barrier keeps seen marks this far inside the image (0: none)
        border_margin_px: f64,
        /// what the law servoes on with four marks (image; a pose-based law runs the image law on three)
        servo_features: u32 as ServoFeatures,
        /// zero
        reserved: u32,
        /// λ of a pose-based law (1/s)
        pose_gain_per_s: f64,
        /// a pose-based law's linear speed cap (m/s)
        pose_max_speed_m_s: f64,
        /// a pose-based law's angular speed cap (rad/s)
        pose_max_rotation_rad_s: f64,
        /// CLOCK_MONOTONIC when the daemon made it (ns): a later one is newer (`vservo_protocol::freshness`)
        stamp_ns: u64,
        /// the daemon's seal (SipHash-2-4 of the fields under the run's key): other gains are refused
        seal: u64,
    }
}

wire_message! {
    /// vservod → plant (history 1): how the simulated board moves from now on.
    payload ObjectMsg = "vservo::Object" {
        /// schema version
        schema: u32,
        /// what the board does, 4–6 only (as in `command`)
        kind: u32 as CommandKind,
        /// counts the object commands (1 for the first)
        sequence: u64,
        /// step: the jump in the desired camera frame (m)
        translation_m: [f64; 3],
        /// circle: radius (m)
        radius_m: f64,
        /// circle: speed (rev/min)
        rev_per_min: f64,
        /// CLOCK_MONOTONIC when the daemon made it (ns): a later one is newer (`vservo_protocol::freshness`)
        stamp_ns: u64,
        /// the daemon's seal (SipHash-2-4 of the fields under the run's key): other object commands are refused
        seal: u64,
    }
}
