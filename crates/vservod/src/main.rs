//! # vservod — the vservo daemon
//!
//! Owns the process side of the real-time shell: loads and validates the configuration, starts the four
//! nodes (plant, rmrc, servo, vision) as child processes of its own executable (`vservod node <role>`),
//! supervises them (restart with backoff, dead-node cleanup, the arm held while the plant or rmrc is
//! down), speaks systemd's notify protocol (READY, STATUS, WATCHDOG, STOPPING) and on SIGTERM/SIGINT ramps
//! the arm to rest before it stops the nodes. Logs go to stderr through `tracing` (journald-friendly).

mod commands;
mod faults;
mod helpers;
mod log_limit;
mod node_process;
mod safety;
mod stop_path;
mod supervisor;
mod systemd;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

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

/// SIGTERM and SIGINT set the first flag; SIGHUP sets the second (a reload request).
///
/// The signals are blocked in every thread and taken synchronously by one thread (sigwait), so no signal
/// handler is involved: iceoryx2 installs its own handlers when it first needs them (zeroing new shared
/// memory, for one), which would silently replace ours. Call this before any other thread starts: threads
/// inherit the mask.
/// What the signals ask of this process.
struct Flags {
    /// SIGTERM or SIGINT: stop.
    stop: Arc<AtomicBool>,
    /// SIGHUP: reload the configuration (the daemon).
    reload: Arc<AtomicBool>,
    /// SIGUSR1, the nodes' parent-death signal: the daemon is gone, bring the arm to rest and exit.
    orphaned: Arc<AtomicBool>,
}

fn signal_flags() -> anyhow::Result<Flags> {
    use nix::sys::signal::{SigSet, Signal};
    let flags = Flags {
        stop: Arc::new(AtomicBool::new(false)),
        reload: Arc::new(AtomicBool::new(false)),
        orphaned: Arc::new(AtomicBool::new(false)),
    };
    let mut signals = SigSet::empty();
    for signal in [Signal::SIGTERM, Signal::SIGINT, Signal::SIGHUP, Signal::SIGUSR1] {
        signals.add(signal);
    }
    signals.thread_block().context("blocking SIGTERM, SIGINT, SIGHUP and SIGUSR1")?;
    let (stop, reload, orphaned) = (flags.stop.clone(), flags.reload.clone(), flags.orphaned.clone());
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            while let Ok(signal) = signals.wait() {
                match signal {
                    Signal::SIGHUP => reload.store(true, Ordering::Relaxed),
                    Signal::SIGUSR1 => orphaned.store(true, Ordering::Relaxed),
                    _ => stop.store(true, Ordering::Relaxed),
                }
            }
        })
        .context("starting the signal thread")?;
    Ok(flags)
}

fn main() -> ExitCode {
    // first, before the run's seal key exists: no other process of this user reads this one's memory, and
    // no core dump holds it (docs/PROTOCOL.md, "Seals"); the nodes, exec'd anew, do the same
    let private = vservo_protocol::seal::keep_memory_private();
    init_logging();
    let cli = Cli::parse();
    let result = private
        .context("making the process's memory private (prctl PR_SET_DUMPABLE, RLIMIT_CORE)")
        .and_then(|()| signal_flags());
    let result = result.and_then(|flags| match &cli.command {
        Some(Command::Node(args)) => node_process::run(&cli.config, args, flags.stop, flags.orphaned),
        None => supervisor::run(&cli.config, cli.status_every_s, flags.stop, flags.reload),
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            tracing::error!("{error:#}");
            // a port refused because its slots are held: the daemon names the stream taken
            let slot_taken = error.chain().any(|cause| {
                cause.downcast_ref::<vservo_protocol::ProtocolError>().is_some_and(|e| e.is_slot_taken())
                    || cause.downcast_ref::<vservo_runtime::RuntimeError>().is_some_and(
                        |e| matches!(e, vservo_runtime::RuntimeError::Protocol(p) if p.is_slot_taken()),
                    )
            });
            if slot_taken { ExitCode::from(supervisor::streams::SLOT_TAKEN_EXIT) } else { ExitCode::FAILURE }
        }
    }
}
