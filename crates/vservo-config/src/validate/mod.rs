//! From the file as written to a [`Config`]: one module per section, every check naming its key and value.
//! Names (laws, modes, sources) are parsed by serde in [`crate::raw`]; what is left here are ranges and the
//! checks that span sections, in the order the sections build on each other.

mod arm;
mod calibration_board;
mod camera;
mod checker;
mod collision;
mod controller;
mod desired;
mod franka;
mod motion;
mod object;
mod operation;
mod robot;
mod ros2;
mod runtime;
mod scenario;
mod simulation;
mod timing;
mod vision;
mod weight;

use checker::Checker;

use crate::raw::RawConfig;
use crate::{CellConfig, Config, ConfigError};

/// Validates every section; the first error found is returned, naming `file`.
pub fn validate(raw: RawConfig, file: &str) -> Result<Config, ConfigError> {
    let check = Checker { file };
    let instance = timing::instance(&check, &raw.instance)?;
    let timing = timing::timing(&check, &raw.timing)?;
    let calibration_file = camera::calibration_file(&check, &raw.camera)?;
    let camera = camera::intrinsics(&check, &raw.camera, calibration_file.as_ref())?;
    let tool_from_camera = camera::tool_from_camera(&check, &raw.camera, calibration_file.as_ref())?;
    let camera_truth = camera::truth(&check, &raw.camera, &camera, &tool_from_camera)?;
    let mut board = object::board(&check, &raw.object, &raw.target)?;
    let calibration = raw.calibration.as_ref().map(|c| calibration_board::settings(&check, c)).transpose()?;
    if let (Some(written), Some(settings)) = (&raw.calibration, &calibration)
        && written.printed_on_object
    {
        let grid = calibration_board::printed(&check, written, &raw.object, &board, settings.board)?;
        board.calibration_grid = Some(grid);
    }
    let arm = arm::arm(&check, &raw.robot.arm)?;
    let from_ros2 = ros2::FromRos2 {
        arm: raw.robot.driver == crate::raw::RawRobotDriver::Ros2,
        camera: raw.camera.source == crate::raw::RawCameraSource::Ros2,
    };
    let ros2 = ros2::ros2(&check, &raw.ros2, arm.joint_count(), from_ros2)?;
    let desired = desired::desired(&check, &raw.desired, &arm, &camera, &board)?;
    let fixed_camera = camera::fixed_camera(&check, &raw.camera, &arm, &desired, calibration_file.as_ref())?;
    let controller =
        controller::controller(&check, &raw.controller, &camera, &desired.features, timing.vision_period_s)?;
    let source = camera::source(&check, &raw.camera)?;
    let vision = vision::vision(&check, &raw.vision, source)?;
    let plant = simulation::plant(&check, &raw.plant)?;
    let interpolator = simulation::interpolator(
        &check,
        &raw.interpolator,
        &timing,
        (&raw.robot.arm, &arm),
        (raw.robot.driver, raw.robot.speed_scale),
    )?;
    let joint_servo = simulation::joint_servo(&check, &raw.joint_servo)?;
    let interpolator_jerk = (interpolator.jerk_limit, arm.joint_count());
    let scenario = scenario::scenario(&check, &raw.scenario)?;
    if fixed_camera.is_some() && scenario.object != vservo_settings::simulation::ObjectMotion::Hold {
        return Err(check.invalid(
            "scenario.object_motion",
            format!("{:?}", raw.scenario.object_motion),
            "moves a standing board: with a fixed camera (camera.mount = \"world\") the board rides on the tool \
             (leave it out)",
        ));
    }
    let robot = robot::robot(&check, &raw.robot, &plant, &timing)?;
    let mut controller = controller;
    controller::fit_pose_caps(&check, &raw.controller, &mut controller.options, &robot)?;
    let reacquire = operation::reacquire(&check, &raw.reacquire, &robot, timing.vision_period_s)?;
    let franka_simulator = raw.franka.as_ref().is_some_and(|f| f.simulator);
    robot::driver_and_camera_agree(&check, &raw.robot, &robot, (&vision.source, franka_simulator))?;
    let arm_urdf_file = (raw.robot.arm.preset == crate::raw::RawArmPreset::Urdf)
        .then(|| raw.robot.arm.urdf.clone())
        .flatten();
    Ok(Config {
        origin: file.to_string(),
        instance,
        cell: CellConfig {
            timing,
            camera,
            tool_from_camera,
            fixed_camera,
            camera_truth,
            board,
            desired,
            controller,
            vision,
            plant,
            interpolator,
            joint_servo,
            scenario,
            robot,
            arm,
            reacquire,
            collision: collision::collision(
                &check,
                raw.collision.as_ref(),
                &raw.scene,
                arm_urdf_file.as_deref(),
            )?,
        },
        runtime: runtime::runtime(&check, &raw.runtime)?,
        arm_urdf_file,
        faults: operation::faults(&check, &raw.faults)?,
        viewer: operation::viewer(&check, &raw.viewer)?,
        ros2,
        franka: franka::franka(&check, &raw.robot, raw.franka.as_ref(), &interpolator_jerk)?,
        gstreamer: raw.camera.gstreamer.as_ref().map(|g| camera::gstreamer(&check, g)).transpose()?,
        calibration,
    })
}
