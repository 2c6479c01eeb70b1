//! `vservoctl gains`: what the configured Q and R give — B's singular values, K, and the closed-loop
//! eigenvalues with and without the image pipeline's delay, for the paper's law and the delay-aware one.

use anyhow::Result;
use clap::Args;
use serde_json::json;
use vservo_control::analysis::{loop_eigenvalues, magnitudes, nominal_eigenvalues};

use crate::config_arg::{ConfigArg, design_delay_aware, design_gains};
use crate::output::{matrix_json, matrix_text, print_stdout, vector_json};

/// Arguments of `vservoctl gains`.
#[derive(Args)]
pub struct GainsArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn list(values: &[f64]) -> String {
    values.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>().join(" ")
}

/// Runs the command.
pub fn run(args: &GainsArgs) -> Result<()> {
    let config = args.config.load()?;
    let gains = design_gains(&config)?;
    let delay = config.cell.timing.pipeline_delay_frames;
    let delay_aware = design_delay_aware(&config, &gains)?;
    let k = gains.paper.k;
    let eig_abs = magnitudes(&nominal_eigenvalues(&gains.b, &k));
    let eig_abs_delayed = magnitudes(&loop_eigenvalues(&gains.b, &k, &[], delay));
    let eig_abs_delay_aware = magnitudes(&loop_eigenvalues(
        &gains.b,
        &delay_aware.feature_gain,
        &delay_aware.past_input_gains,
        delay,
    ));
    let sigma: Vec<f64> = gains.decomposition.singular_values.iter().copied().collect();

    if args.json {
        let past: Vec<_> = delay_aware.past_input_gains.iter().map(matrix_json).collect();
        let out = json!({
            "config": config.origin,
            "law": config.cell.controller.law.name(),
            "delay_frames": delay,
            "period_s": config.cell.timing.vision_period_s,
            "r_units": config.cell.controller.r.units().name(),
            "K": matrix_json(&k),
            "singular_values": sigma,
            "eig_abs": eig_abs,
            "eig_abs_delayed": eig_abs_delayed,
            "delay_aware": {
                "K": matrix_json(&delay_aware.feature_gain),
                "K_past": past,
                "eig_abs_delayed": eig_abs_delay_aware,
            },
            "desired_features_px": vector_json(&gains.desired_features),
        });
        print_stdout(&format!("{out}\n"))?;
        return Ok(());
    }
    let mut out = format!(
        "{}: law {}, vision period {} s, pipeline delay {} frame(s), R written in {}\n",
        config.origin,
        config.cell.controller.law.name(),
        config.cell.timing.vision_period_s,
        delay,
        config.cell.controller.r.units().name()
    );
    out += &format!("singular values of B = T·J⁺(ξ_d, Z_d) (px per m/s | rad/s): {}\n", list(&sigma));
    out += &matrix_text("K, the paper's gain (rows vx vy vz in m/s per px, wx wy wz in rad/s per px)", &k);
    out += &format!("|λ| of I − BK, no delay (2N − 6 = 2 unit ones):   {}\n", list(&eig_abs));
    out += &format!("|λ| of the paper's loop with the {delay}-frame delay: {}\n", list(&eig_abs_delayed));
    out += &format!("|λ| of the delay-aware loop with the delay:      {}\n", list(&eig_abs_delay_aware));
    for (j, k_j) in delay_aware.past_input_gains.iter().enumerate() {
        let title = format!("delay-aware K_{} on the command sent {} frame(s) ago", j + 1, j + 1);
        out += &matrix_text(&title, k_j);
    }
    print_stdout(&out)?;
    Ok(())
}
