//! Conversions between the wire payloads and the core types they carry.

use nalgebra::Matrix6;
use vservo_control::{FeatureGain, LawGains};
use vservo_protocol::{GainsMsg, MAX_PAST_GAINS, SCHEMA_VERSION};
use vservo_scene::{FeatureVector, IsometryMatrix3};

/// A fixed-size vector as the array a payload carries.
pub fn to_array<const N: usize>(v: &nalgebra::SVector<f64, N>) -> [f64; N] {
    let mut out = [0.0; N];
    out.copy_from_slice(v.as_slice());
    out
}

/// The wire code of a command interface ([`vservo_protocol::command_mode`]).
pub fn command_mode_code(interface: vservo_config::CommandInterface) -> u32 {
    use vservo_protocol::command_mode;
    match interface {
        vservo_config::CommandInterface::Torque => command_mode::TORQUE,
        vservo_config::CommandInterface::Velocity => command_mode::VELOCITY,
        vservo_config::CommandInterface::Position => command_mode::POSITION,
    }
}

/// A pose as `sim_world.base_from_board` carries it: 3×4 [R | t] row-major.
pub fn pose_to_wire(pose: &IsometryMatrix3<f64>) -> [f64; 12] {
    let (r, t) = (pose.rotation.matrix(), pose.translation.vector);
    let mut out = [0.0; 12];
    for row in 0..3 {
        for col in 0..3 {
            out[4 * row + col] = r[(row, col)];
        }
        out[4 * row + 3] = t[row];
    }
    out
}

/// The pose from a 3×4 [R | t] row-major array; `None` if a number is not finite or R is not a rotation
/// (RᵀR = I and det R = 1 to 1e-6).
pub fn pose_from_wire(m: &[f64; 12]) -> Option<IsometryMatrix3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let rotation = nalgebra::Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    let orthonormal = (rotation.transpose() * rotation - nalgebra::Matrix3::identity()).amax() < 1e-6;
    if !orthonormal || (rotation.determinant() - 1.0).abs() > 1e-6 {
        return None;
    }
    Some(IsometryMatrix3::from_parts(
        nalgebra::Vector3::new(m[3], m[7], m[11]).into(),
        nalgebra::Rotation3::from_matrix_unchecked(rotation),
    ))
}

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
        interaction: gains.options.interaction.code(),
        feedforward: u32::from(gains.options.feedforward),
        border_margin_px: gains.options.border_margin_px,
        seal: 0,
    };
    message.seal = key.seal_gains(&message);
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
    let interaction = vservo_control::Interaction::from_code(message.interaction)?;
    let margin = message.border_margin_px;
    if !(margin.is_finite() && margin >= 0.0) || message.feedforward > 1 {
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
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_survive_the_wire_and_non_finite_ones_are_refused() {
        let pose = IsometryMatrix3::from_parts(
            nalgebra::Translation3::new(1.2, -0.15, 0.66),
            nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 1.1),
        );
        assert_eq!(pose_from_wire(&pose_to_wire(&pose)), Some(pose));
        let mut broken = pose_to_wire(&pose);
        broken[7] = f64::INFINITY;
        assert_eq!(pose_from_wire(&broken), None);
        // a matrix that is not a rotation is no pose
        let mut scaled = pose_to_wire(&pose);
        scaled[0] *= 1.01;
        assert_eq!(pose_from_wire(&scaled), None);
        let mirrored = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        assert_eq!(pose_from_wire(&mirrored), None);
    }

    #[test]
    fn gains_survive_the_wire() {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("default config");
        let mut spec = config.gains_spec();
        spec.law = vservo_control::ControlLaw::DelayAware;
        // the options travel with the gains (a reload applies them)
        spec.options = vservo_control::LawOptions {
            interaction: vservo_control::Interaction::Mean,
            border_margin_px: 20.0,
            feedforward: true,
        };
        let gains = vservo_control::Gains::design(&spec).expect("design");
        let law = LawGains::from(&gains);
        let key = vservo_protocol::seal::SealKey::random().expect("a key");
        let message = gains_message(&law, 3, &key);
        assert_eq!(key.seal_gains(&message), message.seal, "sealed");
        let back = law_gains(&message).expect("valid");
        assert_eq!(back, law);
        let mut broken = gains_message(&law, 3, &key);
        broken.feature_gain[5] = f64::NAN;
        assert_eq!(law_gains(&broken), None);
        // the design's fields are sealed and checked too
        let mut changed = gains_message(&law, 3, &key);
        changed.border_margin_px = 0.0;
        assert_ne!(key.seal_gains(&changed), changed.seal, "the margin is under the seal");
        let spoilers: [fn(&mut GainsMsg); 6] = [
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
