//! The servo's gains on the wire: the daemon's design as a sealed [`GainsMsg`] of a version
//! ([`gains_message`]), and back into the law's gains where the servo takes the message in ([`law_gains`]).
//! The design itself is `vservo_cell::gains::design`, the one the daemon, its commander and the nodes run.

use nalgebra::Matrix6;
use vservo_control::pose_features::PoseFeatures;
use vservo_control::{FeatureGain, LawGains};
use vservo_protocol::{GainsMsg, MAX_PAST_GAINS, SCHEMA_VERSION};
use vservo_scene::FeatureVector;

use crate::wire::to_array;

/// The law's gains as a [`GainsMsg`] of `version`.
pub fn gains_message(gains: &LawGains, version: u64, key: &vservo_protocol::seal::SealKey) -> GainsMsg {
    let mut feature_gain = [0.0; 48];
    for r in 0..6 {
        for c in 0..8 {
            feature_gain[8 * r + c] = gains.feature_gain[(r, c)];
        }
    }
    let mut past_input_gains = [0.0; 36 * MAX_PAST_GAINS];
    for (j, k) in gains.past_input_gains.iter().enumerate().take(MAX_PAST_GAINS) {
        for r in 0..6 {
            for c in 0..6 {
                past_input_gains[36 * j + 6 * r + c] = k[(r, c)];
            }
        }
    }
    let mut q = [0.0; 64];
    for r in 0..8 {
        for c in 0..8 {
            q[8 * r + c] = gains.q[(r, c)];
        }
    }
    let mut r_si = [0.0; 36];
    for r in 0..6 {
        for c in 0..6 {
            r_si[6 * r + c] = gains.r_si[(r, c)];
        }
    }
    let mut message = GainsMsg {
        schema: SCHEMA_VERSION,
        used_past_gains: gains.used_past_gains as u32,
        version,
        feature_gain,
        past_input_gains,
        desired_features_px: to_array(&gains.desired_features),
        desired_depths_m: [
            gains.desired_depths[0],
            gains.desired_depths[1],
            gains.desired_depths[2],
            gains.desired_depths[3],
        ],
        q,
        r_si,
        interaction: wire_interaction(gains.options.interaction).into(),
        feedforward: u32::from(gains.options.feedforward),
        border_margin_px: gains.options.border_margin_px,
        servo_features: wire_servo_features(gains.pose_features).into(),
        reserved: 0,
        pose_gain_per_s: gains.options.pose_gain_per_s,
        pose_max_speed_m_s: gains.options.pose_max_speed_m_s,
        pose_max_rotation_rad_s: gains.options.pose_max_rotation_rad_s,
        stamp_ns: vservo_time::monotonic_ns(),
        seal: 0,
    };
    key.sign(&mut message);
    message
}

/// The law's gains from a [`GainsMsg`]; `None` if a number is not finite or the count is out of range.
pub fn law_gains(message: &GainsMsg) -> Option<LawGains> {
    let finite = message
        .feature_gain
        .iter()
        .chain(&message.past_input_gains)
        .chain(&message.desired_features_px)
        .chain(&message.desired_depths_m)
        .chain(&message.q)
        .chain(&message.r_si);
    if !finite.into_iter().all(|v| v.is_finite()) || message.used_past_gains as usize > MAX_PAST_GAINS {
        return None;
    }
    let interaction = law_interaction(vservo_protocol::Interaction::try_from(message.interaction).ok()?);
    let margin = message.border_margin_px;
    if !(margin.is_finite() && margin >= 0.0) || message.feedforward > 1 {
        return None;
    }
    let pose_features =
        law_pose_features(vservo_protocol::ServoFeatures::try_from(message.servo_features).ok()?);
    let pose_numbers = [message.pose_gain_per_s, message.pose_max_speed_m_s, message.pose_max_rotation_rad_s];
    if !pose_numbers.iter().all(|v| v.is_finite() && *v > 0.0) {
        return None;
    }
    if !message.desired_depths_m.iter().all(|z| *z > 0.0) {
        return None;
    }
    let feature_gain = FeatureGain::from_row_slice(&message.feature_gain);
    let mut past_input_gains = [Matrix6::zeros(); vservo_control::MAX_DELAY_FRAMES];
    for (j, k) in past_input_gains.iter_mut().enumerate().take(MAX_PAST_GAINS) {
        *k = Matrix6::from_row_slice(&message.past_input_gains[36 * j..36 * (j + 1)]);
    }
    Some(LawGains {
        feature_gain,
        past_input_gains,
        used_past_gains: message.used_past_gains as usize,
        desired_features: FeatureVector::from(message.desired_features_px),
        desired_depths: vservo_scene::MarkDepths::from(message.desired_depths_m),
        q: nalgebra::SMatrix::<f64, 8, 8>::from_row_slice(&message.q),
        r_si: Matrix6::from_row_slice(&message.r_si),
        options: vservo_control::LawOptions {
            interaction,
            border_margin_px: margin,
            feedforward: message.feedforward == 1,
            pose_gain_per_s: message.pose_gain_per_s,
            pose_max_speed_m_s: message.pose_max_speed_m_s,
            pose_max_rotation_rad_s: message.pose_max_rotation_rad_s,
        },
        pose_features,
    })
}

