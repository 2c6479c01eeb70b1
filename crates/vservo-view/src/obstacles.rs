//! The collision guard's scene as Foxglove shows it: each obstacle of `[[scene.obstacles]]` and the workspace box
//! as `foxglove.SceneUpdate` entities in the base frame, named, and coloured by what the guard says of them now
//! (the status's nearest pair): grey when clear, amber within the slow-down distance, red at the stop distance.
//! Pure conversions; the bridge writes them (`vservoctl record`, `vservoctl view`).

use foxglove::messages::{
    Color, CubePrimitive, CylinderPrimitive, KeyValuePair, LinePrimitive, Point3, Pose, Quaternion,
    SceneEntity, SceneUpdate, SpherePrimitive, TextPrimitive, Timestamp, Vector3,
};
use nalgebra::{IsometryMatrix3, UnitQuaternion};
use vservo_settings::collision::{Obstacle, Primitive, PrimitiveKind, Workspace};

/// The obstacles' topic.
pub const OBSTACLES_TOPIC: &str = "/scene/obstacles";
/// The frame the obstacles stand in (the arm's `base`, as in `/tf`).
pub const BASE_FRAME: &str = "base";
/// The name the guard gives the workspace box in the status's nearest pair.
pub const WORKSPACE_NAME: &str = "workspace";

/// What the guard keeps the arm off, and at what distances.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardedScene {
    /// The obstacles.
    pub obstacles: Vec<Obstacle>,
    /// The box the tool and the camera stay inside.
    pub workspace: Option<Workspace>,
    /// Below this the guard slows a motion that closes the distance (m).
    pub slowdown_distance_m: f64,
    /// The guard stops the arm before this (m).
    pub stop_distance_m: f64,
}

/// The nearest pair as the status names it: its two names and the distance between them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest<'a> {
    /// The two names the status joins with " – ".
    pub between: &'a str,
    /// Their distance (m).
    pub distance_m: f64,
}

impl Nearest<'_> {
    /// Whether `name` is one of the pair.
    fn names(&self, name: &str) -> bool {
        self.between.split(" – ").any(|part| part == name)
    }
}

/// How near the guard says a thing is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Nearness {
    /// Farther than the slow-down distance, or not the nearest pair.
    Clear,
    /// Within the slow-down distance: a motion towards it is slowed.
    Slowing,
    /// Within the stop distance.
    Stopping,
}

impl Nearness {
    fn color(self, alpha: f64) -> Option<Color> {
        let (r, g, b) = match self {
            Nearness::Clear => (0.62, 0.64, 0.68),
            Nearness::Slowing => (1.0, 0.6, 0.0),
            Nearness::Stopping => (0.9, 0.12, 0.08),
        };
        Some(Color { r, g, b, a: alpha })
    }
}

impl GuardedScene {
    /// How near `name` is, from the status's nearest pair.
    pub fn nearness(&self, name: &str, nearest: Option<Nearest<'_>>) -> Nearness {
        match nearest {
            Some(pair) if pair.names(name) && pair.distance_m <= self.stop_distance_m => Nearness::Stopping,
            Some(pair) if pair.names(name) && pair.distance_m <= self.slowdown_distance_m => {
                Nearness::Slowing
            }
            _ => Nearness::Clear,
        }
    }

    /// How near each obstacle is, then the workspace (if there is one): what the colours of an update are.
    pub fn nearnesses(&self, nearest: Option<Nearest<'_>>) -> Vec<Nearness> {
        let obstacles = self.obstacles.iter().map(|obstacle| self.nearness(&obstacle.name, nearest));
        let workspace = self.workspace.map(|_| self.nearness(WORKSPACE_NAME, nearest));
        obstacles.chain(workspace).collect()
    }

    /// The scene as one update: an entity per obstacle (`obstacle/<name>`, its solids and its name) and the
    /// workspace's edges (`workspace`), each replacing the one of the same id drawn before.
    pub fn update(&self, nearest: Option<Nearest<'_>>, stamp_ns: u64) -> SceneUpdate {
        let mut entities: Vec<SceneEntity> = self
            .obstacles
            .iter()
            .map(|obstacle| {
                let nearness = self.nearness(&obstacle.name, nearest);
                obstacle_entity(obstacle, nearness, stamp_ns)
            })
            .collect();
        if let Some(workspace) = &self.workspace {
            entities.push(workspace_entity(workspace, self.nearness(WORKSPACE_NAME, nearest), stamp_ns));
        }
        SceneUpdate { deletions: Vec::new(), entities }
    }
}

fn timestamp(stamp_ns: u64) -> Option<Timestamp> {
    Some(crate::drawing::timestamp(stamp_ns))
}

fn pose(base_from: &IsometryMatrix3<f64>) -> Option<Pose> {
    let t = base_from.translation.vector;
    let q = UnitQuaternion::from_rotation_matrix(&base_from.rotation);
    Some(Pose {
        position: Some(Vector3 { x: t.x, y: t.y, z: t.z }),
        orientation: Some(Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }),
    })
}

fn size(primitive: &Primitive) -> Option<Vector3> {
    let [x, y, z] = primitive.size_m;
    Some(Vector3 { x, y, z })
}

fn entity(id: String, stamp_ns: u64, metadata: Vec<KeyValuePair>) -> SceneEntity {
    SceneEntity {
        timestamp: timestamp(stamp_ns),
        frame_id: BASE_FRAME.to_string(),
        id,
        lifetime: None,
        frame_locked: false,
        metadata,
        ..SceneEntity::default()
    }
}

