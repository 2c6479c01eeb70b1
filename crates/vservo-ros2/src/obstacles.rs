//! The collision guard's scene as ROS 2 markers (`vservo/obstacles`, `visualization_msgs/MarkerArray`,
//! transient local, made once): each obstacle of `[[scene.obstacles]]` as cubes, cylinders and balls in the
//! arm's base frame, a namespace per obstacle with its name as a text above it, and the workspace box as a line
//! list. A first marker `DELETEALL` clears what an earlier run of the bridge left in a viewer.

use nalgebra::{IsometryMatrix3, UnitQuaternion};
use vservo_config::{Collision, Obstacle, Primitive, PrimitiveKind};

use crate::msg::{ColorRgba, Header, Marker, MarkerArray, Point, Pose, Quaternion, Time, Vector3};

/// The namespace of the workspace box's marker.
pub const WORKSPACE_NAMESPACE: &str = "workspace";
/// The obstacles' colour (translucent grey).
const OBSTACLE_COLOR: ColorRgba = ColorRgba { r: 0.62, g: 0.64, b: 0.68, a: 0.45 };
/// The names' and the workspace's colour.
const LINE_COLOR: ColorRgba = ColorRgba { r: 0.9, g: 0.9, b: 0.9, a: 1.0 };
/// The workspace's lines' width (m).
const LINE_WIDTH_M: f64 = 0.005;
/// The names' height (m).
const TEXT_HEIGHT_M: f64 = 0.05;

/// The markers of the guard's scene, in `base` (the arm's base frame as ROS names it), stamped `stamp`.
pub fn markers(collision: &Collision, base: &str, stamp: Time) -> MarkerArray {
    let header = Header { stamp, frame_id: base.to_string() };
    let mut markers = vec![Marker { header: header.clone(), action: Marker::DELETEALL, ..Marker::default() }];
    for obstacle in &collision.obstacles {
        markers.extend(obstacle_markers(obstacle, &header));
    }
    if let Some(workspace) = &collision.workspace {
        markers.push(workspace_marker(&workspace.primitive(), &header));
    }
    MarkerArray { markers }
}

fn pose(base_from: &IsometryMatrix3<f64>) -> Pose {
    let t = base_from.translation.vector;
    let q = UnitQuaternion::from_rotation_matrix(&base_from.rotation);
    Pose {
        position: Point { x: t.x, y: t.y, z: t.z },
        orientation: Quaternion { x: q.i, y: q.j, z: q.k, w: q.w },
    }
}

/// An obstacle: a marker per primitive (ids 0, 1, …), then its name (the next id), in its own namespace.
fn obstacle_markers(obstacle: &Obstacle, header: &Header) -> Vec<Marker> {
    let primitives = obstacle.primitives();
    let mut markers: Vec<Marker> = primitives
        .iter()
        .enumerate()
        .map(|(id, primitive)| {
            let [x, y, z] = primitive.size_m;
            Marker {
                header: header.clone(),
                ns: obstacle.name.clone(),
                id: id as i32,
                kind: match primitive.kind {
                    PrimitiveKind::Cube => Marker::CUBE,
                    PrimitiveKind::Cylinder => Marker::CYLINDER,
                    PrimitiveKind::Sphere => Marker::SPHERE,
                },
                action: Marker::ADD,
                pose: pose(&primitive.base_from_centre),
                scale: Vector3 { x, y, z },
                color: OBSTACLE_COLOR,
                ..Marker::default()
            }
        })
        .collect();
    markers.push(Marker {
        header: header.clone(),
        ns: obstacle.name.clone(),
        id: primitives.len() as i32,
        kind: Marker::TEXT_VIEW_FACING,
        action: Marker::ADD,
        pose: pose(&obstacle.base_from_obstacle),
        scale: Vector3 { x: 0.0, y: 0.0, z: TEXT_HEIGHT_M },
        color: LINE_COLOR,
        text: obstacle.name.clone(),
        ..Marker::default()
    });
    markers
}

/// The workspace box's twelve edges.
fn workspace_marker(workspace: &Primitive, header: &Header) -> Marker {
    let points = workspace.edges().into_iter().flatten().map(|p| Point { x: p.x, y: p.y, z: p.z }).collect();
    Marker {
        header: header.clone(),
        ns: WORKSPACE_NAMESPACE.to_string(),
        id: 0,
        kind: Marker::LINE_LIST,
        action: Marker::ADD,
        pose: pose(&IsometryMatrix3::identity()),
        scale: Vector3 { x: LINE_WIDTH_M, y: 0.0, z: 0.0 },
        color: LINE_COLOR,
        points,
        ..Marker::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_config::{Solid, Workspace};

    fn collision() -> Collision {
        Collision {
            slowdown_distance_m: 0.1,
            stop_distance_m: 0.03,
            disabled_pairs: Vec::new(),
            arm_urdf: None,
            camera_box: None,
            workspace: Some(Workspace { min_m: [-1.0, -1.0, 0.0], max_m: [1.0, 1.0, 1.5] }),
            obstacles: vec![
                Obstacle {
                    name: "table".into(),
                    solid: Solid::Box { size_m: [1.2, 0.8, 0.04] },
                    base_from_obstacle: IsometryMatrix3::translation(0.6, 0.0, -0.02),
                },
                Obstacle {
                    name: "post".into(),
                    solid: Solid::Capsule { radius_m: 0.05, length_m: 0.5 },
                    base_from_obstacle: IsometryMatrix3::translation(-0.3, 0.4, 0.25),
                },
            ],
            board: false,
        }
    }

    #[test]
    fn each_obstacle_is_its_primitives_and_its_name_in_a_namespace_of_its_own() {
        let array = markers(&collision(), "base_link", Time { sec: 4, nanosec: 5 });
        let kinds: Vec<(&str, i32, i32)> =
            array.markers.iter().map(|m| (m.ns.as_str(), m.id, m.kind)).collect();
        assert_eq!(
            kinds,
            [
                ("", 0, 0),
                ("table", 0, Marker::CUBE),
                ("table", 1, Marker::TEXT_VIEW_FACING),
                ("post", 0, Marker::CYLINDER),
                ("post", 1, Marker::SPHERE),
                ("post", 2, Marker::SPHERE),
                ("post", 3, Marker::TEXT_VIEW_FACING),
                ("workspace", 0, Marker::LINE_LIST),
            ]
        );
        assert_eq!(array.markers[0].action, Marker::DELETEALL);
        let table = &array.markers[1];
        assert_eq!(table.header.frame_id, "base_link");
        assert_eq!((table.scale.x, table.scale.y, table.scale.z), (1.2, 0.8, 0.04));
        assert_eq!((table.pose.position.x, table.pose.position.z), (0.6, -0.02));
        assert_eq!(array.markers[6].text, "post");
        assert_eq!(array.markers[7].points.len(), 24);
    }

    #[test]
    fn the_markers_serialize_to_cdr() {
        let array = markers(&collision(), "base", Time::default());
        let bytes = crate::schema::cdr(&array).expect("CDR");
        assert!(bytes.len() > 8 * 100, "{}", bytes.len());
    }
}
