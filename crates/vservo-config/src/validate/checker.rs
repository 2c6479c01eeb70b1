//! The checks every section uses, each error naming the file, the key and the value.

use std::time::Duration;

use nalgebra::Vector3;

use crate::raw::RawPose;
use crate::{ConfigError, pose_from_rpy};

/// Builds errors for one file.
pub struct Checker<'a> {
    /// The file, as named in messages.
    pub file: &'a str,
}

impl Checker<'_> {
    /// The error for `key = value`.
    pub fn invalid(
        &self,
        key: &str,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    /// A finite number above 0.
    pub fn positive(&self, key: &str, value: f64) -> Result<f64, ConfigError> {
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(self.invalid(key, value, "must be a positive number"))
        }
    }

    /// A number inside [low, high] (both finite), else an error saying the range.
    pub fn within(&self, key: &str, value: f64, low: f64, high: f64, unit: &str) -> Result<f64, ConfigError> {
        if value.is_finite() && (low..=high).contains(&value) {
            Ok(value)
        } else {
            Err(self.invalid(key, value, format!("must be from {low} to {high} {unit}")))
        }
    }

    /// A time in seconds inside [low, high] (both finite and positive), as a duration.
    pub fn duration(
        &self,
        key: &str,
        value_s: f64,
        low_s: f64,
        high_s: f64,
    ) -> Result<Duration, ConfigError> {
        self.within(key, value_s, low_s, high_s, "s").map(Duration::from_secs_f64)
    }

    /// Every value finite.
    pub fn finite<const N: usize>(&self, key: &str, values: [f64; N]) -> Result<[f64; N], ConfigError> {
        if values.iter().all(|v| v.is_finite()) {
            Ok(values)
        } else {
            Err(self.invalid(key, format!("{values:?}"), "every value must be a finite number"))
        }
    }

    /// Every value inside [low, high], else an error saying the range.
    pub fn all_within<const N: usize>(
        &self,
        key: &str,
        values: [f64; N],
        low: f64,
        high: f64,
        unit: &str,
    ) -> Result<[f64; N], ConfigError> {
        if values.iter().all(|v| v.is_finite() && (low..=high).contains(v)) {
            Ok(values)
        } else {
            Err(self.invalid(key, format!("{values:?}"), format!("each must be from {low} to {high} {unit}")))
        }
    }

    /// One value per joint of `arm`, each finite and within `low..=high`, as a joint vector.
    pub fn per_joint(
        &self,
        key: &str,
        values: &[f64],
        arm: &vservo_arm::SerialArm,
        (low, high): (f64, f64),
        unit: &str,
    ) -> Result<vservo_arm::JointVector, ConfigError> {
        let count = arm.joint_count();
        if values.len() != count {
            return Err(self.invalid(
                key,
                format!("{values:?}"),
                format!("must list the {count} joints of the {}", arm.name),
            ));
        }
        if !values.iter().all(|v| v.is_finite() && (low..=high).contains(v)) {
            return Err(self.invalid(
                key,
                format!("{values:?}"),
                format!("each must be from {low} to {high} {unit}"),
            ));
        }
        vservo_arm::joint_vector(values)
            .ok_or_else(|| self.invalid(key, format!("{values:?}"), "too many joints"))
    }

    /// A pose whose translation stays within ±`reach_m` per axis, its angles within ±360°.
    pub fn pose(
        &self,
        key: &str,
        raw: &RawPose,
        reach_m: f64,
    ) -> Result<nalgebra::IsometryMatrix3<f64>, ConfigError> {
        let translation =
            self.all_within(&format!("{key}.translation_m"), raw.translation_m, -reach_m, reach_m, "m")?;
        let rpy =
            self.all_within(&format!("{key}.rotation_rpy_deg"), raw.rotation_rpy_deg, -360.0, 360.0, "°")?;
        Ok(pose_from_rpy(Vector3::from(translation), Vector3::from(rpy.map(f64::to_radians))))
    }

    /// A whole number inside [low, high] as the type `T`, else `reason`.
    pub fn whole<T: TryFrom<i64> + PartialOrd>(
        &self,
        key: &str,
        value: i64,
        low: T,
        high: T,
        reason: &str,
    ) -> Result<T, ConfigError> {
        T::try_from(value)
            .ok()
            .filter(|v| low <= *v && *v <= high)
            .ok_or_else(|| self.invalid(key, value, reason))
    }
}
