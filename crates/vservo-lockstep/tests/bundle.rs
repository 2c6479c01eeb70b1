//! A bundle of four tags through the lens (config/vservo-bundle.toml: config/vservo-apriltag.toml's cell, its
//! target four tag36h11 tags): the features are the bundle's outer corners through the homography of the tags
//! seen, so that a tag covered, while the camera moves or for the whole run, costs no frame and the servo
//! converges below 1 px of the true corners.

use vservo_config::{Config, Occlusion};
use vservo_lockstep::summary::summarize;
use vservo_lockstep::{Lockstep, Trace};

fn bundle() -> Config {
    Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-bundle.toml"))
        .expect("config/vservo-bundle.toml is valid")
}

fn run(config: &Config) -> Trace {
    let trace = Lockstep::new(config).expect("reachable").run(|_| {});
    assert!(!trace.faults.any_limit(), "{:?}", trace.faults);
    trace
}

/// Frames in `from_s..until_s` in which a feature is missing.
fn frames_missing_a_feature(trace: &Trace, from_s: f64, until_s: f64) -> usize {
    let during = trace.frames.iter().filter(|f| (from_s..until_s).contains(&f.t_s));
    during.filter(|f| f.measured.iter().any(|v| !v.is_finite())).count()
}

/// The file's scenario: the second tag covered from 2 s to 6 s. No frame misses a feature, covered or not, and
/// the servo converges below 1 px.
#[test]
fn a_bundle_with_a_tag_covered_while_moving_loses_no_frame_and_converges_below_one_pixel() {
    let mut config = bundle();
    assert_eq!(config.cell.board.target_tags().len(), 4, "the premise: a bundle of four");
    assert!(
        config.cell.scenario.occlusions[0] == Some(Occlusion { mark: 1, from_s: 2.0, until_s: 6.0 }),
        "the premise: the second tag covered from 2 s to 6 s"
    );
    config.cell.scenario.duration_s = 8.0;
    let trace = run(&config);
    assert_eq!(frames_missing_a_feature(&trace, 0.0, 8.0), 0, "a frame without features");
    let summary = summarize(&trace, &config.cell.scenario.object);
    println!(
        "tag 2 covered 2–6 s: final error {:.3} px, settling {:?} s",
        summary.final_error_px, summary.settling_time_s
    );
    assert!(summary.final_error_px < 1.0, "{summary:?}");
}

/// A corner's tag covered for the whole run (the bundle found from the other three from the first frame): the
/// servo converges below 1 px of the true outer corners, the covered tag's among them, with the file's image law
/// and with the pose-based law (the board's pose from the outer corners, so from every tag seen).
#[test]
fn a_bundle_with_one_tag_covered_all_along_converges_below_one_pixel() {
    use vservo_control::ControlLaw;
    for (tag, law) in [(0, None), (2, None), (0, Some(ControlLaw::Pbvs))] {
        let mut config = bundle();
        if let Some(law) = law {
            config.cell.controller.law = law;
        }
        config.cell.scenario.duration_s = 6.0;
        config.cell.scenario.occlusions = [None; vservo_config::MAX_OCCLUSIONS];
        config.cell.scenario.occlusions[0] = Some(Occlusion { mark: tag, from_s: 0.0, until_s: 6.0 });
        let trace = run(&config);
        assert_eq!(
            frames_missing_a_feature(&trace, 0.0, 6.0),
            0,
            "tag {}: a frame without features",
            tag + 1
        );
        let summary = summarize(&trace, &config.cell.scenario.object);
        println!(
            "tag {} covered all along, {:?}: final error {:.3} px",
            tag + 1,
            config.cell.controller.law,
            summary.final_error_px
        );
        assert!(summary.final_error_px < 1.0, "tag {}: {summary:?}", tag + 1);
    }
}
