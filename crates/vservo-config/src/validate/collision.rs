//! `[collision]` and `[[scene.obstacles]]`: distances in order, shapes with volume, names once.

use nalgebra::Vector3;
use vservo_settings::collision::{Solid, Workspace};

use super::checker::Checker;
use crate::raw::{RawCollision, RawObstacle, RawObstacleShape, RawScene};
use crate::{CameraBox, Collision, ConfigError, Obstacle, pose_from_rpy};

/// How far from the base an obstacle's centre may be (m).
const SCENE_REACH_M: f64 = 20.0;

/// The guard's settings when `[collision]` is given (obstacles without it are refused: nothing would act on
/// them). `arm_urdf`: the arm's URDF, for its shapes.
pub fn collision(
    check: &Checker,
    c: Option<&RawCollision>,
    scene: &RawScene,
    arm_urdf: Option<&str>,
) -> Result<Option<Collision>, ConfigError> {
    let Some(c) = c else {
        if scene.obstacles.is_empty() {
            return Ok(None);
        }
        return Err(check.invalid(
            "scene.obstacles",
            format!("{} obstacles", scene.obstacles.len()),
            "nothing keeps the arm off them without the guard: add a [collision] section",
        ));
    };
    let stop_distance_m = check.within("collision.stop_distance_m", c.stop_distance_m, 0.001, 1.0, "m")?;
    let slowdown_distance_m =
        check.within("collision.slowdown_distance_m", c.slowdown_distance_m, 0.001, 2.0, "m")?;
    if slowdown_distance_m <= stop_distance_m {
        return Err(check.invalid(
            "collision.slowdown_distance_m",
            slowdown_distance_m,
            format!(
                "must be above collision.stop_distance_m ({stop_distance_m} m): the arm slows between them"
            ),
        ));
    }
    let obstacles = scene
        .obstacles
        .iter()
        .enumerate()
        .map(|(k, o)| obstacle(check, k, o))
        .collect::<Result<Vec<_>, _>>()?;
    for (k, o) in obstacles.iter().enumerate() {
        if o.name.trim().is_empty() || obstacles[..k].iter().any(|other| other.name == o.name) {
            return Err(check.invalid(
                &format!("scene.obstacles[{k}].name"),
                format!("{:?}", o.name),
                "each obstacle needs a name of its own",
            ));
        }
    }
    Ok(Some(Collision {
        slowdown_distance_m,
        stop_distance_m,
        disabled_pairs: c.disabled_pairs.clone(),
        arm_urdf: arm_urdf.filter(|_| c.arm_shapes).map(str::to_string),
        camera_box: c.camera_box_m.map(|size| camera_box(check, size, c.camera_box_centre_m)).transpose()?,
        workspace: workspace(check, c.workspace_min_m, c.workspace_max_m)?,
        obstacles,
        board: c.board,
    }))
}

fn camera_box(check: &Checker, size_m: [f64; 3], centre: [f64; 3]) -> Result<CameraBox, ConfigError> {
    Ok(CameraBox {
        size_m: check.all_within("collision.camera_box_m", size_m, 0.001, 1.0, "m")?,
        centre_in_camera_m: check.all_within("collision.camera_box_centre_m", centre, -1.0, 1.0, "m")?,
    })
}

fn workspace(
    check: &Checker,
    min: Option<[f64; 3]>,
    max: Option<[f64; 3]>,
) -> Result<Option<Workspace>, ConfigError> {
    match (min, max) {
        (None, None) => Ok(None),
        (Some(min_m), Some(max_m)) => {
            let min_m =
                check.all_within("collision.workspace_min_m", min_m, -SCENE_REACH_M, SCENE_REACH_M, "m")?;
            let max_m =
                check.all_within("collision.workspace_max_m", max_m, -SCENE_REACH_M, SCENE_REACH_M, "m")?;
            if (0..3).any(|i| max_m[i] <= min_m[i]) {
                return Err(check.invalid(
                    "collision.workspace_max_m",
                    format!("{max_m:?}"),
                    format!("must be above collision.workspace_min_m ({min_m:?}) on every axis"),
                ));
            }
            Ok(Some(Workspace { min_m, max_m }))
        }
        (Some(_), None) | (None, Some(_)) => Err(check.invalid(
            "collision.workspace_min_m",
            "(one of the two)",
            "the workspace box needs both collision.workspace_min_m and collision.workspace_max_m",
        )),
    }
}

/// Obstacle `k`: its shape's numbers (only its shape's), positive, and its pose.
fn obstacle(check: &Checker, k: usize, o: &RawObstacle) -> Result<Obstacle, ConfigError> {
    let key = |field: &str| format!("scene.obstacles[{k}].{field}");
    let given = [
        ("size_m", o.size_m.is_some()),
        ("radius_m", o.radius_m.is_some()),
        ("length_m", o.length_m.is_some()),
    ];
    let wants: &[&str] = match o.shape {
        RawObstacleShape::Box => &["size_m"],
        RawObstacleShape::Cylinder | RawObstacleShape::Capsule => &["radius_m", "length_m"],
        RawObstacleShape::Sphere => &["radius_m"],
        RawObstacleShape::Plane => &[],
    };
    for (field, is_given) in given {
        if is_given != wants.contains(&field) {
            let why = if is_given { "is not a number of this shape" } else { "is needed for this shape" };
            return Err(check.invalid(&key(field), format!("{:?}", o.shape).to_lowercase(), why));
        }
    }
    let length =
        |value: Option<f64>, field: &str| check.within(&key(field), value.unwrap_or(0.0), 0.001, 50.0, "m");
    let solid = match o.shape {
        RawObstacleShape::Box => Solid::Box {
            size_m: check.all_within(&key("size_m"), o.size_m.unwrap_or_default(), 0.001, 50.0, "m")?,
        },
        RawObstacleShape::Cylinder => Solid::Cylinder {
            radius_m: length(o.radius_m, "radius_m")?,
            length_m: length(o.length_m, "length_m")?,
        },
        RawObstacleShape::Capsule => Solid::Capsule {
            radius_m: length(o.radius_m, "radius_m")?,
            length_m: length(o.length_m, "length_m")?,
        },
        RawObstacleShape::Sphere => Solid::Sphere { radius_m: length(o.radius_m, "radius_m")? },
        RawObstacleShape::Plane => Solid::HalfSpace,
    };
    let translation =
        check.all_within(&key("translation_m"), o.translation_m, -SCENE_REACH_M, SCENE_REACH_M, "m")?;
    let rpy = check.all_within(&key("rotation_rpy_deg"), o.rotation_rpy_deg, -360.0, 360.0, "°")?;
    Ok(Obstacle {
        name: o.name.clone(),
        solid,
        base_from_obstacle: pose_from_rpy(
            Vector3::from(translation),
            Vector3::from(rpy.map(f64::to_radians)),
        ),
    })
}
