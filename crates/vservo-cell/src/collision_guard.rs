//! The collision guard built from the configuration (`[collision]`, `[[scene.obstacles]]`): the arm's URDF
//! shapes, the camera's box, the obstacles and the board, their pairs, and the workspace's points (the tool's
//! origin and the camera box's corners).
//!
//! The board is an obstacle where it stands still: on a hand camera's cell whose scenario does not move it
//! (`scenario.object_motion = "hold"`), or on the tool of a fixed camera's cell. A fixed camera's box stands in
//! the world.

use nalgebra::{Translation3, Vector3};
use vservo_arm::{Geometry, SerialArm, Transform};
use vservo_collision::{BodyKind, BodySpec, CollisionModel, GeometryError, Guard, GuardSettings, Solid};
use vservo_config::{CellConfig, Collision};
use vservo_settings::simulation::ObjectMotion;

/// How thick the board is taken to be, behind its face (m).
pub const BOARD_THICKNESS_M: f64 = 0.01;

/// The guard the configuration asks for, or `None` without `[collision]`.
pub fn guard(config: &CellConfig, arm: &SerialArm) -> Result<Option<Guard>, GeometryError> {
    let Some(collision) = &config.collision else { return Ok(None) };
    let joints = arm.joint_count();
    let last_from_tool = arm.last_from_tool();
    let mut bodies = arm_bodies(collision, arm)?;
    let mut points = vec![("tool".to_string(), last_from_tool.translation.vector)];
    if let Some(camera_box) = &collision.camera_box {
        let solid = Solid::Box { size_m: camera_box.size_m };
        let camera_from_box = Transform::from_parts(
            Translation3::from(Vector3::from(camera_box.centre_in_camera_m)),
            nalgebra::Rotation3::identity(),
        );
        let (kind, carrier, carrier_from_camera) = match &config.fixed_camera {
            None => (BodyKind::Arm, joints, last_from_tool * config.tool_from_camera),
            Some(fixed) => (BodyKind::Obstacle, 0, fixed.base_from_camera),
        };
        bodies.push(body("camera", kind, carrier, carrier_from_camera * camera_from_box, solid)?);
        if config.fixed_camera.is_none() {
            points.extend(box_corners(&camera_box.size_m).into_iter().enumerate().map(|(k, corner)| {
                (
                    format!("camera corner {}", k + 1),
                    (carrier_from_camera * camera_from_box).transform_point(&corner.into()).coords,
                )
            }));
        }
    }
    for obstacle in &collision.obstacles {
        bodies.push(body(
            &obstacle.name,
            BodyKind::Obstacle,
            0,
            obstacle.base_from_obstacle,
            obstacle.solid,
        )?);
    }
    if collision.board {
        bodies.extend(board(config, joints, &last_from_tool)?);
    }
    let model = CollisionModel::new(bodies, &collision.disabled_pairs)?;
    let settings = GuardSettings {
        slowdown_distance_m: collision.slowdown_distance_m,
        stop_distance_m: collision.stop_distance_m,
    };
    Ok(Some(Guard::new(model, settings, collision.workspace, points)))
}

/// The arm's links from its URDF, where the arm is a URDF chain and its shapes are asked for.
fn arm_bodies(collision: &Collision, arm: &SerialArm) -> Result<Vec<BodySpec>, GeometryError> {
    match (&collision.arm_urdf, &arm.geometry) {
        (Some(urdf), Geometry::Chain(chain)) => {
            vservo_collision::arm_bodies(std::path::Path::new(urdf), chain)
        }
        _ => Ok(Vec::new()),
    }
}

/// The board as a thin box behind its face, where it stands still.
fn board(
    config: &CellConfig,
    joints: usize,
    last_from_tool: &Transform,
) -> Result<Option<BodySpec>, GeometryError> {
    let [low, high] = config.board.extent_in_board;
    let solid = Solid::Box { size_m: [high.x - low.x, high.y - low.y, BOARD_THICKNESS_M] };
    let board_from_box = Transform::from_parts(
        Translation3::new((low.x + high.x) / 2.0, (low.y + high.y) / 2.0, BOARD_THICKNESS_M / 2.0),
        nalgebra::Rotation3::identity(),
    );
    let placed = match &config.fixed_camera {
        Some(fixed) => Some((BodyKind::Arm, joints, last_from_tool * fixed.tool_from_board)),
        None if config.scenario.object == ObjectMotion::Hold => {
            Some((BodyKind::Obstacle, 0, config.base_from_board(&config.arm)))
        }
        None => None,
    };
    placed
        .map(|(kind, carrier, carrier_from_board)| {
            body("board", kind, carrier, carrier_from_board * board_from_box, solid)
        })
        .transpose()
}

/// One body of one solid.
fn body(
    name: &str,
    kind: BodyKind,
    carrier: usize,
    carrier_from_body: Transform,
    solid: Solid,
) -> Result<BodySpec, GeometryError> {
    let (shape, body_from_shape) = vservo_collision::shape::shape_of(&solid)
        .map_err(|why| GeometryError::BadShape { body: name.to_string(), why })?;
    Ok(BodySpec {
        name: name.to_string(),
        kind,
        carrier,
        carrier_from_body,
        shapes: vec![(shape, body_from_shape)],
    })
}

/// A box's eight corners about its centre.
fn box_corners(size_m: &[f64; 3]) -> [Vector3<f64>; 8] {
    std::array::from_fn(|k| {
        let sign = |bit: usize| if k & (1 << bit) == 0 { -0.5 } else { 0.5 };
        Vector3::new(sign(0) * size_m[0], sign(1) * size_m[1], sign(2) * size_m[2])
    })
}
