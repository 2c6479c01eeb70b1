//! `vservod node <role>`: one node in the foreground, as the supervisor starts it.

use std::io::Read;
use std::os::fd::AsFd;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, bail};
use vservo_protocol::NodeRole;
use vservo_protocol::seal::SealKey;
use vservo_runtime::{NodeContext, nodes};

/// Arguments of `vservod node`.
#[derive(clap::Args)]
pub struct NodeArgs {
    /// plant, rmrc, servo or vision.
    role: String,
    /// plant: start at rest at these joint angles (rad, one per joint of the arm) instead of the scenario's start.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    resume_q: Option<Vec<f64>>,
    /// vision: track the marks from these eight features (px) instead of matching the layout.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    resume_features: Option<Vec<f64>>,
    /// plant: the tick to start counting from.
    #[arg(long, default_value_t = 0)]
    resume_tick: u64,
    /// Read the configuration from stdin (the daemon hands over the one in force) instead of the file;
    /// `--config` then only names it in messages.
    #[arg(long)]
    config_stdin: bool,
}

/// The environment variable that tells a node its daemon's pid.
pub const DAEMON_PID_ENV: &str = "VSERVO_DAEMON_PID";

pub fn run(
    config_path: &Path,
    args: &NodeArgs,
    stop: Arc<AtomicBool>,
    orphaned: Arc<AtomicBool>,
) -> anyhow::Result<()> {
    let Some(role) = NodeRole::from_name(&args.role) else {
        bail!("unknown node role {:?}: expected plant, rmrc, servo or vision", args.role);
    };
    // however the daemon ends (SIGKILL, a panic, systemd's watchdog), the nodes hear it (SIGUSR1) and bring
    // the arm to rest in order: servo and vision stop (a zero twist), the rmrc ramps the reference to rest,
    // the plant holds the arm and goes last
    nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGUSR1).context("prctl(PR_SET_PDEATHSIG)")?;
    let daemon_pid = std::env::var(DAEMON_PID_ENV).ok().and_then(|v| v.parse::<i32>().ok());
    if daemon_pid.is_some_and(|pid| nix::unistd::getppid().as_raw() != pid) {
        // the daemon died before the signal was armed
        orphaned.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    let (config, seal_key) = if args.config_stdin {
        let (seal_key, toml) = read_handover().context("reading the key and the configuration from stdin")?;
        (vservo_config::Config::from_toml(&toml, &config_path.display().to_string())?, seal_key)
    } else {
        (vservo_config::Config::load(config_path)?, None)
    };
    let cell = vservo_cell::Cell::new(&config.cell).with_context(|| format!("{}", config_path.display()))?;
    let joint_count = config.cell.arm.joint_count();
    let resume = match &args.resume_q {
        Some(q) if q.len() == joint_count && q.iter().all(|v| v.is_finite()) => {
            Some((vservo_arm::joint_vector(q).context("--resume-q")?, args.resume_tick))
        }
        Some(q) => {
            bail!("--resume-q {q:?}: expected {joint_count} finite joint angles (the configured arm's)")
        }
        None => None,
    };
    let resume_features = match &args.resume_features {
        Some(xi) if xi.len() == 8 && xi.iter().all(|v| v.is_finite()) => {
            Some(vservo_scene::FeatureVector::from_column_slice(xi))
        }
        Some(xi) => bail!("--resume-features {xi:?}: expected eight finite features (px)"),
        None => None,
    };
    let context = NodeContext {
        cell,
        instance: config.instance.clone(),
        runtime: config.runtime.clone(),
        stop,
        orphaned,
        seal_key,
        resume,
        resume_features,
    };
    match role {
        NodeRole::Plant => nodes::plant::run(&context)?,
        NodeRole::Rmrc => nodes::rmrc::run(&context)?,
        NodeRole::Servo => nodes::servo::run(&context)?,
        NodeRole::Vision => nodes::vision::run(&context)?,
    }
    Ok(())
}

/// What the daemon hands a node on its stdin: the run's key on a first line of its own (if the first line
/// is one: `vservo_protocol::seal::read_key_line`, which leaves no copy of the key's text in the node's memory,
/// docs/PROTOCOL.md "Seals"), then the configuration's text.
fn read_handover() -> std::io::Result<(Option<SealKey>, String)> {
    let mut stdin = std::fs::File::from(std::io::stdin().as_fd().try_clone_to_owned()?);
    let (key, mut text) = vservo_protocol::seal::read_key_line(&mut stdin)?;
    // the daemon hands over a configuration it read within the files' bound; more is not its
    let bound = vservo_config::MAX_CONFIG_FILE_BYTES;
    if (&mut stdin).take(bound + 1).read_to_end(&mut text)? as u64 > bound {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("the configuration on stdin is over {bound} bytes"),
        ));
    }
    let text =
        String::from_utf8(text).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))?;
    Ok((key, text))
}
