//! `vservoctl scene`: the cell a configuration describes, as one JSON object, for drivers and simulators
//! written outside this repository (the MuJoCo reference driver builds its model from it): the arm's
//! standard-DH table or its URDF (file, links, joint names) and limits, the joints the scenario starts at, the camera on the hand and its
//! intrinsics, the board with its marks (and the calibration board printed on it) and where it stands, the
//! periods and the robot driver's settings. The camera is the real one: where `[camera.truth]` says the camera
//! and its mount differ from what the configuration believes, a driver that simulates the cell renders the
//! truth, as vservo's own simulated camera does (`believed_camera` and `believed_tool_from_camera` give the
//! belief).

use anyhow::Result;
use clap::Args;
use serde_json::{Value, json};
use vservo_cell::Cell;
use vservo_scene::IsometryMatrix3;

use crate::UsageError;
use crate::config_arg::ConfigArg;
use crate::output::print_stdout;

/// Arguments of `vservoctl scene`.
#[derive(Args)]
pub struct SceneArgs {
    #[command(flatten)]
    config: ConfigArg,
}

/// A pose as a 4×4 homogeneous matrix, row by row.
fn matrix4(pose: &IsometryMatrix3<f64>) -> Value {
    let m = pose.to_homogeneous();
    Value::from((0..4).map(|r| (0..4).map(|c| m[(r, c)]).collect::<Vec<f64>>()).collect::<Vec<_>>())
}

/// Runs the command.
pub fn run(args: &SceneArgs) -> Result<()> {
    let config = args.config.load()?;
    let cell = Cell::new(&config.cell).map_err(|e| UsageError(format!("{}: {e}", config.origin)))?;
    let arm = cell.arm();
    let chain = match &arm.geometry {
        vservo_arm::Geometry::Chain(chain) => Some(chain),
        vservo_arm::Geometry::Dh => None,
    };
    let dh: Vec<Value> = arm
        .joints()
        .iter()
        .map(|l| {
            json!({"a_m": l.dh.a(), "alpha_rad": l.dh.alpha(), "d_m": l.dh.d(), "theta_offset_rad": l.dh.offset()})
        })
        .collect();
    let limits = |f: &dyn Fn(&vservo_arm::JointLimits) -> Value| -> Vec<Value> {
        arm.joints().iter().map(|l| f(&l.limits)).collect()
    };
    let board = &config.cell.board;
    let truth = config.cell.true_camera();
    let scene = json!({
        "instance": config.instance,
        "arm": {
            "name": arm.name,
            "dh": chain.is_none().then_some(dh),
            // an arm from a URDF: the file (absolute) and the chain's links and joints, for a driver that loads it
            "urdf": config.arm_urdf_file.as_ref().map(|file| absolute(file)),
            "base_link": chain.map(|c| c.base_link.clone()),
            "tip_link": chain.map(|c| c.tip_link.clone()),
            "joint_names": chain.map(|c| c.joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>()),
            "joint_limits_rad": limits(&|l| json!([l.position_min, l.position_max])),
            "velocity_limits_rad_s": limits(&|l| json!(l.velocity_max)),
            "torque_limits_nm": limits(&|l| json!(l.torque_max)),
            // the motion limits the joint reference keeps (the arm's, narrowed by [interpolator]); no jerk limit:
            // null (the reference's acceleration may step within a tick)
            "acceleration_limits_rad_s2": &config.cell.interpolator.acceleration_limit.as_slice()[..arm.joint_count()],
            "jerk_limits_rad_s3": config.cell.interpolator.jerk_limit.map(|j| j.as_slice()[..arm.joint_count()].to_vec()),
            "tool_speed_limit_m_s": finite(config.cell.interpolator.tool_speed_limit_m_s),
            "tool_rotation_limit_rad_s": finite(config.cell.interpolator.tool_rotation_limit_rad_s),
        },
        "start_joints_rad": &cell.start_joints().as_slice()[..arm.joint_count()],
        "desired_joints_rad": &config.cell.desired.joints.as_slice()[..arm.joint_count()],
        "desired_features_px": config.cell.desired.features.as_slice(),
        // "hand": the camera at tool_from_camera, the board standing at base_from_board; "world": the camera fixed
        // at base_from_camera, the board on the tool at tool_from_board (base_from_board: where it is at the
        // desired joints)
        "camera_mount": if config.cell.fixed_camera.is_some() { "world" } else { "hand" },
        "tool_from_camera": config.cell.fixed_camera.is_none().then(|| matrix4(&truth.tool_from_camera)),
        "base_from_camera": match config.cell.true_mount() {
            vservo_scene::CameraMount::World { base_from_camera, .. } => Some(matrix4(&base_from_camera)),
            vservo_scene::CameraMount::Hand { .. } => None,
        },
        "believed_base_from_camera": config.cell.fixed_camera.map(|fixed| matrix4(&fixed.base_from_camera)),
        "tool_from_board": config.cell.fixed_camera.map(|fixed| matrix4(&fixed.tool_from_board)),
        "base_from_board": matrix4(&config.cell.base_from_board(arm)),
        "camera": camera_json(&truth.intrinsics, config.cell.vision.render.noise_sigma_gray),
        "believed_tool_from_camera": config.cell.fixed_camera.is_none().then(|| matrix4(&config.cell.tool_from_camera)),
        "believed_camera": camera_json(&config.cell.camera, config.cell.vision.render.noise_sigma_gray),
        "board": {
            "mark_diameter_m": board.mark_diameter_m,
            "marks_in_board_m": board.marks_in_board.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
            "extent_m": board.extent_in_board.map(|p| [p.x, p.y]),
            // with an AprilTag target: the tag, and its black cells (row-major, 8 × 8, rows along +y) to draw
            "apriltag": board.apriltag().map(|tag| json!({
                "family": "tag36h11",
                "id": tag.id(),
                "size_m": tag.size_m(),
                "centre_in_board_m": [tag.centre_in_board().x, tag.centre_in_board().y],
                "black_cells": black_cells(tag),
            })),
            // with an AprilTag target or a bundle: every tag of the target, as "apriltag" is
            "target_tags": board.target_tags().iter().map(|tag| json!({
                "id": tag.id(),
                "size_m": tag.size_m(),
                "centre_in_board_m": [tag.centre_in_board().x, tag.centre_in_board().y],
                "black_cells": black_cells(tag),
            })).collect::<Vec<_>>(),
            // the calibration board (`vservoctl board`) printed on it, its tags as the target's
            "calibration_grid": board.calibration_grid.as_ref().map(|grid| json!({
                "tags": grid.tags().map(|tag| json!({
                    "id": tag.id(),
                    "size_m": tag.size_m(),
                    "centre_in_board_m": [tag.centre_in_board().x, tag.centre_in_board().y],
                    "black_cells": black_cells(&tag),
                })).collect::<Vec<_>>(),
            })),
        },
        "timing": {"vision_period_s": config.cell.timing.vision_period_s},
        "robot": robot_json(&config),
        // the collision guard's settings and what stands around the arm (null without [collision])
        "collision": config.cell.collision.as_ref().map(collision_json),
    });
    print_stdout(&format!("{}\n", serde_json::to_string_pretty(&scene)?))?;
    Ok(())
}

