//! `vservoctl basin`: a Monte Carlo of starting poses around the desired one, run in the lockstep simulator
//! on all cores, to see from where a law converges: per class the share that settles to 1 px, the median
//! and p90 settling time, and why the others did not.
//!
//! Classes (the starts are split evenly among them): translations and rotations (rotation vector, per axis)
//! drawn uniformly within ±range in the desired camera frame, and rolls about the optical axis of 30–90°
//! either way. A start which the arm cannot reach is not counted; one whose first image does not show all four
//! marks whole is not counted with the others but run on its own: acquired (then converged), or ended as the
//! daemon would end it, in the safe stop `target_lost` once the marks have been missing for
//! `faults.target_lost_s`. A run stops once every mark has stayed within
//! 1 px for `--settled-for` seconds (with `--full` it runs the whole duration and must stay within 1 px to
//! the end); its settling time is when it last entered. The configuration's scenario object motion and
//! occlusions are left out: the board holds still and every mark can be seen.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use nalgebra::Vector3;
use plotters::style::RGBColor;
use rayon::prelude::*;
use serde_json::{Value, json};
use vservo_config::Config;
use vservo_lockstep::{FrameRecord, Lockstep, ServoVerdict};
use vservo_scene::MARKS;

use crate::UsageError;
use crate::config_arg::{ConfigArg, LawArg};

mod draw;

/// Arguments of `vservoctl basin`.
#[derive(Args)]
pub struct BasinArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Starts in all, split evenly among the classes.
    #[arg(long, default_value_t = 400)]
    starts: usize,
    /// The seed of the starts: the same seed, the same starts.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The longest a run may take to settle (simulated s).
    #[arg(long, default_value_t = 30.0)]
    duration: f64,
    /// A run has settled once every mark has stayed within 1 px this long (s); it stops there.
    #[arg(long, default_value_t = 2.0)]
    settled_for: f64,
    /// Run every start for the whole duration instead: it has settled if every mark stays within 1 px from
    /// some time to the end.
    #[arg(long)]
    full: bool,
    /// The control law, overriding `controller.law`.
    #[arg(long, value_enum)]
    law: Option<LawArg>,
    /// Print the result as JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Write basin.json and basin.svg here.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// A class of starts.
#[derive(Debug, Clone, Copy)]
struct Class {
    name: &'static str,
    /// ±, per axis (m).
    translation_m: f64,
    /// ±, per axis (deg).
    rotation_deg: f64,
    /// A roll about the optical axis of this many degrees (lowest, highest), either way; no other motion.
    roll_deg: Option<(f64, f64)>,
}

const CLASSES: [Class; 4] = [
    Class { name: "small", translation_m: 0.05, rotation_deg: 5.0, roll_deg: None },
    Class { name: "medium", translation_m: 0.10, rotation_deg: 15.0, roll_deg: None },
    Class { name: "large", translation_m: 0.15, rotation_deg: 30.0, roll_deg: None },
    Class { name: "roll", translation_m: 0.0, rotation_deg: 0.0, roll_deg: Some((30.0, 90.0)) },
];

/// How one start ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Converged,
    MarksLeftImage,
    Limits,
    NotConverged,
    /// A start with part of the target out of view whose marks stayed missing (the servo looking, or holding)
    /// for `faults.target_lost_s`: the daemon's named safe stop `target_lost`.
    TargetLost,
    /// Not counted: the first image does not show all four marks whole.
    NotAllSeenAtStart,
    /// Not counted: no inverse-kinematics solution within the joint limits.
    Unreachable,
}

impl Outcome {
    /// Every outcome, in the legend's order.
    const ALL: [Outcome; 7] = [
        Outcome::Converged,
        Outcome::MarksLeftImage,
        Outcome::Limits,
        Outcome::NotConverged,
        Outcome::TargetLost,
        Outcome::NotAllSeenAtStart,
        Outcome::Unreachable,
    ];

