//! The one gains design: the servo's gains for a configuration and the target in force (the file's
//! `[desired]`, or one a client placed with [`crate::target`]). [`crate::Cell::new`] designs through here
//! (the daemon's start check, every node, the lockstep), and so does the daemon's commander for each
//! version it hands the servo; the servo runs the version the daemon's `gains` message names.

use vservo_config::CellConfig;
use vservo_control::{Gains, GainsError, GainsSpec};

use crate::target::Target;

/// What the gains are designed for: the configuration's specification, with `target` (if a client set
/// one) in place of `[desired]`'s features and depths.
pub fn spec(config: &CellConfig, target: Option<&Target>) -> GainsSpec {
    let mut spec = config.gains_spec();
    if let Some(target) = target {
        spec.desired_features = target.features;
        spec.desired_depths = target.depths;
    }
    spec
}

/// The servo's gains for `config` and the target in force.
pub fn design(config: &CellConfig, target: Option<&Target>) -> Result<Gains, GainsError> {
    Gains::design(&spec(config, target))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::{CellNow, TargetRequest, place};

    fn config() -> CellConfig {
        vservo_config::Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml")
            .expect("the default")
            .cell
    }

    #[test]
    fn a_clients_target_replaces_the_files_and_the_rest_is_the_files() {
        let config = config();
        let features = [161.0, 168.0, 328.0, 178.0, 349.0, 75.0, 182.0, 70.0].into();
        let target =
            place(&config, 0.0, &TargetRequest::Features(features), &CellNow::default()).expect("placed");
        let file = design(&config, None).expect("the file's");
        let client = design(&config, Some(&target)).expect("the client's");
        assert_eq!(file.desired_features, config.desired.features);
        assert_eq!((client.desired_features, client.desired_depths), (target.features, target.depths));
        assert_ne!(client.feature_gain, file.feature_gain, "designed for the client's target");
        assert_eq!(spec(&config, Some(&target)).q, config.gains_spec().q);
    }
}
