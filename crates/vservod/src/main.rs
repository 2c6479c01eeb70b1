//! # vservod — the vservo daemon
//!
//! Owns the process side of the real-time shell: loads and validates the configuration, starts the four
//! nodes (plant, rmrc, servo, vision) as child processes of its own executable (`vservod node <role>`; no
//! plant unless `robot.driver = "simulated"`), supervises them (restart with backoff, dead-node cleanup, the
//! arm held while the plant or rmrc is down), serves commands, speaks systemd's notify protocol (READY,
//! STATUS, WATCHDOG, STOPPING) and on SIGTERM/SIGINT ramps the arm to rest before it stops the nodes in order.
//! When the daemon dies the nodes hear it (parent-death signal SIGUSR1) and bring the arm to rest in order.
//! Logs go to stderr through `tracing` (journald-friendly).
//!
//! Each decision is a pure module with unit tests (no processes, no iceoryx2, time passed in); the I/O
//! around them is thin:
//! - [`supervisor`] (`run`: a loop of named steps over a `Daemon`): `launch` starts a node (the configuration in
//!   force and the run's seal key on its stdin; a restarted plant resumes at rest where the arm stopped, vision
//!   tracks from the last features); `observe` drains what the loop published (every joint state, twist and
//!   feature vector to the fault monitor, each telemetry to its node); `restart` is the restart policy (backoff
//!   doubling up to `runtime.restart_backoff_max_s`, reset after 10 s stable); `node` a node's health (its own
//!   telemetry fresher than 0.5 s) and hang (no telemetry, or a plant that stops ticking, for
//!   `runtime.hang_timeout_s`, 5 s grace before the first: killed and restarted); `health` the robot driver's
//!   state (waiting, running, stalled after `state_timeout_periods`: ERROR on the stall — for an external driver
//!   a safe stop, `robot_stalled` —, WARN when it is back), the camera (`CameraWatch`: no frame for
//!   `faults.camera_timeout_periods` while the vision node runs is `camera_stalled`), the daemon's state, the
//!   resume conditions, readiness and the watchdog (kept alive while the rmrc and the simulated plant — the nodes
//!   that bring the arm to rest — are healthy); `status` the status message and tick rate; `cleanup` when dead
//!   nodes' and clients' shared memory is freed (at once after a loss, every 2 s); `shutdown` the stop order
//!   (servo and vision, the arm at rest under the rmrc, then rmrc and plant); `streams` who holds each stream's
//!   writer slot (four times a second: a live process that is not the stream's writer is the fault
//!   `stream_taken`, named with its pid; a node that exits 76 because its slot was held is the same fault; an
//!   external driver's or camera's writer is named when it changes).
//! - [`faults`] decides when the cell must go to a safe stop and whether it may resume: each condition written
//!   once (`CONDITIONS`, judged on `Evidence`: what was seen since the last cycle to find a fault, how things
//!   stand now to name what keeps a resume back).
//! - [`safety`] turns those decisions into sealed `cell_mode` messages (and a client's joint move into
//!   `cell_mode` moving, which a safe stop holds and a resume takes on; a joint move also ends a `target_lost`
//!   stop that only the lost marks keep), one ERROR line per safe stop and one WARN per resume, and the fault in
//!   the status. It publishes the mode in force again at least every 100 ms with the nodes' processes
//!   (`writers`): the nodes' heartbeat (none for 1 s: they hold the arm) and the writers whose sealed streams they
//!   take; a daemon that published nothing that long (it was stopped) latches `supervision_stalled`.
//! - [`commands`] answers the `command` service with typed outcomes (`Accepted`, `CommandRefused`; the reply
//!   text made once): `reload` diffs validated `Config` values (comments and key order are no change; a
//!   changed key outside `[controller]`/`[desired]` is a `ReloadRefused::RestartOnly` naming it, but the
//!   camera's lens and mount, applied while the cell is held by restarting the vision, servo and rmrc nodes,
//!   `reload::NODE_RESTART_KEYS`); targets are
//!   placed by `vservo_cell::target` (from the joints and the features, board-plane homography, never the
//!   simulation); `object` checks object commands against named limits (refused with an external robot);
//!   `joint_move` checks a `move_joints` goal (the arm's joint count, finite, `vservo_arm::GOAL_MARGIN_RAD`
//!   inside each joint's limits, the share of the speed limits in [0.01, 1]; refused while the robot driver is
//!   not running).
//! - [`helpers`] starts the helper processes installed next to vservod and restarts them 5 s after they end:
//!   `vservoctl view` (`[viewer] enabled`), `vservo-ros2` (`[ros2] enabled`), `vservo-ros2-driver`
//!   (`[robot] driver` or `[camera] source` = `"ros2"`) and `vservo-franka` (`[robot] driver = "franka"`).
//!   They end with the daemon (parent-death signal); the drivers are stopped last, after the arm's ramp to
//!   rest. A driver of `driver = "external"` or `source = "external"` (the user's, the Python reference
//!   drivers, `vservo-gst-camera`) is never started by vservod.
//! - [`stop_path`] judges the safe-stop FIFO's bursts, and `supervisor/stop_path_watch` reads the FIFO every
//!   cycle (any byte a safe stop, `requested`, logged once per burst; the path replaced by something else a safe
//!   stop too, and the FIFO made again); [`log_limit`] logs commands one line each up to 10 a second and a summary for floods;
//!   [`systemd`] speaks sd_notify; [`node_process`] is `vservod node <role>`.
//!
//! Commands go client → `command` (request-response) → vservod, which validates them, designs gains
//! (`vservo_cell::gains::design`, the one design: the start check, every node's `Cell`, and each version the
//! commander publishes through `vservo_runtime::gains::gains_message`) and hands them on: `gains` → servo
//! (swapped in before the next frame, history kept; the servo runs the version the message names), `object`
//! → plant (simulated robot only). Wire codes are the protocol's enums inside the daemon, converted where a
//! message is built or taken in.
//!
//! ## Safe stop
//!
//! The supervisor feeds every joint state, twist and feature vector it drains to the fault monitor
//! (`faults::FaultMonitor`); on a fault `safety::Safety` publishes a sealed `cell_mode` "safe stop": the servo
//! answers each frame with a zero twist (verdict held, the law remembering the zero) and the rmrc sets a zero
//! twist every tick, which the interpolator ramps to at its acceleration limits and holds. A resume (a
//! command, or `[faults] resume = "automatic"`) is granted only when no cause is left, and publishes
//! "servoing" with the next sequence.

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