    fn name(self) -> &'static str {
        match self {
            Outcome::Converged => "converged",
            Outcome::MarksLeftImage => "marks left the image",
            Outcome::Limits => "joint limits",
            Outcome::NotConverged => "not converged in time",
            Outcome::TargetLost => "target lost (safe stop)",
            Outcome::NotAllSeenAtStart => "not all marks seen at start",
            Outcome::Unreachable => "unreachable",
        }
    }

    fn counted(self) -> bool {
        !matches!(self, Outcome::NotAllSeenAtStart | Outcome::Unreachable | Outcome::TargetLost)
    }

    fn colour(self) -> RGBColor {
        match self {
            Outcome::Converged => RGBColor(30, 150, 60),
            Outcome::MarksLeftImage => RGBColor(230, 140, 0),
            Outcome::Limits => RGBColor(150, 60, 170),
            Outcome::NotConverged => RGBColor(200, 30, 30),
            Outcome::TargetLost => RGBColor(60, 90, 200),
            _ => RGBColor(170, 170, 170),
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Start {
    class: usize,
    translation_m: Vector3<f64>,
    rotation: Vector3<f64>,
}

#[derive(Debug, Clone, Copy)]
struct Run {
    start: Start,
    outcome: Outcome,
    settling_time_s: Option<f64>,
    /// A mark's true image left the image at some frame (even if the run converged).
    left_image: bool,
    /// The first image did not show all four marks whole: the start is not counted with the others, but
    /// run, to see whether the cell acquires the target (outcome converged) or ends in a safe stop.
    partial: bool,
}

impl Run {
    /// The outcome a start is drawn as: a start with part of the target out of view as such (a ring, as the
    /// starts not counted), whatever became of it.
    fn drawn_as(&self) -> Outcome {
        if self.partial { Outcome::NotAllSeenAtStart } else { self.outcome }
    }
}

/// SplitMix64: a small, well-mixed generator, so that a seed gives the same starts everywhere.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn starts(count: usize, seed: u64) -> Vec<Start> {
    let mut rng = SplitMix64(seed);
    (0..count)
        .map(|i| {
            let class = i % CLASSES.len();
            let c = CLASSES[class];
            let mut axis = |range: f64| Vector3::from_fn(|_, _| rng.uniform(-range, range));
            let (translation_m, rotation) = match c.roll_deg {
                None => (axis(c.translation_m), axis(c.rotation_deg.to_radians())),
                Some((lo, hi)) => {
                    let roll = rng.uniform(lo, hi).to_radians();
                    let sign = if rng.next() & 1 == 0 { 1.0 } else { -1.0 };
                    (Vector3::zeros(), Vector3::new(0.0, 0.0, sign * roll))
                }
            };
            Start { class, translation_m, rotation }
        })
        .collect()
}

/// The largest true error of any mark in a frame (px).
fn error_px(frame: &FrameRecord, desired: &vservo_scene::FeatureVector) -> f64 {
    (0..MARKS)
        .map(|m| {
            let dx = frame.truth[2 * m] - desired[2 * m];
            let dy = frame.truth[2 * m + 1] - desired[2 * m + 1];
            (dx * dx + dy * dy).sqrt()
        })
        .fold(0.0, f64::max)
}

fn run_one(config: &Config, start: Start, settled_for_s: f64, full: bool) -> Run {
    let mut config = config.clone();
    config.cell.scenario.initial_camera_translation_m = start.translation_m;
    config.cell.scenario.initial_camera_rotation = start.rotation;
    let unreachable = Run {
        start,
        outcome: Outcome::Unreachable,
        settling_time_s: None,
        left_image: false,
        partial: false,
    };
    let Ok(mut lockstep) = Lockstep::new(&config) else { return unreachable };
    let desired = lockstep.gains().desired_features;
    let target_lost_s = config.faults.target_lost.as_secs_f64();
    let mut entered: Option<f64> = None;
    let mut lost_since: Option<f64> = None;
    let trace = lockstep.run_until(|frames| {
        let Some(last) = frames.last() else { return false };
        // as the daemon: marks missing so that the servo cannot servo, for target_lost_s, is a safe stop
        if matches!(last.verdict, Some(ServoVerdict::MarksMissing(_) | ServoVerdict::Reacquiring(_))) {
            let since = *lost_since.get_or_insert(last.t_s);
            if last.t_s - since >= target_lost_s && !frames[0].measured.iter().all(|v| v.is_finite()) {
                return true;
            }
        } else {
            lost_since = None;
        }
        if error_px(last, &desired) < 1.0 {
            let since = *entered.get_or_insert(last.t_s);
            !full && last.t_s - since >= settled_for_s
        } else {
            entered = None;
            false
        }
    });
    let partial = trace.frames.first().is_none_or(|f| !f.measured.iter().all(|v| v.is_finite()));
    let left_image = trace.frames.iter().any(|f| {
        (0..MARKS)
            .any(|m| !config.cell.camera.contains(&nalgebra::Point2::new(f.truth[2 * m], f.truth[2 * m + 1])))
    });
    let settled = trace.frames.last().is_some_and(|last| {
        let long_enough = |since: f64| full || last.t_s - since >= settled_for_s;
        entered.is_some_and(long_enough) && error_px(last, &desired) < 1.0
    });
    let lost =
        trace.frames.last().zip(lost_since).is_some_and(|(last, since)| last.t_s - since >= target_lost_s);
    let outcome = if settled {
        Outcome::Converged
    } else if partial && lost {
        Outcome::TargetLost
    } else if trace.faults.position_limit != 0 || trace.faults.velocity_limit != 0 {
        Outcome::Limits
    } else if left_image && !partial {
        Outcome::MarksLeftImage
    } else {
        Outcome::NotConverged
    };
    Run { start, outcome, settling_time_s: settled.then_some(entered).flatten(), left_image, partial }
}

fn percentile(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let rank = (p * (sorted.len() - 1) as f64).round() as usize;
    Some(sorted[rank.min(sorted.len() - 1)])
}

fn class_summary(runs: &[Run], class: usize) -> Value {
    let mine: Vec<&Run> = runs.iter().filter(|r| r.start.class == class).collect();
    let counted: Vec<&&Run> = mine.iter().filter(|r| !r.partial && r.outcome.counted()).collect();
    let mut times: Vec<f64> = counted.iter().filter_map(|r| r.settling_time_s).collect();
    times.sort_by(f64::total_cmp);
    let converged = times.len();
    let mut reasons = serde_json::Map::new();
    for outcome in [Outcome::MarksLeftImage, Outcome::Limits, Outcome::NotConverged, Outcome::Unreachable] {
        let n = mine.iter().filter(|r| !r.partial && r.outcome == outcome).count();
        if n > 0 {
            reasons.insert(outcome.name().into(), json!(n));
        }
    }
    let partial: Vec<&&Run> = mine.iter().filter(|r| r.partial).collect();
    if !partial.is_empty() {
        reasons.insert(Outcome::NotAllSeenAtStart.name().into(), json!(partial.len()));
    }
    let mut acquired_times: Vec<f64> = partial.iter().filter_map(|r| r.settling_time_s).collect();
    acquired_times.sort_by(f64::total_cmp);
    let mut partial_outcomes = serde_json::Map::new();
    for outcome in Outcome::ALL {
        let n = partial.iter().filter(|r| r.outcome == outcome).count();
        if n > 0 {
            partial_outcomes.insert(outcome.name().into(), json!(n));
        }
    }
    let c = CLASSES[class];
    json!({
        "class": c.name,
        "translation_m": c.translation_m,
        "rotation_deg": c.rotation_deg,
        "roll_deg": c.roll_deg.map(|(lo, hi)| [lo, hi]),
        "starts": mine.len(),
        "counted": counted.len(),
        "converged": converged,
        "converged_share": if counted.is_empty() { None } else { Some(converged as f64 / counted.len() as f64) },
        "median_settling_s": percentile(&times, 0.5),
        "p90_settling_s": percentile(&times, 0.9),
        "marks_left_image": counted.iter().filter(|r| r.left_image).count(),
        "not_converged": reasons,
        // the starts with part of the target out of view: acquired (then converged), or a named safe stop
        "partial_view": {
            "starts": partial.len(),
            "acquired": acquired_times.len(),
            "safe_stop": partial.iter().filter(|r| r.outcome == Outcome::TargetLost).count(),
            "median_settling_s": percentile(&acquired_times, 0.5),
            "outcomes": partial_outcomes,
        },
    })
}

/// Runs the command.
pub fn run(args: &BasinArgs) -> Result<()> {
    let config = args.config.load()?;
    if args.starts == 0 {
        return Err(UsageError("--starts 0: at least one start is needed".into()).into());
    }
    for (name, value) in [("--duration", args.duration), ("--settled-for", args.settled_for)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(UsageError(format!("{name} {value}: must be a positive number of seconds")).into());
        }
    }
    let mut config = config;
    if let Some(law) = args.law {
        config.cell.controller.law = law.law();
    }
    config.cell.scenario.duration_s = args.duration;
    // the board holds still and every mark can be seen: what is measured is the law's reach from a start
    config.cell.scenario.object = vservo_sim::world::ObjectMotion::Hold;
    config.cell.scenario.occlusions = Default::default();
    // the configuration itself must make a cell (a bad one is the user's to fix, not a failed start)
    Lockstep::new(&config).map_err(|e| UsageError(format!("{}: {e}", config.origin)))?;

    let all = starts(args.starts, args.seed);
    let bar = std::io::IsTerminal::is_terminal(&std::io::stderr()).then(|| {
        let bar = indicatif::ProgressBar::new(all.len() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template("starts {bar:40} {pos}/{len} ({elapsed}, {eta} left)")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    let started = std::time::Instant::now();
    let runs: Vec<Run> = all
        .par_iter()
        .map(|&start| {
            let run = run_one(&config, start, args.settled_for, args.full);
            if let Some(bar) = &bar {
                bar.inc(1);
            }
            run
        })
        .collect();
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let wall_s = started.elapsed().as_secs_f64();

    let classes: Vec<Value> = (0..CLASSES.len()).map(|c| class_summary(&runs, c)).collect();
    let result = json!({
        "config": config.origin,
        "law": config.cell.controller.law.name(),
        "interaction": config.cell.controller.options.interaction.name(),
        "border_margin_px": config.cell.controller.options.border_margin_px,
        "feedforward": config.cell.controller.options.feedforward,
        "plant": config.cell.plant.mode.name(),
        "limits": limits_kept(&config.cell),
        "starts": args.starts,
        "seed": args.seed,
        "duration_s": args.duration,
        "settled_for_s": if args.full { None } else { Some(args.settled_for) },
        "full": args.full,
        "threads": rayon::current_num_threads(),
        "wall_s": wall_s,
        "classes": classes,
        "runs": runs.iter().map(|r| json!({
            "class": CLASSES[r.start.class].name,
            "translation_m": [r.start.translation_m.x, r.start.translation_m.y, r.start.translation_m.z],
            "rotation_deg": [
                r.start.rotation.x.to_degrees(),
                r.start.rotation.y.to_degrees(),
                r.start.rotation.z.to_degrees(),
            ],
            "outcome": r.outcome.name(),
            "settling_time_s": r.settling_time_s,
            "marks_left_image": r.left_image,
        })).collect::<Vec<_>>(),
    });
    if let Some(dir) = &args.out {
        vservo_config::new_file::folder(dir)?;
        crate::output::write_in(dir, "basin.json", format!("{result:#}\n").as_bytes())?;
        let mut svg = String::new();
        draw::draw(&runs, &mut svg)?;
        crate::output::write_in(dir, "basin.svg", svg.as_bytes())?;
    }
    if args.json {
        let mut summary = result.clone();
        if let Some(object) = summary.as_object_mut() {
            object.remove("runs");
        }
        println!("{summary}");
    } else {
        print_table(&result);
    }
    Ok(())
}

/// The limits the runs' reference keeps, in words: the arm's (its file's acceleration and jerk, the tool's
/// caps), or none for the paper's ideal robot.
fn limits_kept(cell: &vservo_config::CellConfig) -> String {
    let kept = vservo_cell::Cell::new(cell).map(|c| c.keeps_limits()).unwrap_or(true);
    if !kept {
        return "none (the ideal robot)".to_string();
    }
    let i = &cell.interpolator;
    let joints = cell.arm.joint_count();
    let most = |v: &vservo_arm::JointVector| v.rows(0, joints).max();
    let jerk = i.jerk_limit.map_or("no jerk limit".to_string(), |j| format!("{} rad/s³", most(&j)));
    format!(
        "up to {} rad/s², {jerk}, tool {} m/s and {} rad/s, at speed scale {}",
        most(&i.acceleration_limit),
        i.tool_speed_limit_m_s,
        i.tool_rotation_limit_rad_s,
        i.speed_scale
    )
}

fn print_table(result: &Value) {
    println!(
        "{} — law {}, interaction {}, margin {} px, feed-forward {}, {} plant, limits kept: {}; {} starts (seed {}) \
         in {:.1} s on {} threads",
        result["config"].as_str().unwrap_or(""),
        result["law"].as_str().unwrap_or(""),
        result["interaction"].as_str().unwrap_or(""),
        result["border_margin_px"],
        result["feedforward"],
        result["plant"].as_str().unwrap_or(""),
        result["limits"].as_str().unwrap_or(""),
        result["starts"],
        result["seed"],
        result["wall_s"].as_f64().unwrap_or(f64::NAN),
        result["threads"],
    );
    println!(
        "{:<8} {:>7} {:>10} {:>10} {:>9} {:>9} {:>6}  not converged",
        "class", "counted", "converged", "share", "median s", "p90 s", "left"
    );
    let seconds = |v: &Value| v.as_f64().map_or("-".to_string(), |s| format!("{s:.2}"));
    for class in result["classes"].as_array().into_iter().flatten() {
        let reasons = class["not_converged"]
            .as_object()
            .map(|m| m.iter().map(|(k, v)| format!("{k}: {v}")).collect::<Vec<_>>().join(", "))
            .unwrap_or_default();
        let count = |key: &str| class[key].as_u64().unwrap_or(0);
        println!(
            "{:<8} {:>7} {:>10} {:>9.1}% {:>9} {:>9} {:>6}  {}",
            class["class"].as_str().unwrap_or(""),
            count("counted"),
            count("converged"),
            class["converged_share"].as_f64().unwrap_or(f64::NAN) * 100.0,
            seconds(&class["median_settling_s"]),
            seconds(&class["p90_settling_s"]),
            count("marks_left_image"),
            reasons,
        );
    }
    println!(
        "starts with part of the target out of view: acquired (median settling) / safe stop (target lost) / other"
    );
    for class in result["classes"].as_array().into_iter().flatten() {
        let partial = &class["partial_view"];
        let count = |key: &str| partial[key].as_u64().unwrap_or(0);
        let other = count("starts") - count("acquired") - count("safe_stop");
        println!(
            "{:<8} {:>3} of {:>3} acquired ({} s) / {} safe stop / {} other",
            class["class"].as_str().unwrap_or(""),
            count("acquired"),
            count("starts"),
            seconds(&partial["median_settling_s"]),
            count("safe_stop"),
            other,
        );
    }
}

/// One panel per class: each start at its translation (cm, norm) and rotation (deg, norm), coloured by
/// outcome.
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_are_drawn_within_their_class_and_the_same_seed_gives_the_same_starts() {
        let a = starts(400, 7);
        let b = starts(400, 7);
        assert!(
            a.iter().zip(&b).all(|(x, y)| x.translation_m == y.translation_m && x.rotation == y.rotation)
        );
        assert_ne!(starts(4, 8)[0].translation_m, a[0].translation_m);
        for s in &a {
            let c = CLASSES[s.class];
            match c.roll_deg {
                None => {
                    assert!(s.translation_m.amax() <= c.translation_m);
                    assert!(s.rotation.amax() <= c.rotation_deg.to_radians());
                }
                Some((lo, hi)) => {
                    let roll = s.rotation.z.abs().to_degrees();
                    assert!((lo..=hi).contains(&roll) && s.translation_m == Vector3::zeros());
                }
            }
        }
        assert_eq!(a.iter().filter(|s| s.class == 3).count(), 100);
    }

    #[test]
    fn percentiles_of_a_sorted_list() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.5), Some(6.0));
        assert_eq!(percentile(&v, 0.9), Some(9.0));
        assert_eq!(percentile(&[], 0.5), None);
    }
}
