//! `[controller]`: the law, Q and R, and the options beyond the paper's law.

use vservo_scene::{CameraIntrinsics, FEATURES, FeatureVector, MARKS};
use vservo_settings::{
    control::{Interaction, LawOptions},
    weights::{InputWeight, StateWeight},
};

use super::checker::Checker;
use super::weight::weight;
use crate::raw::RawController;
use crate::{ConfigError, Controller};

/// The law, its weights (Q ⪰ 0 on the features, R ≻ 0 on the twist in its unit) and its options.
pub fn controller(
    check: &Checker,
    k: &RawController,
    camera: &CameraIntrinsics,
    desired_features: &FeatureVector,
) -> Result<Controller, ConfigError> {
    let q_matrix = weight::<FEATURES>(check, "controller.q", &k.q)?;
    let q = StateWeight::new(q_matrix).map_err(|e| check.invalid("controller.q", &k.q, e.to_string()))?;
    let r_matrix = weight::<6>(check, "controller.r", &k.r)?;
    let r = InputWeight::new(r_matrix, k.r_units.into())
        .map_err(|e| check.invalid("controller.r", &k.r, e.to_string()))?;
    let options = law_options(check, k, camera, desired_features)?;
    Ok(Controller { law: k.law.into(), q, r, options })
}

/// `controller.interaction`, `controller.border_margin_px` and `controller.feedforward`: optional, the paper's
/// law as published when left out. A margin must leave ξ_d inside it.
fn law_options(
    check: &Checker,
    k: &RawController,
    camera: &CameraIntrinsics,
    desired_features: &FeatureVector,
) -> Result<LawOptions, ConfigError> {
    let interaction = k.interaction.map_or(Interaction::Desired, Interaction::from);
    let border_margin_px = border_margin_px(check, k.border_margin_px.unwrap_or(0.0), camera)?;
    desired_inside_the_margin(check, border_margin_px, camera, desired_features)?;
    Ok(LawOptions { interaction, border_margin_px, feedforward: k.feedforward.unwrap_or(false) })
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
