//! `[vision]`: the feature extractor's tuning, and `[vision.render]`, the simulated camera's scene.

use vservo_settings::vision::{ExtractorSettings, RenderSettings, Threshold};

use super::checker::Checker;
use crate::raw::{RawRender, RawVision};
use crate::{ConfigError, Vision, VisionSource};

/// The image source with the extractor's and the renderer's settings.
pub fn vision(check: &Checker, v: &RawVision, source: VisionSource) -> Result<Vision, ConfigError> {
    Ok(Vision {
        source,
        undistort: v.undistort,
        extractor: extractor(check, v)?,
        render: render(check, &v.render)?,
    })
}

fn extractor(check: &Checker, v: &RawVision) -> Result<ExtractorSettings, ConfigError> {
    let threshold = threshold(check, &v.threshold)?;
    let area = |key: &str, value: i64| {
        check.whole(key, value, 1u32, u32::MAX, "must be a whole number of pixels, at least 1")
    };
    let min_area_px = area("vision.min_mark_area_px", v.min_mark_area_px)?;
    let max_area_px = area("vision.max_mark_area_px", v.max_mark_area_px)?;
    if max_area_px <= min_area_px {
        return Err(check.invalid(
            "vision.max_mark_area_px",
            max_area_px,
            format!("must exceed vision.min_mark_area_px ({min_area_px})"),
        ));
    }
    check.within("vision.max_elongation", v.max_elongation, 1.0, 100.0, "")?;
    if !(v.min_ellipse_fill.is_finite() && (0.0..=1.0).contains(&v.min_ellipse_fill)) {
        return Err(check.invalid("vision.min_ellipse_fill", v.min_ellipse_fill, "must be between 0 and 1"));
    }
    let gate_px = check.within("vision.gate_px", v.gate_px, 0.1, 16384.0, "px")?;
    Ok(ExtractorSettings {
        threshold,
        min_area_px,
        max_area_px,
        max_elongation: v.max_elongation,
        min_ellipse_fill: v.min_ellipse_fill,
        gate_px,
    })
}

/// `vision.threshold`: `"otsu"` or a gray level (a name or a number: the one key whose value is either).
fn threshold(check: &Checker, value: &toml::Value) -> Result<Threshold, ConfigError> {
    match value {
        toml::Value::String(s) if s == "otsu" => Ok(Threshold::Otsu),
        toml::Value::Integer(level) if (1..=255).contains(level) => Ok(Threshold::Fixed(*level as u8)),
        other => {
            Err(check.invalid("vision.threshold", other, "must be \"otsu\" or a gray level from 1 to 255"))
        }
    }
}

fn render(check: &Checker, r: &RawRender) -> Result<RenderSettings, ConfigError> {
    let gray = |key: &str, value: f64| {
        if value.is_finite() && (0.0..=255.0).contains(&value) {
            Ok(value)
        } else {
            Err(check.invalid(key, value, "must be a gray level from 0 to 255"))
        }
    };
    let background_gray = gray("vision.render.background_gray", r.background_gray)?;
    let board_gray = gray("vision.render.board_gray", r.board_gray)?;
    let mark_gray = gray("vision.render.mark_gray", r.mark_gray)?;
    if board_gray - mark_gray < 20.0 {
        return Err(check.invalid(
            "vision.render.mark_gray",
            mark_gray,
            format!("must be at least 20 levels darker than the board ({board_gray})"),
        ));
    }
    if !(r.noise_sigma_gray.is_finite() && (0.0..=50.0).contains(&r.noise_sigma_gray)) {
        return Err(check.invalid(
            "vision.render.noise_sigma_gray",
            r.noise_sigma_gray,
            "must be between 0 and 50 gray levels",
        ));
    }
    let lighting_gradient = check.finite("vision.render.lighting_gradient", r.lighting_gradient)?;
    if lighting_gradient.iter().any(|g| g.abs() >= 1.0) {
        return Err(check.invalid(
            "vision.render.lighting_gradient",
            format!("{lighting_gradient:?}"),
            "each must be between −1 and 1 (a fraction of the brightness)",
        ));
    }
    let supersampling = check.whole(
        "vision.render.supersampling",
        r.supersampling,
        1u32,
        16,
        "must be from 1 to 16 samples per axis",
    )?;
    if !(r.exposure_s.is_finite() && (0.0..=0.1).contains(&r.exposure_s)) {
        return Err(check.invalid(
            "vision.render.exposure_s",
            r.exposure_s,
            "must be from 0 (an instant) to 0.1 s",
        ));
    }
    Ok(RenderSettings {
        background_gray,
        board_gray,
        mark_gray,
        noise_sigma_gray: r.noise_sigma_gray,
        // the seed's bits as written, negative numbers included
        noise_seed: r.noise_seed as u64,
        lighting_gradient,
        supersampling,
        exposure_s: r.exposure_s,
    })
}
