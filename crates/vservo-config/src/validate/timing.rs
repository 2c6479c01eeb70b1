//! `[instance]` and `[timing]`.

use super::checker::Checker;
use crate::raw::{RawInstance, RawTiming};
use crate::{ConfigError, INSTANCE_NAME_RULE, Timing, is_instance_name};

/// The instance name, trimmed.
pub fn instance(check: &Checker, raw: &RawInstance) -> Result<String, ConfigError> {
    let name = raw.name.trim();
    if !is_instance_name(name) {
        return Err(check.invalid("instance.name", format!("{:?}", raw.name), INSTANCE_NAME_RULE));
    }
    Ok(name.to_string())
}

/// The periods, the vision period a whole number of control periods, and the pipeline delay.
pub fn timing(check: &Checker, t: &RawTiming) -> Result<Timing, ConfigError> {
    let vision_period_s = check.within("timing.vision_period_s", t.vision_period_s, 0.001, 10.0, "s")?;
    let control_period_s = check.within("timing.control_period_s", t.control_period_s, 1e-4, 0.1, "s")?;
    let control_ticks_per_frame = ticks_per_frame(check, vision_period_s, control_period_s)?;
    let most_frames = vservo_settings::control::MAX_DELAY_FRAMES;
    let pipeline_delay_frames = check.whole(
        "timing.pipeline_delay_frames",
        t.pipeline_delay_frames,
        0,
        most_frames,
        &format!("must be between 0 and {most_frames}"),
    )?;
    Ok(Timing { vision_period_s, pipeline_delay_frames, control_period_s, control_ticks_per_frame })
}

/// Control periods per vision period: a whole number from 1 to a million.
fn ticks_per_frame(check: &Checker, vision_period_s: f64, control_period_s: f64) -> Result<u32, ConfigError> {
    let ticks = vision_period_s / control_period_s;
    if (ticks - ticks.round()).abs() > 1e-6 * ticks || ticks.round() < 1.0 || ticks > 1e6 {
        return Err(check.invalid(
            "timing.vision_period_s",
            vision_period_s,
            format!(
                "must be a whole number of control periods ({control_period_s} s); it is {ticks} of them"
            ),
        ));
    }
    Ok(ticks.round() as u32)
}