/// An obstacle: its primitives, translucent, and its name above its centre.
fn obstacle_entity(obstacle: &Obstacle, nearness: Nearness, stamp_ns: u64) -> SceneEntity {
    let metadata = vec![KeyValuePair { key: "name".into(), value: obstacle.name.clone() }];
    let mut drawn = entity(format!("obstacle/{}", obstacle.name), stamp_ns, metadata);
    let color = nearness.color(0.45);
    for primitive in obstacle.primitives() {
        let pose = pose(&primitive.base_from_centre);
        match primitive.kind {
            PrimitiveKind::Cube => drawn.cubes.push(CubePrimitive { pose, size: size(&primitive), color }),
            PrimitiveKind::Cylinder => drawn.cylinders.push(CylinderPrimitive {
                pose,
                size: size(&primitive),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color,
            }),
            PrimitiveKind::Sphere => {
                drawn.spheres.push(SpherePrimitive { pose, size: size(&primitive), color })
            }
        }
    }
    drawn.texts.push(TextPrimitive {
        pose: pose(&obstacle.base_from_obstacle),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: nearness.color(1.0),
        text: obstacle.name.clone(),
    });
    drawn
}

/// The workspace: its box's twelve edges as lines.
fn workspace_entity(workspace: &Workspace, nearness: Nearness, stamp_ns: u64) -> SceneEntity {
    let mut drawn = entity(WORKSPACE_NAME.to_string(), stamp_ns, Vec::new());
    let points = workspace
        .primitive()
        .edges()
        .into_iter()
        .flatten()
        .map(|p| Point3 { x: p.x, y: p.y, z: p.z })
        .collect();
    drawn.lines.push(LinePrimitive {
        r#type: foxglove::messages::line_primitive::Type::LineList as i32,
        pose: pose(&IsometryMatrix3::identity()),
        thickness: 2.0,
        scale_invariant: true,
        points,
        color: nearness.color(1.0),
        colors: Vec::new(),
        indices: Vec::new(),
    });
    drawn
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_settings::collision::Solid;

    fn scene() -> GuardedScene {
        let table = Obstacle {
            name: "table".into(),
            solid: Solid::Box { size_m: [1.2, 0.8, 0.04] },
            base_from_obstacle: IsometryMatrix3::translation(0.5, 0.0, -0.02),
        };
        let post = Obstacle {
            name: "post".into(),
            solid: Solid::Capsule { radius_m: 0.05, length_m: 0.6 },
            base_from_obstacle: IsometryMatrix3::translation(-0.4, 0.3, 0.3),
        };
        GuardedScene {
            obstacles: vec![table, post],
            workspace: Some(Workspace { min_m: [-0.8, -0.8, 0.0], max_m: [0.8, 0.8, 1.2] }),
            slowdown_distance_m: 0.10,
            stop_distance_m: 0.03,
        }
    }

    #[test]
    fn each_obstacle_is_an_entity_of_its_solids_where_it_stands_and_the_workspace_its_edges() {
        let update = scene().update(None, 2_500_000_000);
        let ids: Vec<&str> = update.entities.iter().map(|e| e.id.as_str()).collect();
        assert_eq!(ids, ["obstacle/table", "obstacle/post", "workspace"]);
        let table = &update.entities[0];
        assert_eq!(table.frame_id, "base");
        assert_eq!(table.cubes.len(), 1);
        let cube = table.cubes[0];
        let size = cube.size.expect("size");
        assert_eq!((size.x, size.y, size.z), (1.2, 0.8, 0.04));
        let centre = cube.pose.and_then(|p| p.position).expect("position");
        assert_eq!((centre.x, centre.y, centre.z), (0.5, 0.0, -0.02));
        assert_eq!(table.texts[0].text, "table");
        let post = &update.entities[1];
        assert_eq!((post.cylinders.len(), post.spheres.len()), (1, 2), "a capsule: a cylinder and two balls");
        assert_eq!(update.entities[2].lines[0].points.len(), 24, "12 edges as a line list");
        let stamp = table.timestamp.expect("stamped");
        assert_eq!((stamp.sec(), stamp.nsec()), (2, 500_000_000));
    }

    #[test]
    fn the_nearest_obstacle_is_amber_within_the_slow_down_distance_and_red_at_the_stop_distance() {
        let scene = scene();
        let color = |nearest: Option<Nearest<'_>>, entity: usize| {
            scene.update(nearest, 0).entities[entity].texts.first().and_then(|t| t.color).expect("color")
        };
        let clear = color(None, 0);
        let slowing = color(Some(Nearest { between: "camera – table", distance_m: 0.06 }), 0);
        let stopping = color(Some(Nearest { between: "camera – table", distance_m: 0.02 }), 0);
        assert_eq!((clear.r, clear.g), (0.62, 0.64));
        assert_eq!((slowing.r, slowing.g), (1.0, 0.6));
        assert_eq!((stopping.r, stopping.g), (0.9, 0.12));
        // the other obstacle stays grey; a name is matched whole ("table" is not "tablet")
        assert_eq!(color(Some(Nearest { between: "camera – table", distance_m: 0.02 }), 1).r, 0.62);
        assert_eq!(color(Some(Nearest { between: "camera – tablet", distance_m: 0.02 }), 0).r, 0.62);
        let near_the_floor = Some(Nearest { between: "camera – workspace", distance_m: 0.05 });
        let workspace = scene.update(near_the_floor, 0);
        assert_eq!(workspace.entities[2].lines[0].color.expect("color").r, 1.0);
        // what the colours are, the workspace's included (it has no name drawn)
        assert_eq!(scene.nearnesses(near_the_floor), [Nearness::Clear, Nearness::Clear, Nearness::Slowing]);
    }
}
