//! `vservoctl stability`: the Corollary 1 margins — how far the object may move from the desired pose,
//! along and about each camera axis, before the fixed gain's loop becomes unstable.

use anyhow::Result;
use clap::Args;
use serde_json::{Map, Value, json};
use vservo_control::analysis::{LoopUnderTest, Margin, StabilityMargins};

use crate::config_arg::{ConfigArg, design_delay_aware, design_gains};
use crate::output::print_stdout;

/// Arguments of `vservoctl stability`.
#[derive(Args)]
pub struct StabilityArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

const AXES: [&str; 3] = ["x", "y", "z"];

fn insert(map: &mut Map<String, Value>, bounds: &mut Map<String, Value>, prefix: &str, m: &StabilityMargins) {
    for (i, axis) in AXES.iter().enumerate() {
        let t = m.translation[i];
        let r = m.rotation[i];
        map.insert(format!("{prefix}trans_{axis}"), json!(t.magnitude));
        map.insert(format!("{prefix}rot_{axis}"), json!(r.magnitude.to_degrees()));
        bounds.insert(format!("{prefix}trans_{axis}"), json!(t.bounded_by.name()));
        bounds.insert(format!("{prefix}rot_{axis}"), json!(r.bounded_by.name()));
    }
}

fn describe(margin: &Margin, scale: f64, unit: &str) -> String {
    let at_least =
        if margin.bounded_by == vservo_control::analysis::Bound::SearchLimit { "≥ " } else { "" };
    format!("{at_least}{:.1} {unit} ({})", margin.magnitude * scale, margin.bounded_by.name())
}

fn table(title: &str, m: &StabilityMargins) -> String {
    let mut out = format!("{title}\n");
    for (i, axis) in AXES.iter().enumerate() {
        out += &format!(
            "  along {axis}: {:<36} about {axis}: {}\n",
            describe(&m.translation[i], 1000.0, "mm"),
            describe(&m.rotation[i], 180.0 / std::f64::consts::PI, "deg")
        );
    }
    out
}

/// Runs the command.
pub fn run(args: &StabilityArgs) -> Result<()> {
    let config = args.config.load()?;
    let gains = design_gains(&config)?;
    let delay = config.cell.timing.pipeline_delay_frames;
    let delay_aware = design_delay_aware(&config, &gains)?;
    let loop_with = |feature_gain, past: &[nalgebra::Matrix6<f64>], delay_frames| {
        LoopUnderTest {
            camera: &config.cell.camera,
            board: &config.cell.board,
            camera_from_board_desired: &config.cell.desired.camera_from_board,
            period_s: config.cell.timing.vision_period_s,
            feature_gain,
            past_input_gains: past,
            delay_frames,
        }
        .stability_margins()
    };
    let undelayed = loop_with(&gains.paper.k, &[], 0);
    let delayed = loop_with(&gains.paper.k, &[], delay);
    let aware = loop_with(&delay_aware.feature_gain, &delay_aware.past_input_gains, delay);

    if args.json {
        let mut map = Map::new();
        let mut bounds = Map::new();
        insert(&mut map, &mut bounds, "", &undelayed);
        insert(&mut map, &mut bounds, "delayed_", &delayed);
        insert(&mut map, &mut bounds, "delay_aware_", &aware);
        map.insert("config".into(), json!(config.origin));
        map.insert("delay_frames".into(), json!(delay));
        map.insert("bounded_by".into(), Value::Object(bounds));
        print_stdout(&format!("{}\n", Value::Object(map)))?;
        return Ok(());
    }
    let mut out = format!(
        "{}: Corollary 1 — largest object displacement from the desired pose, either way, for which the\n\
         fixed gain's loop stays stable (translations along, rotations about the camera axes through its centre)\n",
        config.origin
    );
    out += &table("paper's gain, no delay (the paper's test):", &undelayed);
    out += &table(&format!("paper's gain, with the {delay}-frame pipeline delay:"), &delayed);
    out += &table(&format!("delay-aware gain, with the {delay}-frame pipeline delay:"), &aware);
    out += "the paper claims stability for translations < 3000 mm and rotations < 60 deg (no delay)\n";
    print_stdout(&out)?;
    Ok(())
}
