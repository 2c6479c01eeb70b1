//! `vservoctl calibrate`: the command line of the `vservo_calibrate` crate (docs/CALIBRATION.md; the crate's doc
//! has the steps): its arguments, the order of the steps, and the report printed.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use vservo_calibrate::{CalibrateError, apply, capture, dataset, file, live, plan, report, solver, spread};
use vservo_config::{CalibrationSettings, Config};

use crate::UsageError;
use crate::config_arg::ConfigArg;
use crate::output::print_stdout;

/// `vservoctl calibrate`.
#[derive(Args, Debug)]
pub struct CalibrateArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Calibrate the configured simulated cell in the lockstep simulator (no daemon): the arm is put at each
    /// pose and the simulated camera, as `[camera.truth]` says it is, takes the view; the result is compared
    /// with that truth. Without it the configuration's running instance is calibrated: its arm is moved.
    #[arg(long)]
    lockstep: bool,
    /// The share of each joint's speed limit the moves between views use, (0, 1] (the accelerations: its
    /// square).
    #[arg(long, default_value_t = 0.25)]
    speed_fraction: f64,
    /// Take these poses instead of planning them: a JSON list of joint vectors (rad), in the order taken;
    /// each is checked inside the limits and with the board in view, and the set for its spread.
    #[arg(long, value_name = "FILE")]
    poses: Option<PathBuf>,
    /// Plan the poses and check them (reach, board in view, spread) without moving or solving.
    #[arg(long)]
    dry_run: bool,
    /// Where the calibration file is written (default: `calibration.output_file`, else calibration.yaml
    /// beside the configuration file).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Replace one's own calibration file (a link or another user's file at its name is refused, one's own
    /// file too unless --force; checked before anything moves).
    #[arg(long)]
    force: bool,
    /// Where the views are kept for the solver (default: a directory `calibration-views` beside the
    /// calibration file).
    #[arg(long, value_name = "DIR")]
    views: Option<PathBuf>,
    /// The Python interpreter that runs the solver (with OpenCV, SciPy and NumPy) [default: the project's
    /// environment (target/python-venv, made by scripts/setup.sh) beside this vservoctl, else $VIRTUAL_ENV's,
    /// else python3].
    #[arg(long, value_name = "FILE")]
    python: Option<PathBuf>,
    /// The solver script (default: clients/python/vservo_calibrate.py of the source tree or the package).
    #[arg(long, value_name = "FILE")]
    solver: Option<PathBuf>,
    /// Make the configuration read the result: `--config`'s file gets `[camera] calibration_file` in place of
    /// its lens keys (the file as it was kept beside it, `<name>.before-calibration`; checked before anything
    /// moves, and validated before it is written), and the running instance takes it: held (a safe stop),
    /// reloaded (its camera's nodes restart), resumed.
    #[arg(long)]
    apply: bool,
    /// JSON: the report as one object, the last line.
    #[arg(long)]
    json: bool,
}

