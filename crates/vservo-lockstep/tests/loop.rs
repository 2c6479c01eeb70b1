//! The lockstep loop: the paper's translation step converges, runs are bit-identical, and the delay-aware
//! law is faster.

use vservo_config::Config;
use vservo_control::ControlLaw;
use vservo_lockstep::{Lockstep, Trace};
use vservo_sim::plant::PlantMode;

fn config(law: ControlLaw) -> Config {
    let mut config =
        Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml").expect("valid");
    config.cell.controller.law = law;
    config
}

fn run(law: ControlLaw, plant: PlantMode, duration_s: f64) -> Trace {
    let mut config = config(law);
    config.cell.plant.mode = plant;
    config.cell.scenario.duration_s = duration_s;
    Lockstep::new(&config).expect("reachable").run(|_| {})
}

/// The largest true feature error (px) of a frame.
fn error_px(trace: &Trace, frame: usize) -> f64 {
    let f = &trace.frames[frame];
    (0..4)
        .map(|m| {
            let dx = f.truth[2 * m] - trace.desired_features[2 * m];
            let dy = f.truth[2 * m + 1] - trace.desired_features[2 * m + 1];
            (dx * dx + dy * dy).sqrt()
        })
        .fold(0.0, f64::max)
}

/// The time after which every mark's error stays below `limit_px`.
fn settling_time(trace: &Trace, limit_px: f64) -> f64 {
    let last_out = (0..trace.frames.len()).rev().find(|&i| error_px(trace, i) >= limit_px);
    match last_out {
        Some(i) if i + 1 < trace.frames.len() => trace.frames[i + 1].t_s,
        Some(_) => f64::INFINITY,
        None => 0.0,
    }
}

#[test]
fn kinematic_translation_step_converges_with_the_papers_gain() {
    let trace = run(ControlLaw::Paper, PlantMode::Kinematic, 30.0);
    let start = error_px(&trace, 0);
    assert!(start > 20.0, "the step starts ~30 px away: {start}");
    let last = trace.frames.len() - 1;
    assert!(error_px(&trace, last) < 0.05, "final error {} px", error_px(&trace, last));
    assert!(!trace.faults.any_limit(), "{:?}", trace.faults);
    println!("paper, kinematic: settles to 1 px in {:.2} s", settling_time(&trace, 1.0));
}

#[test]
fn delay_aware_law_settles_at_least_five_times_faster() {
    let paper = run(ControlLaw::Paper, PlantMode::Kinematic, 20.0);
    let aware = run(ControlLaw::DelayAware, PlantMode::Kinematic, 20.0);
    let (t_paper, t_aware) = (settling_time(&paper, 1.0), settling_time(&aware, 1.0));
    println!("settling to 1 px: paper {t_paper:.2} s, delay-aware {t_aware:.2} s");
    assert!(t_aware * 5.0 <= t_paper, "paper {t_paper} s, delay-aware {t_aware} s");
}

#[test]
fn two_runs_are_bit_identical() {
    let a = run(ControlLaw::Paper, PlantMode::Dynamic, 2.0);
    let b = run(ControlLaw::Paper, PlantMode::Dynamic, 2.0);
    assert_eq!(a, b);
    assert!(a.frames.len() > 20 && a.joints.len() > 150);
}

#[test]
fn full_dynamics_with_rendered_images_tracks_the_kinematic_loop() {
    let kinematic = run(ControlLaw::Paper, PlantMode::Kinematic, 30.0);
    let dynamic = run(ControlLaw::Paper, PlantMode::Dynamic, 30.0);
    let mut sum_sq = 0.0;
    let mut n = 0;
    for (k, d) in kinematic.frames.iter().zip(&dynamic.frames) {
        for i in 0..8 {
            sum_sq += (k.truth[i] - d.truth[i]).powi(2);
            n += 1;
        }
    }
    let rms = (sum_sq / n as f64).sqrt();
    println!("RMS feature difference, dynamic vs kinematic plant: {rms:.4} px");
    // the step is ~30 px; the arm's own dynamics (acceleration limits, servo lag) may add a few
    assert!(rms < 0.1 * error_px(&kinematic, 0), "{rms} px");
    let last = dynamic.frames.len() - 1;
    // Coulomb friction leaves a small stick-slip cycle (measured 0.1–0.5 px over 60 s)
    assert!(error_px(&dynamic, last) < 1.0, "dynamic final error {} px", error_px(&dynamic, last));
    assert!(!dynamic.faults.any_limit(), "{:?}", dynamic.faults);
}

#[test]
fn recorded_images_are_refused_with_a_reason() {
    let mut config = config(ControlLaw::Paper);
    config.cell.vision.source = vservo_config::VisionSource::Directory("/tmp".into());
    let error = Lockstep::new(&config).err().expect("refused");
    assert!(error.to_string().contains("camera.source"), "{error}");
}
