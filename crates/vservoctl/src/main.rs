//! # vservoctl — the vservo command-line tool
//!
//! Owns the user-facing commands: on a configuration (the models, the gains, the lockstep simulator, the cell,
//! calibration) and on a running instance (found by `--instance` or `--config`, [`instance`]). Each subcommand
//! lives in its own module; output is text or JSON. Input errors are reported as [`UsageError`] and end with
//! exit code 2, a command the daemon refused with 3, a command with every slot taken with 75, other failures
//! with exit code 1.
//!
//! On a configuration:
//! - `model` ([`model`]): the arm model at one joint state; `gains` ([`gains`]): K, B's singular values,
//!   closed-loop eigenvalues with and without the delay; `stability` ([`stability`]): the Corollary 1 margins;
//! - `vision render`, `vision extract` ([`vision`]): the camera's view at a joint configuration, the features
//!   of any image;
//! - `sim` ([`sim`]): a scenario in the lockstep simulator (summary.json, CSVs, SVG figures by [`plots`]);
//!   `basin` ([`basin`]): a Monte Carlo of starting poses in classes on all cores with rayon (the share
//!   converged, settling times, why the others failed; JSON and an SVG);
//! - `scene` ([`scene`]): the cell a configuration describes, as JSON for drivers; `board` ([`board`]): a
//!   calibration board as an SVG to print at scale, and its layout as JSON; `tags` ([`tags`]): every tag in
//!   pictures, as the detector sees them;
//! - `calibrate` ([`calibrate`], docs/CALIBRATION.md): the command line of the `vservo_calibrate` crate (the
//!   poses planned on a half sphere around the board or given with `--poses`, their spread checked, the views
//!   taken in lockstep or through a running vservod, the OpenCV solver, the report, the calibration file, and
//!   with `--apply` the configuration edited to read it and the running instance reloaded); its crate doc has
//!   the steps.
//!
//! On a running instance:
//! - `status` ([`status`]), `top` ([`top`]: a live terminal view with ratatui), `echo` ([`echo`]: a topic as
//!   JSON lines);
//! - `target`, `object`, `reload`, `safe-stop`, `resume`, `move-joints`, `servo` and `speed` ([`commands`]);
//! - `check` ([`check`]): the preflight on a held cell, reading only: `check/observe` watches joint states,
//!   frames, status and gains for a while (a second by default), `check/ros_names` hears a ROS 2 arm's joint
//!   names over DDS (`vservo_ros2::probe`); pure judgements with unit tests: `check/verdicts` (held, period,
//!   joints), `check/view` (kinematics against the board seen, camera and marks, the desired pose's reach),
//!   `check/first_twist` (the law's twist through the cell's own rmrc stage); PASS or FAIL with the value
//!   measured;
//! - `record` ([`record`]): MCAP with zstd chunks, files created with mode 0600; with `--ros2` the ROS 2
//!   bridge's messages through `vservo_ros2::translate`, ROS 2's profile, `ros2msg` schemas and CDR
//!   ([`record_ros2`]); `plot` ([`plot_recording`]): the figures of `sim` from a recording, turned back into a
//!   lockstep `Trace`, and with `--frames N` a contact sheet of its camera images ([`contact_sheet`]);
//! - `snapshot` ([`snapshot`]): the newest camera image with its marks as a PNG; the drawing, shared with the
//!   contact sheet, in [`annotate`];
//! - `view` ([`view`]): the instance's streams served to Foxglove by the live view's crate (`vservo_view`: its
//!   server, a thread per viewer, a token in the URL or HTTP 401/403, at most `--max-clients` or 503, a bounded
//!   queue per viewer that drops its oldest data); `--url` prints the URL with the token. vservod starts it
//!   with `[viewer] enabled`.
//!
//! `echo`, `record` and `view` started before the daemon wait for the instance. [`bridge`] takes an
//! instance's services to a sink of channels (the MCAP file of `record`, the live server of `view`): every
//! service as JSON, and through `vservo_view::drawing` (pure conversions, unit-tested) the camera image
//! (`foxglove.RawImage`), the marks the servo used, ξ_d, the errors and the missing marks
//! (`foxglove.ImageAnnotations`, stamped with the image's capture time), and the arm's, camera's and board's
//! frames (`foxglove.FrameTransforms`; the arm is the one configured, link by link, read from the
//! configuration the daemon runs, which it writes to the instance's directory,
//! `vservo_protocol::InstanceDir::configuration`; none is drawn when that cannot be read).

