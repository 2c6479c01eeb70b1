//! `vservod node <role>`: one node in the foreground, as the supervisor starts it.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, bail};
use vservo_arm::JointVector;
use vservo_protocol::NodeRole;
use vservo_runtime::{NodeContext, nodes};

/// Arguments of `vservod node`.
#[derive(clap::Args)]
pub struct NodeArgs {
    /// plant, rmrc, servo or vision.
    role: String,
    /// plant: start at rest at these six joint angles (rad) instead of the scenario's start.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    resume_q: Option<Vec<f64>>,
    /// vision: track the marks from these eight features (px) instead of matching the layout.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    resume_features: Option<Vec<f64>>,
    /// plant: the tick to start counting from.
    #[arg(long, default_value_t = 0)]
    resume_tick: u64,
}

pub fn run(config_path: &Path, args: &NodeArgs, stop: Arc<AtomicBool>) -> anyhow::Result<()> {
    let Some(role) = NodeRole::from_name(&args.role) else {
        bail!("unknown node role {:?}: expected plant, rmrc, servo or vision", args.role);
    };
    // stop with the daemon, whichever way it ends
    nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGTERM).context("prctl(PR_SET_PDEATHSIG)")?;
    let config = vservo_config::Config::load(config_path)?;
    let cell = vservo_cell::Cell::new(&config).with_context(|| format!("{}", config_path.display()))?;
    let resume = match &args.resume_q {
        Some(q) if q.len() == 6 && q.iter().all(|v| v.is_finite()) => {
            Some((JointVector::from_column_slice(q), args.resume_tick))
        }
        Some(q) => bail!("--resume-q {q:?}: expected six finite joint angles"),
        None => None,
    };
    let resume_features = match &args.resume_features {
        Some(xi) if xi.len() == 8 && xi.iter().all(|v| v.is_finite()) => {
            Some(vservo_scene::FeatureVector::from_column_slice(xi))
        }
        Some(xi) => bail!("--resume-features {xi:?}: expected eight finite features (px)"),
        None => None,
    };
    let context = NodeContext { cell, instance: config.instance.clone(), stop, resume, resume_features };
    match role {
        NodeRole::Plant => nodes::plant::run(&context)?,
        NodeRole::Rmrc => nodes::rmrc::run(&context)?,
        NodeRole::Servo => nodes::servo::run(&context)?,
        NodeRole::Vision => nodes::vision::run(&context)?,
    }
    Ok(())
}