/// Runs `vservoctl calibrate`.
pub fn run(args: &CalibrateArgs) -> Result<()> {
    let config = args.config.load()?;
    let settings = settings_of(&config)?;
    let given = args.poses.as_deref().map(read_poses).transpose()?;
    let solver_path = solver::locate(args.solver.as_deref())?;
    let python = solver::python(args.python.as_deref());
    let out = output_file(args, &settings);
    if !args.dry_run {
        vservo_config::new_file::check(&out, args.force)?;
    }
    let edit =
        if args.apply && !args.dry_run { Some(apply::Edit::check(&args.config.config)?) } else { None };
    let views_dir = args.views.clone().unwrap_or_else(|| out.with_file_name("calibration-views"));
    if !args.dry_run {
        // before anything moves: the views go into a folder of the user's own, never through a planted link
        vservo_config::new_file::check_folder(&views_dir)?;
    }
    let (views, truth) = if args.lockstep {
        let cell = capture::Simulated::new(&config)?;
        let board = cell.base_from_board();
        let start = config.cell.desired.joints;
        let planned = plan_poses(&config, &settings, start, (config.cell.mount(), board), given.as_deref())?;
        if args.dry_run {
            return Ok(print_stdout(&report::plan(&config, &planned, args.json))?);
        }
        (cell.take_views(&planned), Some(simulated_truth_of(&config)))
    } else {
        let mut cell = live::Running::connect(&config, args.speed_fraction)?;
        let solver = SolverRun { python: &python, script: &solver_path, views_dir: &views_dir };
        if args.dry_run {
            // a dry run moves nothing: it waits for the arm to be at rest
            let settled_ns = cell.at_rest(LOCATE_REST_WAIT)?;
            let located = Located { start: cell.joints_now()?, settled_ns };
            let planned =
                locate_and_plan(&config, &settings, &mut cell, &located, &solver, given.as_deref())?;
            return Ok(print_stdout(&report::plan(&config, &planned, args.json))?);
        }
        let (start, settled_ns) = cell.hold_here().map_err(|e| cell.stop_here(e))?;
        let located = Located { start, settled_ns };
        let planned =
            match locate_and_plan(&config, &settings, &mut cell, &located, &solver, given.as_deref()) {
                Ok(planned) => planned,
                Err(e) => return Err(cell.give_back(e).into()),
            };
        let views = cell.take_views(&planned).map_err(|e| cell.stop_here(e))?;
        cell.finish(&located.start).map_err(|e| cell.stop_here(e))?;
        (views, simulated_truth(&config))
    };
    let measured: Vec<_> = views.iter().map(|v| v.base_from_tool).collect();
    spread::check(&solved_poses(&config, &measured))
        .map_err(|e| UsageError(format!("the views taken: {e}")))?;
    dataset::write(
        &views_dir,
        &views,
        &config.cell.camera,
        (config.cell.camera_in_mount().0, &config.cell.camera_in_mount().1),
        &settings.board,
        config.cell.arm.joint_count(),
    )?;
    let solved = solver::solve(&python, &solver_path, &views_dir)?;
    file::write(&out, args.force, &config, &solved)?;
    let applied = edit
        .map(|edit| -> Result<_> {
            let mut applied = edit.apply(&out)?;
            if !args.lockstep {
                applied.reload = Some(apply::reload(&config.instance));
            }
            Ok(applied)
        })
        .transpose()?;
    let report =
        report::Solution { solved: &solved, truth: truth.as_ref(), out: &out, views_dir: &views_dir };
    let text = report::solved(&config, &report, applied.as_ref(), args.json);
    print_stdout(&text)?;
    Ok(())
}

/// How long a dry run waits for the arm to be at rest before it locates the board.
const LOCATE_REST_WAIT: std::time::Duration = std::time::Duration::from_secs(20);

/// Where the arm is, at rest, when the calibration starts.
struct Located {
    start: vservo_arm::JointVector,
    /// The stamp of the joint state from which it is known at rest (a frame after it sees it so).
    settled_ns: u64,
}

/// The board located from where the arm is, and the poses planned around it (refused before anything moves).
fn locate_and_plan(
    config: &Config,
    settings: &CalibrationSettings,
    cell: &mut live::Running,
    at: &Located,
    solver: &SolverRun,
    given: Option<&[Vec<f64>]>,
) -> vservo_calibrate::Result<Vec<plan::PlannedPose>> {
    let located = locate_board(config, settings, cell, at, solver)?;
    plan_poses(config, settings, at.start, located, given)
}

/// How the solver is run, and where the views go.
struct SolverRun<'a> {
    python: &'a std::path::Path,
    script: &'a std::path::Path,
    views_dir: &'a std::path::Path,
}

/// Where the board is, from a view where the arm is now: the solver finds the board's pose in the camera through
/// the camera and mount the configuration believes (a few millimetres off on a cell not yet calibrated, which
/// the plan's margins take). A hand camera's board stands in the base (the pose returned); a fixed camera's
/// rides on the tool (the mount returned holds it there).
fn locate_board(
    config: &Config,
    settings: &CalibrationSettings,
    cell: &mut live::Running,
    at: &Located,
    solver: &SolverRun,
) -> vservo_calibrate::Result<(vservo_scene::CameraMount, vservo_scene::IsometryMatrix3<f64>)> {
    let view = cell.take_view("locating the board", at.settled_ns)?;
    let dir = solver.views_dir.join("locate");
    dataset::write(
        &dir,
        std::slice::from_ref(&view),
        &config.cell.camera,
        (config.cell.camera_in_mount().0, &config.cell.camera_in_mount().1),
        &settings.board,
        config.cell.arm.joint_count(),
    )?;
    let located = solver::locate_board(solver.python, solver.script, &dir)?;
    let camera_from_board = report::isometry(&located.camera_from_board.matrix)
        .ok_or_else(|| CalibrateError::Solver("the solver's board pose is not a 4 × 4 matrix".into()))?;
    eprintln!(
        "the board: {} tags found, {:.3} m from the camera ({:.2} px RMS through the configured camera)",
        located.tags_found,
        camera_from_board.translation.vector.norm(),
        located.rms_px
    );
    let base_from_tool = config.cell.arm.base_from_tool(&at.start);
    let base_from_board = config.cell.mount().base_from_camera(&base_from_tool) * camera_from_board;
    Ok(match config.cell.mount() {
        hand @ vservo_scene::CameraMount::Hand { .. } => (hand, base_from_board),
        vservo_scene::CameraMount::World { base_from_camera, .. } => {
            let tool_from_board = base_from_tool.inverse() * base_from_board;
            (vservo_scene::CameraMount::World { base_from_camera, tool_from_board }, base_from_board)
        }
    })
}

