//! `[scenario]`: what the simulated cell does: its length, the camera's start, the board's motion, the
//! occlusions.

use nalgebra::Vector3;
use vservo_scene::MARKS;
use vservo_settings::simulation::ObjectMotion;

use super::checker::Checker;
use crate::raw::{RawObjectMotion, RawOcclusion, RawScenario};
use crate::{ConfigError, MAX_OCCLUSIONS, Occlusion, Scenario};

/// The scenario; every key is checked, whichever motion uses it.
pub fn scenario(check: &Checker, s: &RawScenario) -> Result<Scenario, ConfigError> {
    let duration_s = check.within("scenario.duration_s", s.duration_s, 0.001, 86_400.0, "s")?;
    let translation = check.all_within(
        "scenario.initial_camera_translation_m",
        s.initial_camera_translation_m,
        -1.0,
        1.0,
        "m",
    )?;
    let rotation = check.all_within(
        "scenario.initial_camera_rotation_deg",
        s.initial_camera_rotation_deg,
        -180.0,
        180.0,
        "°",
    )?;
    Ok(Scenario {
        duration_s,
        initial_camera_translation_m: Vector3::from(translation),
        initial_camera_rotation: Vector3::from(rotation.map(f64::to_radians)),
        object: object_motion(check, s)?,
        occlusions: occlusions(check, &s.occlusions)?,
    })
}

/// How the board moves: the step's and the circle's keys checked whichever is chosen.
fn object_motion(check: &Checker, s: &RawScenario) -> Result<ObjectMotion, ConfigError> {
    let at_s = check.within("scenario.step_at_s", s.step_at_s, 0.0, 86_400.0, "s")?;
    let by = check.all_within("scenario.step_translation_m", s.step_translation_m, -1.0, 1.0, "m")?;
    let radius_m = check.within("scenario.circle_radius_m", s.circle_radius_m, 0.001, 1.0, "m")?;
    let rev_per_min =
        check.within("scenario.circle_rev_per_min", s.circle_rev_per_min, 0.001, 60.0, "rev/min")?;
    Ok(match s.object_motion {
        RawObjectMotion::Hold => ObjectMotion::Hold,
        RawObjectMotion::Step => ObjectMotion::Step { at_s, translation_m: Vector3::from(by) },
        RawObjectMotion::Circle => ObjectMotion::Circle { radius_m, rev_per_min },
    })
}

/// At most [`MAX_OCCLUSIONS`], each a mark (1 to 4 in the file) and a span of time.
fn occlusions(
    check: &Checker,
    written: &[RawOcclusion],
) -> Result<[Option<Occlusion>; MAX_OCCLUSIONS], ConfigError> {
    if written.len() > MAX_OCCLUSIONS {
        return Err(check.invalid(
            "scenario.occlusions",
            written.len(),
            format!("at most {MAX_OCCLUSIONS} occlusions"),
        ));
    }
    let mut occlusions = [None; MAX_OCCLUSIONS];
    for (i, (slot, o)) in occlusions.iter_mut().zip(written).enumerate() {
        let key = format!("scenario.occlusions[{i}]");
        let mark =
            check.whole(&format!("{key}.mark"), o.mark, 1usize, MARKS, "must be a mark number, 1 to 4")?;
        if !(o.from_s.is_finite() && o.until_s.is_finite() && 0.0 <= o.from_s && o.from_s < o.until_s) {
            return Err(check.invalid(
                &format!("{key}.until_s"),
                o.until_s,
                format!("must come after from_s ({}), both at least 0 s", o.from_s),
            ));
        }
        *slot = Some(Occlusion { mark: mark - 1, from_s: o.from_s, until_s: o.until_s });
    }
    Ok(occlusions)
}
