//! # vservo-franka — a Franka arm as vservo's robot driver
//!
//! With `[robot] driver = "franka"` vservod starts this process (and restarts it if it ends; it ends with the
//! daemon). It speaks the Franka's own network protocol, the FCI (server protocol version 10: the FR3, through the
//! `vservo-franka` client), and is the instance's robot driver behind docs/DRIVERS.md's contract (the rules in
//! `vservo-driver`):
//! - it runs one joint-velocity motion under the robot's joint impedance controller; each robot state (1 kHz) is
//!   published as a `joint_state` (`tick` is the robot's own millisecond counter, `message_id`, since the first)
//!   and answered, within the robot's cycle, with the rmrc's answer to it — or, if that has not come within
//!   `[franka] answer_within_s`, with the command in force;
//! - the velocities sent pass the driver's last guard ([`shaper`], `[franka] limit_rate`): each joint's change of
//!   velocity per period within the arm's acceleration limit, and the change of that within its jerk limit,
//!   whatever the rmrc's timing; no command for `[franka] hold_after_s` brings the arm to rest within them;
//! - a robot error (a reflex) is a driver fault, logged with the Franka's own error names (the cell's safe stop
//!   `driver_fault`); once the cell is held, `vservoctl resume` runs the robot's automatic error recovery and a
//!   new motion;
//! - a robot that goes away (its connection closed: the robot or its server stopped) is a driver fault,
//!   `robot_connection_lost`, reported while the driver connects again every second (a resume is refused with
//!   it); once connected, `vservoctl resume` starts a new motion;
//! - on SIGTERM or the daemon's death the arm is brought to rest within the limits and the motion finished
//!   cleanly (`motion_generation_finished`).
//!
//! Modules: [`run`] (the loop: one robot state in, one `joint_state` out, the rmrc's answer — or the command
//! in force — through the guard, one command back within the robot's cycle; the robot's recovery on a resume,
//! polled cycle by cycle), [`shaper`] (the guard), [`cell`] (the instance's side: the robot driver's streams and
//! the cell's mode), [`report`] (what it counts and logs: the JSON line scripts/run-franka-sim.sh reads). It
//! depends on `vservo-driver`, `vservo-franka`, `vservo-protocol`, `vservo-config`, `vservo-arm` (its limit margin)
//! and `vservo-time`, not on the runtime.
//!
//! Exit codes: 0 after the motion ended on SIGINT/SIGTERM, 1 on an error, 2 on a configuration it cannot run.

mod cell;
mod report;
mod run;
mod shaper;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

/// A Franka arm (FCI, protocol version 10) as vservo's robot driver.
#[derive(Parser, Debug)]
#[command(name = "vservo-franka", version)]
struct Cli {
    /// The instance's configuration: `[instance] name`, `[robot]` (driver = "franka"), `[robot.arm]`, `[franka]`.
    #[arg(long, value_name = "FILE", default_value = "config/vservo.toml")]
    config: PathBuf,
    /// Started by this vservod: end when it does, however it ends.
    #[arg(long, value_name = "PID", hide = true)]
    daemon_pid: Option<i32>,
    /// Read the run's seal key from stdin, as vservod hands it: without it no command is the rmrc's, and none is
    /// taken.
    #[arg(long, hide = true)]
    seal_key_stdin: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    vservo_driver::logging::to_stderr("info");
    let key = match vservo_driver::seal_key(cli.seal_key_stdin) {
        Ok(key) => key,
        Err(error) => {
            tracing::error!("{error:#}");
            return ExitCode::from(2);
        }
    };
    let config = match vservo_config::Config::load(&cli.config) {
        Ok(config) => config,
        Err(error) => {
            tracing::error!("{error}");
            return ExitCode::from(2);
        }
    };
    let Some(franka) = config.franka.clone() else {
        tracing::error!("{}: robot.driver is not \"franka\": there is no Franka to drive", config.origin);
        return ExitCode::from(2);
    };
    vservo_driver::logging::exit_code(vservo_protocol::signals::run_until_stopped(cli.daemon_pid, |stop| {
        run::run(&config, &franka, key.clone(), stop)
    }))
}
