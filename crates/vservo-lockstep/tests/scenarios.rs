//! The paper's experiments, from the scenario files, against the paper's claims.

use vservo_config::Config;
use vservo_control::ControlLaw;
use vservo_lockstep::Lockstep;
use vservo_lockstep::summary::{Summary, summarize};

fn scenario(name: &str, law: ControlLaw) -> Summary {
    let path = format!("{}/../../config/scenarios/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let mut config = Config::load(&path).expect("the scenario file is valid");
    config.cell.controller.law = law;
    let trace = Lockstep::new(&config).expect("reachable").run(|_| {});
    assert!(!trace.faults.any_limit(), "{name}: {:?}", trace.faults);
    let summary = summarize(&trace, &config.cell.scenario.object);
    println!("{name} ({}): {summary:?}", law.name());
    summary
}

#[test]
fn translation_step_converges_and_the_delay_aware_law_is_five_times_faster_without_overshoot() {
    let paper = scenario("translation-step", ControlLaw::Paper);
    let aware = scenario("translation-step", ControlLaw::DelayAware);
    assert!(paper.final_error_px < 1.0, "{paper:?}");
    let (t_paper, t_aware) =
        (paper.settling_time_s.expect("settles"), aware.settling_time_s.expect("settles"));
    assert!(t_aware * 5.0 <= t_paper, "paper {t_paper} s, delay-aware {t_aware} s");
    assert!(aware.overshoot_percent.expect("a step") < 10.0, "{aware:?}");
    // the paper's gain overshoots (Fig. 7)
    assert!(paper.overshoot_percent.expect("a step") > 10.0, "{paper:?}");
}

#[test]
fn rotation_step_converges() {
    for law in [ControlLaw::Paper, ControlLaw::DelayAware] {
        let summary = scenario("rotation-step", law);
        assert!(summary.final_error_px < 1.0, "{summary:?}");
        assert!(summary.settling_time_s.is_some(), "{summary:?}");
    }
}

#[test]
fn tracking_stays_within_the_papers_errors_and_the_second_r_follows_the_circle_better() {
    let identity = scenario("tracking-r-identity", ControlLaw::Paper);
    let fig12 = scenario("tracking-r-fig12", ControlLaw::Paper);
    for s in [&identity, &fig12] {
        assert!(s.max_error_x_px.expect("tracking") < 20.0, "{s:?}");
        assert!(s.max_error_y_px.expect("tracking") < 10.0, "{s:?}");
    }
    // the object's circle has a radius of 0.1 m: R = diag(1, 1, 0.5, 6, 6, 6) moves the camera closer to it
    let miss = |s: &Summary| {
        (0.1 - s.camera_amplitude_y_m.expect("tracking")).abs()
            + (0.1 - s.camera_amplitude_z_m.expect("tracking")).abs()
    };
    assert!(miss(&fig12) < miss(&identity), "R = I: {identity:?}, Fig. 12's R: {fig12:?}");
}