/// The law's pose features as the wire's code.
fn wire_servo_features(features: Option<PoseFeatures>) -> vservo_protocol::ServoFeatures {
    match features {
        None => vservo_protocol::ServoFeatures::Image,
        Some(PoseFeatures::CameraPath) => vservo_protocol::ServoFeatures::CameraPose,
        Some(PoseFeatures::TargetPath) => vservo_protocol::ServoFeatures::TargetPose,
        Some(PoseFeatures::TwoAndAHalfD) => vservo_protocol::ServoFeatures::TwoAndAHalfD,
    }
}

/// The wire's code as the law's pose features.
fn law_pose_features(features: vservo_protocol::ServoFeatures) -> Option<PoseFeatures> {
    match features {
        vservo_protocol::ServoFeatures::Image => None,
        vservo_protocol::ServoFeatures::CameraPose => Some(PoseFeatures::CameraPath),
        vservo_protocol::ServoFeatures::TargetPose => Some(PoseFeatures::TargetPath),
        vservo_protocol::ServoFeatures::TwoAndAHalfD => Some(PoseFeatures::TwoAndAHalfD),
    }
}

/// The law's interaction as the wire's code (the law knows no codes).
fn wire_interaction(interaction: vservo_control::Interaction) -> vservo_protocol::Interaction {
    match interaction {
        vservo_control::Interaction::Desired => vservo_protocol::Interaction::Desired,
        vservo_control::Interaction::Mean => vservo_protocol::Interaction::Mean,
        vservo_control::Interaction::Current => vservo_protocol::Interaction::Current,
    }
}

/// The wire's interaction code as the law's.
fn law_interaction(interaction: vservo_protocol::Interaction) -> vservo_control::Interaction {
    match interaction {
        vservo_protocol::Interaction::Desired => vservo_control::Interaction::Desired,
        vservo_protocol::Interaction::Mean => vservo_control::Interaction::Mean,
        vservo_protocol::Interaction::Current => vservo_control::Interaction::Current,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gains_survive_the_wire() {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("default config");
        let mut spec = config.cell.gains_spec();
        spec.law = vservo_control::ControlLaw::TwoAndAHalfD;
        // the options travel with the gains (a reload applies them)
        spec.options = vservo_control::LawOptions {
            interaction: vservo_control::Interaction::Mean,
            border_margin_px: 20.0,
            feedforward: true,
            pose_gain_per_s: 3.0,
            pose_max_speed_m_s: 0.3,
            pose_max_rotation_rad_s: 1.5,
        };
        let gains = vservo_control::Gains::design(&spec).expect("design");
        let law = LawGains::from(&gains);
        let key = vservo_protocol::seal::SealKey::random().expect("a key");
        let message = gains_message(&law, 3, &key);
        assert_eq!(key.seal(&message), message.seal, "sealed");
        let back = law_gains(&message).expect("valid");
        assert_eq!(back, law);
        let mut broken = gains_message(&law, 3, &key);
        broken.feature_gain[5] = f64::NAN;
        assert_eq!(law_gains(&broken), None);
        // the design's fields are sealed and checked too
        let mut changed = gains_message(&law, 3, &key);
        changed.border_margin_px = 0.0;
        assert_ne!(key.seal(&changed), changed.seal, "the margin is under the seal");
        let spoilers: [fn(&mut GainsMsg); 11] = [
            |m: &mut GainsMsg| m.pose_max_speed_m_s = -1.0,
            |m: &mut GainsMsg| m.pose_max_rotation_rad_s = f64::INFINITY,
            |m: &mut GainsMsg| m.servo_features = 4,
            |m: &mut GainsMsg| m.pose_gain_per_s = 0.0,
            |m: &mut GainsMsg| m.pose_gain_per_s = f64::NAN,
            |m: &mut GainsMsg| m.interaction = 3,
            |m: &mut GainsMsg| m.feedforward = 2,
            |m: &mut GainsMsg| m.border_margin_px = -1.0,
            |m: &mut GainsMsg| m.desired_depths_m[2] = 0.0,
            |m: &mut GainsMsg| m.q[9] = f64::NAN,
            |m: &mut GainsMsg| m.r_si[0] = f64::INFINITY,
        ];
        for spoil in spoilers {
            let mut bad = gains_message(&law, 3, &key);
            spoil(&mut bad);
            assert_eq!(law_gains(&bad), None);
        }
    }
}