mod annotate;
mod basin;
mod board;
mod bridge;
mod calibrate;
mod check;
mod commands;
mod config_arg;
mod contact_sheet;
mod echo;
mod gains;
mod instance;
mod joint_args;
mod model;
mod output;
mod plot_recording;
mod plots;
mod record;
mod record_ros2;
mod scene;
mod seconds_arg;
mod sim;
mod snapshot;
mod stability;
mod status;
mod tag;
mod tags;
mod teach;
mod top;
mod view;
mod vision;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Bad input from the user: printed as is, exit code 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

#[derive(Parser)]
#[command(name = "vservoctl", version, about = "Inspect and control vservo, the visual-servo controller")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Kinematics of the configured arm (default: the PUMA 560, with its dynamics and closed-form inverse
    /// kinematics) at one joint state.
    Model(model::ModelArgs),
    /// The LQ gain the configuration gives, and its closed-loop eigenvalues with and without the delay.
    Gains(gains::GainsArgs),
    /// The Corollary 1 stability margins of the configured gain.
    Stability(stability::StabilityArgs),
    /// The simulated camera and the feature extractor.
    Vision(vision::VisionArgs),
    /// Run a scenario in the lockstep simulator and write its summary, data and plots.
    Sim(sim::SimArgs),
    /// A Monte Carlo of starting poses in the lockstep simulator, on all cores: per class the share that
    /// converges to 1 px, the settling times and why the others did not.
    Basin(basin::BasinArgs),
    /// The state of a running instance: nodes, restarts, loop timing, feature error, gains version.
    Status(status::StatusArgs),
    /// Print a running instance's messages on one topic as JSON lines.
    Echo(echo::EchoArgs),
    /// Give a running instance a new target (features, a camera pose, or what it sees now).
    Target(commands::TargetArgs),
    /// Move a running instance's simulated board (hold, step, circle).
    Object(commands::ObjectArgs),
    /// Make a running instance reload its configuration file (as SIGHUP does).
    Reload(commands::ReloadArgs),
    /// Bring a running instance's arm to rest and hold it (a safe stop, ended by `resume`).
    SafeStop(commands::ReloadArgs),
    /// Servo again after a safe stop (refused, with each cause, while a fault's cause is still there).
    Resume(commands::ReloadArgs),
    /// Move a running instance's arm to joint angles at a share of the speed limits, and hold it there instead
    /// of servoing (refused in a safe stop, but for a `target_lost` one, which it ends, or outside the joint limits) until `servo`.
    MoveJoints(commands::MoveJointsArgs),
    /// End a joint move: servo again from where the arm is.
    Servo(commands::ReloadArgs),
    /// Set the dynamics override: the share of the arm's speed, acceleration and jerk limits the reference keeps
    /// (lowering is always taken; raising only while held, or with --while-moving).
    Speed(commands::SpeedArgs),
    /// A live terminal view of a running instance: nodes, loop timing, fault, servo, feature error (q quits).
    Top(top::TopArgs),
    /// Record every service of a running instance to an MCAP file.
    Record(record::RecordArgs),
    /// Serve a running instance live to Foxglove (WebSocket, token required): the camera image with the marks,
    /// the arm in 3D, every service; `--url` prints the URL with the token.
    View(view::ViewArgs),
    /// Draw the figures of `sim` from an MCAP recording.
    Plot(plot_recording::PlotArgs),
    /// The cell a configuration describes (arm, camera, board, start joints, periods) as JSON, for drivers.
    Scene(scene::SceneArgs),
    /// What the camera of a running instance sees now, as a PNG: the newest image with the marks found, where
    /// the servo wants them and the error between, and every tag in view outlined with its id; the frame's
    /// numbers as JSON.
    Snapshot(snapshot::SnapshotArgs),
    /// A calibration board (a grid of AprilTags) as an SVG to print at scale, and its layout as JSON.
    Board(board::BoardArgs),
    /// One AprilTag (tag36h11) as an SVG to print at scale for a tag target: the id, the size of its black
    /// square, a scale bar and which edge is up.
    Tag(tag::TagArgs),
    /// Every tag36h11 tag in pictures (PNG, JPEG or PGM, gray or colour, any size): id, corners, centre, how
    /// each corner was measured, the time; `--draw` writes the picture annotated.
    Tags(tags::TagsArgs),
    /// The preflight before a first motion, on a held cell (nothing moves): joint states at their period, the
    /// joints' count, names and limits, the kinematics against what the camera sees, the frames and the target,
    /// the desired pose's reach, and the first twist's motion against the limits; PASS or FAIL with the value
    /// each measured (exit code 1 when one fails).
    Check(check::CheckArgs),
    /// Calibrate the camera (intrinsics, lens) and where it sits on the hand (`tool_from_camera`) from
    /// views of the calibration board at poses around it.
    Calibrate(calibrate::CalibrateArgs),
    /// Teach the goal: with the arm still where the camera should be, the view now becomes `[desired]` (the
    /// joints, and the board's pose as seen) in the configuration file, which the running instance reloads;
    /// `--target-only` changes the running goal alone.
    Teach(teach::TeachArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Model(args) => model::run(&args),
        Command::Gains(args) => gains::run(&args),
        Command::Stability(args) => stability::run(&args),
        Command::Vision(args) => vision::run(&args),
        Command::Sim(args) => sim::run(&args),
        Command::Basin(args) => basin::run(&args),
        Command::Status(args) => status::run(&args),
        Command::Echo(args) => echo::run(&args),
        Command::Target(args) => commands::target(&args),
        Command::Object(args) => commands::object(&args),
        Command::Reload(args) => commands::reload(&args),
        Command::SafeStop(args) => commands::safe_stop(&args),
        Command::Resume(args) => commands::resume(&args),
        Command::MoveJoints(args) => commands::move_joints(&args),
        Command::Servo(args) => commands::servo(&args),
        Command::Speed(args) => commands::speed(&args),
        Command::Top(args) => top::run(&args),
        Command::Record(args) => record::run(&args),
        // the live view serves the instance to its viewers: its memory is private like the daemon's
        // (docs/PROTOCOL.md, "Seals")
        Command::View(args) => vservo_protocol::seal::keep_memory_private()
            .map_err(|e| anyhow::anyhow!("making the process's memory private: {e}"))
            .and_then(|()| view::run(&args)),
        Command::Plot(args) => plot_recording::run(&args),
        Command::Scene(args) => scene::run(&args),
        Command::Snapshot(args) => snapshot::run(&args),
        Command::Board(args) => board::run(&args),
        Command::Tag(args) => tag::run(&args),
        Command::Tags(args) => tags::run(&args),
        Command::Calibrate(args) => calibrate::run(&args),
        Command::Teach(args) => teach::run(&args),
        Command::Check(args) => check::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("vservoctl: {error:#}");
            let refused =
                error.downcast_ref::<vservo_calibrate::CalibrateError>().is_some_and(|e| e.is_refusal());
            if error.is::<UsageError>() || refused {
                ExitCode::from(2)
            } else if error.is::<commands::Refused>() {
                ExitCode::from(3)
            } else if matches!(error.downcast_ref(), Some(vservo_client::ClientError::Busy { .. })) {
                // EX_TEMPFAIL: try again
                ExitCode::from(75)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