/// The robot driver, the command it takes, its period and the dynamics override.
fn robot_json(config: &vservo_config::Config) -> Value {
    json!({
        "driver": config.cell.robot.driver.name(),
        "command": config.cell.command_interface().name(),
        "period_s": config.cell.robot.period_s,
        "state_timeout_periods": config.cell.robot.state_timeout_periods,
        "speed_scale": config.cell.interpolator.speed_scale,
    })
}

/// `[collision]` and `[[scene.obstacles]]`: the distances, and each obstacle's shape (as configured: a box's full
/// edges, a cylinder's or capsule's radius and length along its z, a plane's solid side below its xy plane) and
/// pose in the base frame.
fn collision_json(collision: &vservo_config::Collision) -> Value {
    use vservo_config::Solid;
    let obstacles: Vec<Value> = collision
        .obstacles
        .iter()
        .map(|o| {
            let shape = match o.solid {
                Solid::Box { size_m } => json!({"shape": "box", "size_m": size_m}),
                Solid::Cylinder { radius_m, length_m } => {
                    json!({"shape": "cylinder", "radius_m": radius_m, "length_m": length_m})
                }
                Solid::Capsule { radius_m, length_m } => {
                    json!({"shape": "capsule", "radius_m": radius_m, "length_m": length_m})
                }
                Solid::Sphere { radius_m } => json!({"shape": "sphere", "radius_m": radius_m}),
                Solid::HalfSpace => json!({"shape": "plane"}),
            };
            json!({"name": o.name, "solid": shape, "base_from_obstacle": matrix4(&o.base_from_obstacle)})
        })
        .collect();
    json!({
        "slowdown_distance_m": collision.slowdown_distance_m,
        "stop_distance_m": collision.stop_distance_m,
        "camera_box_m": collision.camera_box.map(|b| b.size_m),
        "camera_box_centre_m": collision.camera_box.map(|b| b.centre_in_camera_m),
        "workspace": collision.workspace.map(|w| json!({"min_m": w.min_m, "max_m": w.max_m})),
        "board": collision.board,
        "obstacles": obstacles,
    })
}

/// A camera's intrinsics and lens, and the noise of its images (gray levels).
fn camera_json(camera: &vservo_scene::CameraIntrinsics, noise_sigma_gray: f64) -> Value {
    json!({
        // (focal_px: fy, for a driver that takes one focal length, as a vertical field of view)
        "focal_px": camera.fy_px(),
        "fx_px": camera.fx_px(),
        "fy_px": camera.fy_px(),
        "distortion": camera.distortion().coefficients(),
        "principal_point_px": [camera.principal_point_px().x, camera.principal_point_px().y],
        "width_px": camera.width_px(),
        "height_px": camera.height_px(),
        "noise_sigma_gray": noise_sigma_gray,
    })
}

/// `file` as an absolute path (as given when it cannot be resolved: the driver then says it is missing).
fn absolute(file: &str) -> String {
    std::fs::canonicalize(file).map_or_else(|_| file.to_string(), |path| path.display().to_string())
}

/// The tag's 8 × 8 cells, row by row (rows along the board's +y, columns along +x): true where black.
fn black_cells(tag: &vservo_scene::AprilTag) -> Vec<Vec<bool>> {
    let cell = tag.size_m() / 8.0;
    let c = tag.centre_in_board();
    (0..8)
        .map(|row| {
            (0..8)
                .map(|column| {
                    let x = c.x + (f64::from(column) - 3.5) * cell;
                    let y = c.y + (f64::from(row) - 3.5) * cell;
                    tag.is_black_at(x, y) == Some(true)
                })
                .collect()
        })
        .collect()
}

/// A limit as JSON: null where there is none (infinite).
fn finite(value: f64) -> Option<f64> {
    value.is_finite().then_some(value)
}
