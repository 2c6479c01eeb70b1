//! `[controller]`: the law, Q and R, and the options beyond the paper's law.

use vservo_scene::{CameraIntrinsics, FEATURES, FeatureVector, MARKS};
use vservo_settings::{
    control::{
        DEFAULT_POSE_GAIN_PER_PERIOD, DEFAULT_POSE_MAX_ROTATION_RAD_S, DEFAULT_POSE_MAX_SPEED_M_S,
        Interaction, LawOptions,
    },
    weights::{InputWeight, StateWeight},
};

use super::checker::Checker;
use super::weight::weight;
use crate::raw::RawController;
use crate::{ConfigError, Controller, Robot};

/// The law, its weights (Q ⪰ 0 on the features, R ≻ 0 on the twist in its unit) and its options.
pub fn controller(
    check: &Checker,
    k: &RawController,
    camera: &CameraIntrinsics,
    desired_features: &FeatureVector,
    vision_period_s: f64,
) -> Result<Controller, ConfigError> {
    let q_matrix = weight::<FEATURES>(check, "controller.q", &k.q)?;
    let q = StateWeight::new(q_matrix).map_err(|e| check.invalid("controller.q", &k.q, e.to_string()))?;
    let r_matrix = weight::<6>(check, "controller.r", &k.r)?;
    let r = InputWeight::new(r_matrix, k.r_units.into())
        .map_err(|e| check.invalid("controller.r", &k.r, e.to_string()))?;
    let options = law_options(check, k, camera, desired_features, vision_period_s)?;
    Ok(Controller { law: k.law.into(), q, r, options })
}

/// `controller.interaction`, `controller.border_margin_px`, `controller.feedforward` and
/// `controller.pose_gain_per_s`: optional, the paper's law as published when left out. A margin must leave ξ_d
/// inside it.
fn law_options(
    check: &Checker,
    k: &RawController,
    camera: &CameraIntrinsics,
    desired_features: &FeatureVector,
    vision_period_s: f64,
) -> Result<LawOptions, ConfigError> {
    let interaction = k.interaction.map_or(Interaction::Desired, Interaction::from);
    let border_margin_px = border_margin_px(check, k.border_margin_px.unwrap_or(0.0), camera)?;
    desired_inside_the_margin(check, border_margin_px, camera, desired_features)?;
    let pose_gain_per_s = pose_gain_per_s(check, k.pose_gain_per_s, vision_period_s)?;
    let cap = |key: &str, written: Option<f64>, default: f64, unit: &str| match written {
        None => Ok(default),
        Some(v) => check.within(key, v, 0.001, 20.0, unit),
    };
    Ok(LawOptions {
        interaction,
        border_margin_px,
        feedforward: k.feedforward.unwrap_or(false),
        pose_gain_per_s,
        pose_max_speed_m_s: cap(
            "controller.pose_max_speed_m_s",
            k.pose_max_speed_m_s,
            DEFAULT_POSE_MAX_SPEED_M_S,
            "m/s",
        )?,
        pose_max_rotation_rad_s: cap(
            "controller.pose_max_rotation_rad_s",
            k.pose_max_rotation_rad_s,
            DEFAULT_POSE_MAX_ROTATION_RAD_S,
            "rad/s",
        )?,
    })
}

/// λ of the pose-based laws: positive, and at most one per vision period (λT ≤ 1: the predicted error shrinks
/// by λT a frame; beyond 1 it overshoots, beyond 2 it grows).
fn pose_gain_per_s(check: &Checker, written: Option<f64>, vision_period_s: f64) -> Result<f64, ConfigError> {
    let Some(gain_per_s) = written else {
        return Ok(DEFAULT_POSE_GAIN_PER_PERIOD / vision_period_s);
    };
    let most = 1.0 / vision_period_s;
    if !(gain_per_s.is_finite() && gain_per_s > 0.0 && gain_per_s <= most) {
        return Err(check.invalid(
            "controller.pose_gain_per_s",
            gain_per_s,
            format!(
                "must be positive and at most one per vision period ({most:.2} 1/s at {vision_period_s} s): the \
                 error predicted through the pipeline shrinks by λT a frame"
            ),
        ));
    }
    Ok(gain_per_s)
}

/// At least 0 and less than half the image.
fn border_margin_px(check: &Checker, margin_px: f64, camera: &CameraIntrinsics) -> Result<f64, ConfigError> {
    let half = f64::from(camera.width_px().min(camera.height_px())) / 2.0;
    if !(margin_px.is_finite() && (0.0..half).contains(&margin_px)) {
        return Err(check.invalid(
            "controller.border_margin_px",
            margin_px,
            format!("must be at least 0 and less than half the image ({half} px)"),
        ));
    }
    Ok(margin_px)
}

/// Every desired mark inside the margin: else the barrier would keep the servo from its goal.
fn desired_inside_the_margin(
    check: &Checker,
    margin_px: f64,
    camera: &CameraIntrinsics,
    desired_features: &FeatureVector,
) -> Result<(), ConfigError> {
    let (width, height) = (f64::from(camera.width_px()), f64::from(camera.height_px()));
    let inside = |v: f64, limit: f64| v >= margin_px && v <= limit - margin_px;
    for mark in 0..MARKS {
        let (x, y) = (desired_features[2 * mark], desired_features[2 * mark + 1]);
        if !(inside(x, width) && inside(y, height)) {
            return Err(check.invalid(
                "controller.border_margin_px",
                margin_px,
                format!(
                    "desired mark {} images at ({x:.1}, {y:.1}) px, inside the margin of {margin_px} px along the \
                     {width}×{height} image's edge: the barrier would keep the servo from its goal; place the target \
                     further in (desired.camera_from_board, the marks or [target]) or lower the margin",
                    mark + 1
                ),
            ));
        }
    }
    Ok(())
}

/// The pose-based laws' speed caps within the robot's camera limits, which the rmrc refuses a twist beyond: a cap
/// written above them is refused, a default one lowered to them.
pub fn fit_pose_caps(
    check: &Checker,
    k: &RawController,
    options: &mut LawOptions,
    robot: &Robot,
) -> Result<(), ConfigError> {
    let caps = [
        (
            "controller.pose_max_speed_m_s",
            k.pose_max_speed_m_s.is_some(),
            &mut options.pose_max_speed_m_s,
            robot.max_camera_speed_m_s,
            "max_camera_speed_m_s",
        ),
        (
            "controller.pose_max_rotation_rad_s",
            k.pose_max_rotation_rad_s.is_some(),
            &mut options.pose_max_rotation_rad_s,
            robot.max_camera_rotation_rad_s,
            "max_camera_rotation_rad_s",
        ),
    ];
    for (key, written, cap, limit, limit_key) in caps {
        if written && *cap > limit {
            return Err(check.invalid(
                key,
                *cap,
                format!("must be at most robot.{limit_key} ({limit}): the rmrc refuses a faster twist"),
            ));
        }
        *cap = cap.min(limit);
    }
    Ok(())
}
