//! Exposure and gain on the pipeline's source element: what to set, by the element's kind and the
//! properties it has.
//!
//! - `aravissrc` (GigE Vision/USB3 Vision): `exposure` (µs) and `gain` (dB), with `exposure-auto` and
//!   `gain-auto` off;
//! - `v4l2src` (V4L2/UVC): the `extra-controls` structure with `exposure_time_absolute` in V4L2's unit of
//!   100 µs and `auto_exposure` = 1 (manual). V4L2's `gain` is in the device's own units, not dB: gain is
//!   not set there (a warning says how to set it in the pipeline);
//! - any other source with `exposure` / `gain` properties of type double: those, in µs and dB;
//! - otherwise a warning naming the element.

/// A property setting to apply.
#[derive(Debug, Clone, PartialEq)]
pub enum Setting {
    /// A double property.
    Double(&'static str, f64),
    /// An enum property by its nick (`off`).
    EnumNick(&'static str, &'static str),
    /// v4l2src's `extra-controls`: `controls, name=value, …` (integer values).
    ExtraControls(Vec<(&'static str, i32)>),
}

/// What to do on one source element.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plan {
    /// Properties to set.
    pub settings: Vec<Setting>,
    /// What cannot be set, for a warning each.
    pub warnings: Vec<String>,
}

/// The settings for `exposure_us` and `gain_db` on the element `name` made by `factory`, which has the
/// double properties for which `has_double` is true.
pub fn plan(
    name: &str,
    factory: &str,
    has_double: impl Fn(&str) -> bool,
    exposure_us: Option<f64>,
    gain_db: Option<f64>,
) -> Plan {
    let mut plan = Plan::default();
    if exposure_us.is_none() && gain_db.is_none() {
        return plan;
    }
    if factory == "v4l2src" {
        if let Some(us) = exposure_us {
            let hundreds_of_us = (us / 100.0).round().clamp(1.0, f64::from(i32::MAX)) as i32;
            plan.settings.push(Setting::ExtraControls(vec![
                ("auto_exposure", 1),
                ("exposure_time_absolute", hundreds_of_us),
            ]));
        }
        if gain_db.is_some() {
            plan.warnings.push(format!(
                "{name} (v4l2src): V4L2 takes gain in the device's own units, not dB: gain_db is not applied; \
                 set it in the pipeline (extra-controls=\"c,gain=N\", see v4l2-ctl --list-ctrls)"
            ));
        }
        return plan;
    }
    for (value, property, unit, auto) in
        [(exposure_us, "exposure", "exposure_us", "exposure-auto"), (gain_db, "gain", "gain_db", "gain-auto")]
    {
        let Some(value) = value else { continue };
        if has_double(property) {
            if factory == "aravissrc" {
                plan.settings.push(Setting::EnumNick(auto, "off"));
            }
            plan.settings.push(Setting::Double(property, value));
        } else {
            plan.warnings.push(format!(
                "{name} ({factory}) has no `{property}` property: {unit} = {value} is not applied"
            ));
        }
    }
    plan
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aravissrc_takes_microseconds_and_decibels_with_auto_off() {
        let p = plan("cam", "aravissrc", |p| p == "exposure" || p == "gain", Some(2500.0), Some(6.0));
        assert_eq!(
            p.settings,
            vec![
                Setting::EnumNick("exposure-auto", "off"),
                Setting::Double("exposure", 2500.0),
                Setting::EnumNick("gain-auto", "off"),
                Setting::Double("gain", 6.0),
            ]
        );
        assert!(p.warnings.is_empty());
    }

    #[test]
    fn v4l2src_takes_exposure_in_hundreds_of_microseconds_and_warns_about_gain() {
        let p = plan("v4l2src0", "v4l2src", |_| false, Some(2540.0), Some(3.0));
        assert_eq!(
            p.settings,
            vec![Setting::ExtraControls(vec![("auto_exposure", 1), ("exposure_time_absolute", 25)])]
        );
        assert_eq!(p.warnings.len(), 1);
        assert!(p.warnings[0].contains("v4l2src0 (v4l2src)"), "{:?}", p.warnings);
    }

    #[test]
    fn a_source_without_the_properties_is_named_in_a_warning() {
        let p = plan("videotestsrc0", "videotestsrc", |_| false, Some(1000.0), Some(2.0));
        assert!(p.settings.is_empty());
        assert_eq!(p.warnings.len(), 2);
        assert!(p.warnings[0].contains("videotestsrc0 (videotestsrc) has no `exposure`"), "{:?}", p.warnings);
        assert!(p.warnings[1].contains("gain_db = 2"), "{:?}", p.warnings);
    }

    #[test]
    fn nothing_configured_nothing_done() {
        assert_eq!(plan("x", "v4l2src", |_| true, None, None), Plan::default());
    }
}
