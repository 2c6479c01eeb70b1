//! Files written as overlays (`extends`): each means its base with its own keys over it; an error names the
//! file in which the bad key was written; a cycle and a missing base are refused, naming them.

use std::path::{Path, PathBuf};

use vservo_config::{Config, ConfigError};

fn config_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

fn default() -> Config {
    Config::load(config_dir().join("vservo.toml")).expect("the default loads")
}

/// A directory of this test's own, with `files` written into it.
fn directory_with(name: &str, files: &[(&str, &str)]) -> PathBuf {
    let directory = std::env::temp_dir().join(format!("vservo-overlays-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&directory).expect("a temporary directory");
    for (file, text) in files {
        std::fs::write(directory.join(file), text).expect("a temporary file");
    }
    directory
}

fn default_text() -> String {
    std::fs::read_to_string(config_dir().join("vservo.toml")).expect("the default is readable")
}

/// Each scenario is the default cell with exactly the keys its file writes.
#[test]
fn the_scenarios_are_the_default_with_their_keys_changed() {
    let load = |name: &str| Config::load(config_dir().join(format!("scenarios/{name}.toml"))).expect(name);
    let mut expected = default();

    let translation = load("translation-step");
    expected.origin = translation.origin.clone();
    assert!(translation == expected, "the translation step is the default's scenario");

    let rotation = load("rotation-step");
    let mut expected = default();
    expected.origin = rotation.origin.clone();
    expected.cell.scenario.duration_s = 40.0;
    expected.cell.scenario.initial_camera_translation_m = nalgebra::Vector3::zeros();
    expected.cell.scenario.initial_camera_rotation = nalgebra::Vector3::new(0.0, 0.0, 10f64.to_radians());
    assert!(rotation == expected, "{rotation:?}");

    for (name, r) in [
        ("tracking-r-identity", [1.0, 1.0, 1.0, 1.0, 1.0, 1.0]),
        ("tracking-r-fig12", [1.0, 1.0, 0.5, 6.0, 6.0, 6.0]),
    ] {
        let tracking = load(name);
        let mut expected = default();
        expected.origin = tracking.origin.clone();
        expected.cell.scenario.duration_s = 36.0;
        expected.cell.scenario.initial_camera_translation_m = nalgebra::Vector3::zeros();
        expected.cell.scenario.object =
            vservo_settings::simulation::ObjectMotion::Circle { radius_m: 0.1, rev_per_min: 5.0 };
        expected.cell.controller.r = vservo_settings::weights::InputWeight::new(
            nalgebra::SMatrix::<f64, 6, 6>::from_diagonal(&nalgebra::SVector::<f64, 6>::from(r)),
            vservo_settings::weights::InputUnits::MillimetreMilliradian,
        )
        .expect("R");
        assert!(tracking == expected, "{name}: {tracking:?}");
    }
}

/// The resolved text is a whole configuration: `from_toml` takes it (as vservod's nodes do) and a copy
/// anywhere means the same.
#[test]
fn the_resolved_text_means_what_the_file_means() {
    for file in ["vservo.toml", "vservo-robust.toml", "mujoco.toml", "scenarios/rotation-step.toml"] {
        let path = config_dir().join(file);
        let (config, text) = Config::load_with_text(&path).expect(file);
        assert!(!text.contains("extends"), "{file}: {text}");
        assert_eq!(vservo_config::resolve(&path).expect(file), text);
        let again = Config::from_toml(&text, &config.origin).expect(file);
        assert!(again == config, "{file}");
    }
    assert_eq!(
        Config::instance_of(config_dir().join("scenarios/rotation-step.toml")).expect("name"),
        "default"
    );
    assert_eq!(Config::instance_of(config_dir().join("mujoco.toml")).expect("name"), "mujoco");
}

/// `extends` is relative to the file that writes it, wherever the pair is.
#[test]
fn a_base_is_found_next_to_its_overlay_wherever_they_are() {
    let directory = directory_with(
        "relative",
        &[
            ("base.toml", &default_text()),
            ("cell.toml", "extends = \"base.toml\"\n[scenario]\nduration_s = 7.0\n"),
        ],
    );
    let config = Config::load(directory.join("cell.toml")).expect("the overlay loads");
    assert_eq!(config.cell.scenario.duration_s, 7.0);
    assert_eq!(config.cell.timing.control_ticks_per_frame, 85);
    // given as text, there is no file to find the base from
    let error = Config::from_toml("extends = \"base.toml\"\n", "text").expect_err("refused");
    assert_eq!(error.key(), Some("extends"), "{error}");
}

/// A bad value is reported in the file that wrote it: the overlay's own key in the overlay, the base's in
/// the base; a parser's error likewise.
#[test]
fn errors_name_the_file_in_which_the_bad_key_was_written() {
    let bad_base = default_text().replacen("q = 300.0", "q = -1.0", 1);
    let directory = directory_with(
        "blame",
        &[
            ("base.toml", &default_text()),
            ("bad-base.toml", &bad_base),
            ("bad-value.toml", "extends = \"base.toml\"\n[scenario]\nduration_s = 0.0\n"),
            ("good-over-bad.toml", "extends = \"bad-base.toml\"\n[scenario]\nduration_s = 7.0\n"),
            ("unknown-key.toml", "extends = \"base.toml\"\n[scenario]\nduraton_s = 7.0\n"),
            ("unknown-name.toml", "extends = \"base.toml\"\n[plant]\nmode = \"hydraulic\"\n"),
        ],
    );
    let refused = |file: &str| Config::load(directory.join(file)).expect_err(file);
    let named = |file: &str| directory.join(file).display().to_string();

    let error = refused("bad-value.toml");
    assert_eq!((error.file(), error.key()), (named("bad-value.toml").as_str(), Some("scenario.duration_s")));
    let error = refused("good-over-bad.toml");
    assert_eq!((error.file(), error.key()), (named("bad-base.toml").as_str(), Some("controller.q")));
    assert!(
        error.to_string().starts_with(&format!("{}: controller.q = -1.0", named("bad-base.toml"))),
        "{error}"
    );

    let error = refused("unknown-key.toml");
    assert!(matches!(error, ConfigError::Parse { .. }), "{error:?}");
    assert_eq!(error.file(), named("unknown-key.toml"));
    assert!(error.to_string().contains("duraton_s") && error.to_string().contains("scenario"), "{error}");
    let error = refused("unknown-name.toml");
    assert_eq!((error.file(), error.key()), (named("unknown-name.toml").as_str(), Some("plant.mode")));
    assert!(
        error.to_string().contains("`hydraulic`") && error.to_string().contains("`kinematic`"),
        "{error}"
    );
    // on its line in the overlay
    assert!(error.to_string().contains("line 3:"), "{error}");
    assert!(!error.to_string().contains("did you mean"), "no accepted name is near `hydraulic`: {error}");
    // a misspelt key on its own line (not its table's), with the key it was near
    let error = refused("unknown-key.toml");
    assert!(error.to_string().contains("line 3:"), "the key's line, not the [scenario] table's: {error}");
    assert!(error.to_string().contains("did you mean `duration_s`?"), "{error}");
}

/// A misspelt key or name, in an overlay or in a whole file, gets the accepted one nearest it.
#[test]
fn a_misspelt_key_or_name_gets_a_did_you_mean() {
    let directory = directory_with(
        "did-you-mean",
        &[
            ("base.toml", &default_text()),
            ("name.toml", "extends = \"base.toml\"\n\n[robot]\ndriver = \"simulted\"\n"),
            ("whole.toml", &default_text().replacen("height_px = 512", "hieght_px = 512", 1)),
        ],
    );
    let refused = |file: &str| Config::load(directory.join(file)).expect_err(file).to_string();
    let error = refused("name.toml");
    assert!(error.contains("line 4:") && error.contains("did you mean `simulated`?"), "{error}");
    let error = refused("whole.toml");
    assert!(error.contains("hieght_px") && error.contains("did you mean `height_px`?"), "{error}");
    let line = 1 + default_text().lines().position(|l| l.starts_with("height_px")).expect("the key's line");
    assert!(error.contains(&format!("line {line}")), "{error}");
}

/// A file that extends itself, directly or through another, and a base that is not there are refused,
/// naming them.
#[test]
fn a_cycle_and_a_missing_base_are_refused_naming_them() {
    let directory = directory_with(
        "cycle",
        &[
            ("a.toml", "extends = \"b.toml\"\n"),
            ("b.toml", "extends = \"./a.toml\"\n"),
            ("self.toml", "extends = \"self.toml\"\n"),
            ("orphan.toml", "extends = \"missing/base.toml\"\n"),
            ("number.toml", "extends = 3\n"),
        ],
    );
    let refused = |file: &str| Config::load(directory.join(file)).expect_err(file);
    let named = |file: &str| directory.join(file).display().to_string();

    let error = refused("a.toml");
    let ConfigError::Cycle { file, chain } = &error else { panic!("{error:?}") };
    assert_eq!(file, &named("a.toml"));
    assert!(chain.contains("a.toml") && chain.contains("b.toml"), "{error}");
    assert!(matches!(refused("self.toml"), ConfigError::Cycle { .. }));

    let error = refused("orphan.toml");
    let ConfigError::Base { file, base, .. } = &error else { panic!("{error:?}") };
    assert_eq!(file, &named("orphan.toml"));
    assert!(base.ends_with("missing/base.toml"), "{error}");
    assert!(error.to_string().contains("missing/base.toml"), "{error}");

    let error = refused("number.toml");
    assert_eq!((error.file(), error.key()), (named("number.toml").as_str(), Some("extends")));
}

/// A key of the base made wrong by an overlay's keys is the overlay's fault: the error names the overlay, and says
/// the key is as the base writes it (config/vservo.toml's simulated camera, valid alone, under an overlay's
/// external robot driver).
#[test]
fn a_base_key_an_overlay_made_wrong_is_the_overlays_fault() {
    let directory = directory_with(
        "culprit",
        &[
            ("base.toml", &default_text()),
            (
                "external.toml",
                "extends = \"base.toml\"\n\n[robot]\ndriver = \"external\"\ncommand = \"velocity\"\n",
            ),
        ],
    );
    let error =
        Config::load(directory.join("external.toml")).expect_err("a simulated camera, no simulated arm");
    let named = |file: &str| directory.join(file).display().to_string();
    assert_eq!((error.file(), error.key()), (named("external.toml").as_str(), Some("camera.source")));
    let message = error.to_string();
    assert!(message.contains(&format!("as {} writes it", named("base.toml"))), "{message}");
    assert!(message.contains("this file's keys make it wrong"), "{message}");
}