/// The truth of a simulated cell (`[camera.truth]`, which only a simulated camera may have: vservo's, or a
/// driver's that renders `vservoctl scene`): the camera as it says, the board where the configuration's world
/// puts it (unless a client moved it).
fn simulated_truth(config: &Config) -> Option<report::Truth> {
    config.cell.camera_truth.map(|_| simulated_truth_of(config))
}

/// The simulated cell's camera as it really is, and its board: in the base on the hand, on the tool fixed.
fn simulated_truth_of(config: &Config) -> report::Truth {
    let board = match config.cell.mount() {
        vservo_scene::CameraMount::Hand { .. } => config.cell.base_from_board(&config.cell.arm),
        vservo_scene::CameraMount::World { tool_from_board, .. } => tool_from_board,
    };
    report::Truth {
        camera: config.cell.true_camera(),
        camera_in_mount: config.cell.true_camera_in_mount(),
        board,
    }
}

/// The arm's poses as the hand-eye solver takes them, whose spread decides the calibration: as they are for a
/// camera on the hand, inverted (tool_from_base) for a fixed one (docs/CALIBRATION.md).
fn solved_poses(
    config: &Config,
    base_from_tool: &[vservo_scene::IsometryMatrix3<f64>],
) -> Vec<vservo_scene::IsometryMatrix3<f64>> {
    let fixed = config.cell.fixed_camera.is_some();
    base_from_tool.iter().map(|pose| if fixed { pose.inverse() } else { *pose }).collect()
}

/// `[calibration]`, which the command needs.
fn settings_of(config: &Config) -> Result<CalibrationSettings, UsageError> {
    config.calibration.clone().ok_or_else(|| {
        UsageError(format!(
            "{}: no [calibration] section: it says which board is printed (vservoctl board) and how far the poses go",
            config.origin
        ))
    })
}

/// The plan, refused before anything moves when a pose is out of reach or out of view, or the poses too
/// poorly spread.
fn plan_poses(
    config: &Config,
    settings: &CalibrationSettings,
    start: vservo_arm::JointVector,
    (mount, base_from_board): (vservo_scene::CameraMount, vservo_scene::IsometryMatrix3<f64>),
    given: Option<&[Vec<f64>]>,
) -> vservo_calibrate::Result<Vec<plan::PlannedPose>> {
    let distance_m = settings
        .distance_m
        .unwrap_or_else(|| config.cell.desired.camera_from_board.translation.vector.norm());
    let planner_cell =
        plan::Cell { arm: &config.cell.arm, start, camera: &config.cell.camera, mount, base_from_board };
    let planned = match given {
        Some(joints) => plan::given(&planner_cell, &settings.board, joints),
        None => plan::plan(&planner_cell, settings, distance_m),
    }
    .map_err(|e| {
        CalibrateError::Refused(format!("{}: the plan is refused before anything moves: {e}", config.origin))
    })?;
    let tools: Vec<_> = planned.iter().map(|p| p.base_from_tool).collect();
    spread::check(&solved_poses(config, &tools)).map_err(|e| {
        CalibrateError::Refused(format!("{}: the plan is refused before anything moves: {e}", config.origin))
    })?;
    Ok(planned)
}

/// `--poses FILE`: a JSON list of joint vectors (rad).
fn read_poses(path: &std::path::Path) -> Result<Vec<Vec<f64>>, UsageError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| UsageError(format!("--poses {}: cannot read: {e}", path.display())))?;
    serde_json::from_str(&text).map_err(|e| {
        UsageError(format!(
            "--poses {}: must be a JSON list of joint vectors in radians: {e}",
            path.display()
        ))
    })
}

/// `--out`, else `calibration.output_file` (relative to the configuration file), else calibration.yaml
/// beside the configuration file.
fn output_file(args: &CalibrateArgs, settings: &CalibrationSettings) -> PathBuf {
    if let Some(out) = &args.out {
        return out.clone();
    }
    let config_dir = args.config.config.parent().map(PathBuf::from).unwrap_or_default();
    config_dir.join(settings.output_file.as_deref().unwrap_or("calibration.yaml"))
}
