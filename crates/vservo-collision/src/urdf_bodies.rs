//! The arm's collision bodies from its URDF: each link's `<collision>` elements (boxes, cylinders, capsules,
//! spheres, and meshes kept as their convex hulls) on the frame that carries it.
//!
//! A link rides on the chain link of the nearest moving chain joint above it: links joined by fixed joints ride
//! together, and so do links behind a joint that is not on the chain (a gripper's fingers), held at zero.

use std::path::Path;

use nalgebra::{Rotation3, Translation3};
use parry3d_f64::shape::SharedShape;
use vservo_arm::{Chain, Transform};

use crate::error::GeometryError;
use crate::mesh;
use crate::shape::Solid;

/// What a body is, for the pairs that are checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyKind {
    /// A link of the arm (or what rides on it, as the camera does).
    Arm,
    /// Something in the cell that does not move with the arm.
    Obstacle,
}

/// A rigid body of the cell: shapes on one carrier frame.
#[derive(Clone)]
pub struct BodySpec {
    /// The URDF link's name, `"camera"`, or the obstacle's name.
    pub name: String,
    /// An arm body or an obstacle.
    pub kind: BodyKind,
    /// The frame it rides on: 0 is the base, which does not move; `k ≥ 1` is the link the chain's joint `k − 1`
    /// moves (the tool's frame on an arm without a chain).
    pub carrier: usize,
    /// The body's frame in its carrier's.
    pub carrier_from_body: Transform,
    /// Its shapes, each with its place in the body's frame.
    pub shapes: Vec<(SharedShape, Transform)>,
}

impl std::fmt::Debug for BodySpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BodySpec")
            .field("name", &self.name)
            .field("kind", &self.kind)
            .field("carrier", &self.carrier)
            .field("shapes", &self.shapes.len())
            .finish()
    }
}

/// The collision bodies of the links at and below `chain.base_link` in the URDF at `path`, one per link that
/// has `<collision>` elements, for the chain read from the same file.
pub fn arm_bodies(path: &Path, chain: &Chain) -> Result<Vec<BodySpec>, GeometryError> {
    let text = std::fs::read_to_string(path).map_err(|e| vservo_arm::urdf::UrdfError::Read {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    vservo_arm::urdf_bounds::check(&text).map_err(|bound| vservo_arm::urdf::UrdfError::OutOfBounds {
        path: path.display().to_string(),
        bound,
    })?;
    let robot = urdf_rs::read_from_string(&text).map_err(|e| vservo_arm::urdf::UrdfError::Read {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let urdf_dir = path.parent().unwrap_or(Path::new("."));
    let mut bodies = Vec::new();
    for (link_name, carrier, carrier_from_link) in links_on_carriers(&robot, chain) {
        let Some(link) = robot.links.iter().find(|l| l.name == link_name) else { continue };
        if link.collision.is_empty() {
            continue;
        }
        let shapes = link
            .collision
            .iter()
            .map(|collision| link_shape(collision, urdf_dir, &link.name))
            .collect::<Result<Vec<_>, _>>()?;
        bodies.push(BodySpec {
            name: link.name.clone(),
            kind: BodyKind::Arm,
            carrier,
            carrier_from_body: carrier_from_link,
            shapes,
        });
    }
    Ok(bodies)
}

/// Every link at and below the chain's base link, with its carrier and its frame in the carrier's.
fn links_on_carriers(robot: &urdf_rs::Robot, chain: &Chain) -> Vec<(String, usize, Transform)> {
    let mut found = Vec::new();
    let mut stack = vec![(chain.base_link.clone(), 0, Transform::identity())];
    while let Some((link, carrier, carrier_from_link)) = stack.pop() {
        for joint in robot.joints.iter().filter(|j| j.parent.link == link) {
            let on_chain = chain.joints.iter().position(|c| c.name == joint.name);
            let child = match on_chain {
                Some(k) => (joint.child.link.clone(), k + 1, Transform::identity()),
                None => (joint.child.link.clone(), carrier, carrier_from_link * origin_of(&joint.origin)),
            };
            // a malformed tree (a link that is its own ancestor) was refused when the chain was read; a bound
            // keeps this walk finite all the same
            if found.len() + stack.len() < robot.links.len() {
                stack.push(child);
            }
        }
        found.push((link, carrier, carrier_from_link));
    }
    found
}

/// One `<collision>` element's shape and its place in the link's frame.
fn link_shape(
    collision: &urdf_rs::Collision,
    urdf_dir: &Path,
    link: &str,
) -> Result<(SharedShape, Transform), GeometryError> {
    let link_from_element = origin_of(&collision.origin);
    let solid = match &collision.geometry {
        urdf_rs::Geometry::Box { size } => Solid::Box { size_m: size.0 },
        urdf_rs::Geometry::Cylinder { radius, length } => {
            Solid::Cylinder { radius_m: *radius, length_m: *length }
        }
        urdf_rs::Geometry::Capsule { radius, length } => {
            Solid::Capsule { radius_m: *radius, length_m: *length }
        }
        urdf_rs::Geometry::Sphere { radius } => Solid::Sphere { radius_m: *radius },
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let path = mesh::locate(urdf_dir, filename, link)?;
            let scale = scale.map_or([1.0; 3], |s| s.0);
            if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                return Err(GeometryError::BadShape {
                    body: link.to_string(),
                    why: format!("mesh {filename:?}: scale {scale:?} must be finite and not zero"),
                });
            }
            return Ok((mesh::convex_hull(&path, scale, link)?, link_from_element));
        }
    };
    let (shape, element_from_shape) = crate::shape::shape_of(&solid)
        .map_err(|why| GeometryError::BadShape { body: link.to_string(), why })?;
    Ok((shape, link_from_element * element_from_shape))
}

/// A URDF `<origin>` as a transform (rpy: R = Rz(yaw)·Ry(pitch)·Rx(roll)).
fn origin_of(pose: &urdf_rs::Pose) -> Transform {
    let [x, y, z] = pose.xyz.0;
    let [roll, pitch, yaw] = pose.rpy.0;
    Transform::from_parts(Translation3::new(x, y, z), Rotation3::from_euler_angles(roll, pitch, yaw))
}
