//! The solids a cell is made of, as the configuration and a URDF describe them, and their form for the distance
//! queries (parry3d's shapes, placed by its poses).

use nalgebra::{UnitQuaternion, Vector3};
use parry3d_f64::math::{Pose3, Rot3, Vec3};
use parry3d_f64::shape::SharedShape;

use vservo_arm::Transform;
pub use vservo_settings::collision::Solid;

/// The shape for the distance queries of `solid` and where it sits in the solid's frame (parry's cylinders lie
/// along y), or why the solid has no volume.
pub fn shape_of(solid: &Solid) -> Result<(SharedShape, Transform), String> {
    let along_y_to_z = Transform::from_parts(
        nalgebra::Translation3::identity(),
        nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2),
    );
    match *solid {
        Solid::Box { size_m } => {
            positive("box size_m", &size_m)?;
            Ok((
                SharedShape::cuboid(size_m[0] / 2.0, size_m[1] / 2.0, size_m[2] / 2.0),
                Transform::identity(),
            ))
        }
        Solid::Cylinder { radius_m, length_m } => {
            positive("cylinder radius_m and length_m", &[radius_m, length_m])?;
            Ok((SharedShape::cylinder(length_m / 2.0, radius_m), along_y_to_z))
        }
        Solid::Capsule { radius_m, length_m } => {
            positive("capsule radius_m", &[radius_m])?;
            if !(length_m.is_finite() && length_m >= 0.0) {
                return Err(format!("capsule length_m must be finite and not negative, not {length_m}"));
            }
            Ok((SharedShape::capsule_z(length_m / 2.0, radius_m), Transform::identity()))
        }
        Solid::Sphere { radius_m } => {
            positive("sphere radius_m", &[radius_m])?;
            Ok((SharedShape::ball(radius_m), Transform::identity()))
        }
        Solid::HalfSpace => Ok((SharedShape::halfspace(Vec3::Z), Transform::identity())),
    }
}

/// `Err` unless every value is finite and above zero.
fn positive(what: &str, values: &[f64]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite() && *v > 0.0) {
        Ok(())
    } else {
        Err(format!("{what} must be finite and above zero, not {values:?}"))
    }
}

/// A rigid transform as the distance queries take it.
pub fn pose_of(transform: &Transform) -> Pose3 {
    let rotation = UnitQuaternion::from_rotation_matrix(&transform.rotation);
    let q = rotation.quaternion();
    let t = transform.translation.vector;
    Pose3::from_parts(Vec3::new(t.x, t.y, t.z), Rot3::from_xyzw(q.i, q.j, q.k, q.w).normalize())
}

/// A point or vector of the distance queries in nalgebra's form.
pub fn vector_of(v: Vec3) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}
