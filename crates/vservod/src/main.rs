//! # vservod — the vservo daemon
//!
//! Owns the process side of the real-time shell: loads and validates the configuration, starts the four
//! nodes (plant, rmrc, servo, vision) as child processes of its own executable (`vservod node <role>`),
//! supervises them (restart with backoff, dead-node cleanup, the arm held while the plant or rmrc is
//! down), speaks systemd's notify protocol (READY, STATUS, WATCHDOG, STOPPING) and on SIGTERM/SIGINT ramps
//! the arm to rest before it stops the nodes. Logs go to stderr through `tracing` (journald-friendly).

mod node_process;
mod supervisor;
mod systemd;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "vservod",
    version,
    about = "The vservo visual-servo daemon: runs the cell's four nodes over iceoryx2"
)]
struct Cli {
    /// The configuration file.
    #[arg(long, short, default_value = "config/vservo.toml", global = true)]
    config: PathBuf,
    /// Seconds between the one-line status reports on stderr (0: none).
    #[arg(long, default_value_t = 1.0)]
    status_every_s: f64,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Run one node in the foreground (the daemon starts these itself).
    #[command(hide = true)]
    Node(node_process::NodeArgs),
}

fn init_logging() {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_env("VSERVO_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let stderr_is_terminal = std::io::stderr().is_terminal();
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(stderr_is_terminal);
    // journald stamps each line itself
    if std::env::var_os("JOURNAL_STREAM").is_some() {
        builder.without_time().init();
    } else {
        builder.init();
    }
}

/// SIGTERM and SIGINT set the returned flag; SIGHUP sets the second (reload request).
fn stop_and_reload_flags() -> anyhow::Result<(Arc<AtomicBool>, Arc<AtomicBool>)> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let stop = Arc::new(AtomicBool::new(false));
    let reload = Arc::new(AtomicBool::new(false));
    for signal in [SIGTERM, SIGINT] {
        signal_hook::flag::register(signal, stop.clone()).context("installing the SIGTERM/SIGINT handler")?;
    }
    signal_hook::flag::register(SIGHUP, reload.clone()).context("installing the SIGHUP handler")?;
    Ok((stop, reload))
}

fn main() -> ExitCode {
    init_logging();
    let cli = Cli::parse();
    let result = match &cli.command {
        Some(Command::Node(args)) => node_process::run(&cli.config, args),
        None => supervisor::run(&cli.config, cli.status_every_s),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            tracing::error!("{error:#}");
            ExitCode::FAILURE
        }
    }
}
