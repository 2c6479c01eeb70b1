//! `vservoctl target`, `object`, `reload`, `safe-stop`, `resume`, `move-joints` and `servo`: commands to a
//! running instance, each answered by the daemon with whether it was accepted and why not.

use clap::{Args, Subcommand};
use vservo_client::{Client, Reply};

use crate::UsageError;
use crate::instance::InstanceArg;
use crate::output::print_stdout;

/// The daemon refused the command: printed with its reason, exit code 3.
#[derive(Debug, thiserror::Error)]
#[error("refused: {0}")]
pub struct Refused(pub String);

/// What `vservoctl target` sets.
#[derive(Subcommand, Debug)]
pub enum TargetCommand {
    /// ξ_d directly: eight features x1,y1,…,x4,y4 (px).
    Set {
        /// x1,y1,x2,y2,x3,y3,x4,y4 (px).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, required = true)]
        features: Vec<f64>,
    },
    /// A desired camera pose relative to the board: where the board is in the camera frame.
    Pose {
        /// The board's position in the desired camera frame x,y,z (m), e.g. 0,0,0.5.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, required = true)]
        translation_m: Vec<f64>,
        /// Its orientation, roll,pitch,yaw (degrees; R = Rz·Ry·Rx).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0,0,0")]
        rpy_deg: Vec<f64>,
    },
    /// The features the camera sees now become the target.
    Teach,
}

/// Arguments of `vservoctl target`.
#[derive(Args, Debug)]
pub struct TargetArgs {
    #[command(subcommand)]
    what: TargetCommand,
    #[command(flatten)]
    instance: InstanceArg,
}

/// What `vservoctl object` does with the simulated board.
#[derive(Subcommand, Debug)]
pub enum ObjectCommand {
    /// Stop where it is.
    Hold,
    /// Jump now by x,y,z (m) in the desired camera frame.
    Step {
        /// x,y,z (m).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, required = true)]
        by_m: Vec<f64>,
    },
    /// Circle in the desired camera frame's y–z plane, starting where it is.
    Circle {
        /// Radius (m).
        #[arg(long)]
        radius_m: f64,
        /// Speed (revolutions per minute).
        #[arg(long)]
        rev_per_min: f64,
    },
}

/// Arguments of `vservoctl object`.
#[derive(Args, Debug)]
pub struct ObjectArgs {
    #[command(subcommand)]
    what: ObjectCommand,
    #[command(flatten)]
    instance: InstanceArg,
}

/// Arguments of `vservoctl reload`, `safe-stop` and `resume`: the instance only.
#[derive(Args, Debug)]
pub struct ReloadArgs {
    #[command(flatten)]
    instance: InstanceArg,
}

/// Arguments of `vservoctl move-joints`.
#[derive(Args, Debug)]
pub struct MoveJointsArgs {
    /// The goal: one angle per joint of the arm, q1,…,qn (rad).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, required = true)]
    q: Vec<f64>,
    /// The share of each joint's speed limit the move may use, (0, 1].
    #[arg(long, default_value_t = 0.2)]
    speed_fraction: f64,
    /// Leave a cell held by the user (`start_held`, `requested`) into this move: the move is the arm's first
    /// motion (without it a held cell refuses the move).
    #[arg(long)]
    out_of_hold: bool,
    #[command(flatten)]
    instance: InstanceArg,
}

fn exactly<const N: usize>(option: &str, values: &[f64]) -> Result<[f64; N], UsageError> {
    <[f64; N]>::try_from(values).map_err(|_| {
        UsageError(format!("{option}: expected {N} comma-separated numbers, got {}", values.len()))
    })
}

fn report(reply: Reply) -> anyhow::Result<()> {
    if !reply.accepted {
        return Err(Refused(reply.reason).into());
    }
    let target: Vec<String> = reply.target_features_px.iter().map(|v| format!("{v:.2}")).collect();
    print_stdout(&format!(
        "accepted: {}\n  gains version {}, target ξ_d [{}] px\n",
        reply.reason,
        reply.gains_version,
        target.join(", ")
    ))?;
    Ok(())
}

pub fn target(args: &TargetArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    let reply = match &args.what {
        TargetCommand::Set { features } => {
            client.set_target_features(exactly::<8>("--features", features)?)?
        }
        TargetCommand::Pose { translation_m, rpy_deg } => {
            let rpy = exactly::<3>("--rpy-deg", rpy_deg)?.map(f64::to_radians);
            client.set_target_pose(exactly::<3>("--translation-m", translation_m)?, rpy)?
        }
        TargetCommand::Teach => client.teach()?,
    };
    report(reply)
}

pub fn object(args: &ObjectArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    let reply = match &args.what {
        ObjectCommand::Hold => client.object_hold()?,
        ObjectCommand::Step { by_m } => client.object_step(exactly::<3>("--by-m", by_m)?)?,
        ObjectCommand::Circle { radius_m, rev_per_min } => client.object_circle(*radius_m, *rev_per_min)?,
    };
    report(reply)
}

pub fn reload(args: &ReloadArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    report(client.reload()?)
}

/// How long `safe-stop` waits for the status to show the safe stop.
const SAFE_STOP_CONFIRM: std::time::Duration = std::time::Duration::from_secs(2);

/// `vservoctl safe-stop`: asks on the instance's safe-stop path (no command slot needed), then confirms
/// from the status. A cell already held is refused as before (exit code 3), naming its fault.
pub fn safe_stop(args: &ReloadArgs) -> anyhow::Result<()> {
    let stopped = vservo_client::safe_stop(&args.instance.name()?, SAFE_STOP_CONFIRM)?;
    if stopped.held_before {
        return Err(Refused(format!("the cell is already in a safe stop ({})", stopped.fault.name())).into());
    }
    print_stdout(&format!(
        "safe stop: the cell is in a safe stop (fault {}), confirmed by the status {:.0} ms after the request on {}\n",
        stopped.fault.name(),
        stopped.confirmed_after.as_secs_f64() * 1e3,
        stopped.path.display()
    ))?;
    Ok(())
}

pub fn resume(args: &ReloadArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    report(client.resume()?)
}

/// `vservoctl move-joints`: the arm moves its joints to the goal and holds them there until `servo`.
pub fn move_joints(args: &MoveJointsArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    report(if args.out_of_hold {
        client.move_joints_out_of_hold(&args.q, args.speed_fraction)?
    } else {
        client.move_joints(&args.q, args.speed_fraction)?
    })
}

/// Arguments of `vservoctl speed`.
#[derive(Args, Debug)]
pub struct SpeedArgs {
    /// The share of the arm's speed, acceleration and jerk limits (and of the tool's caps) the reference
    /// keeps, (0, 1].
    scale: f64,
    /// Raise it while the cell moves (without it a raise is taken only while the cell is held).
    #[arg(long)]
    while_moving: bool,
    #[command(flatten)]
    instance: InstanceArg,
}

/// `vservoctl speed`: the dynamics override.
pub fn speed(args: &SpeedArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    report(client.set_speed_scale(args.scale, args.while_moving)?)
}

/// `vservoctl servo`: ends a joint move.
pub fn servo(args: &ReloadArgs) -> anyhow::Result<()> {
    let mut client = Client::connect(&args.instance.name()?)?;
    report(client.servo()?)
}
