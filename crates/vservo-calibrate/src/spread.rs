//! Whether a set of arm poses can determine the hand-eye transform. AX = XB fixes the transform's rotation only
//! from tool motions about at least two non-parallel axes, and its translation only then too (Tsai and Lenz,
//! 1989): poses whose relative rotations all turn about one axis leave the transform free along it. Checked on
//! the plan before anything moves, and on the joints actually measured before solving.

use nalgebra::{Rotation3, Vector3};
use vservo_scene::IsometryMatrix3;

/// Fewer poses than this cannot be calibrated (Zhang's method and AX = XB both want many views).
pub const MIN_POSES: usize = 6;
/// A relative rotation smaller than this says nothing about its axis (rad).
const MIN_ROTATION_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// The relative rotations' axes must spread over at least this angle (rad).
pub const MIN_AXIS_SPREAD_RAD: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// Why a set of poses cannot determine the calibration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpreadRefused {
    /// Too few poses.
    #[error("{poses} poses are too few; at least {MIN_POSES} are needed")]
    TooFewPoses {
        /// Poses given.
        poses: usize,
    },
    /// The tool hardly turns between the poses.
    #[error(
        "the tool turns less than 5° between any two poses: AX = XB needs rotations about two axes at least"
    )]
    TooLittleRotation,
    /// Every relative rotation turns about nearly one axis.
    #[error(
        "the rotation axes are too parallel: every rotation between two poses turns within {spread_deg:.1}° of one axis (tool frame [{axis_x:.2}, {axis_y:.2}, {axis_z:.2}]); AX = XB needs axes {min_deg:.0}° apart or more"
    )]
    AxesTooParallel {
        /// The widest angle between two relative rotations' axes (°).
        spread_deg: f64,
        /// The common axis, in the tool frame.
        axis_x: f64,
        /// y.
        axis_y: f64,
        /// z.
        axis_z: f64,
        /// The least spread accepted (°).
        min_deg: f64,
    },
}

/// Checks the tool poses (`base_from_tool`, in the order taken): enough of them, and rotations between them
/// about axes spread by [`MIN_AXIS_SPREAD_RAD`] or more. Returns the spread (rad).
pub fn check(base_from_tool: &[IsometryMatrix3<f64>]) -> Result<f64, SpreadRefused> {
    if base_from_tool.len() < MIN_POSES {
        return Err(SpreadRefused::TooFewPoses { poses: base_from_tool.len() });
    }
    let axes = relative_axes(base_from_tool);
    let Some(first) = axes.first() else { return Err(SpreadRefused::TooLittleRotation) };
    // the widest angle between two axes (a line's direction: ±a is the same axis)
    let mut spread = 0.0f64;
    for (i, a) in axes.iter().enumerate() {
        for b in &axes[i + 1..] {
            spread = spread.max(a.dot(b).abs().min(1.0).acos());
        }
    }
    if spread < MIN_AXIS_SPREAD_RAD {
        return Err(SpreadRefused::AxesTooParallel {
            spread_deg: spread.to_degrees(),
            axis_x: first.x,
            axis_y: first.y,
            axis_z: first.z,
            min_deg: MIN_AXIS_SPREAD_RAD.to_degrees(),
        });
    }
    Ok(spread)
}

/// The axes (unit, in the tool frame of the first pose of each pair: A's axes in AX = XB) of the rotations between every two poses
/// that turn by [`MIN_ROTATION_RAD`] or more.
fn relative_axes(base_from_tool: &[IsometryMatrix3<f64>]) -> Vec<Vector3<f64>> {
    let mut axes = Vec::new();
    for (i, a) in base_from_tool.iter().enumerate() {
        for b in &base_from_tool[i + 1..] {
            let relative: Rotation3<f64> = a.rotation.inverse() * b.rotation;
            if let Some((axis, angle)) = relative.axis_angle()
                && angle >= MIN_ROTATION_RAD
            {
                axes.push(axis.into_inner());
            }
        }
    }
    axes
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, Unit};

    fn pose(axis: Vector3<f64>, angle: f64, x: f64) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(
            Translation3::new(x, 0.1, 0.4),
            Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle),
        )
    }

    #[test]
    fn rotations_about_one_axis_are_refused_naming_it() {
        let about_z: Vec<_> = (0..12).map(|k| pose(Vector3::z(), 0.2 * k as f64, 0.01 * k as f64)).collect();
        match check(&about_z) {
            Err(SpreadRefused::AxesTooParallel { spread_deg, axis_z, .. }) => {
                assert!(spread_deg < 1e-6 && (axis_z.abs() - 1.0).abs() < 1e-9, "{spread_deg} {axis_z}");
            }
            other => panic!("expected a refusal, got {other:?}"),
        }
        let still: Vec<_> = (0..8).map(|k| pose(Vector3::z(), 0.01 * k as f64, 0.0)).collect();
        assert_eq!(check(&still), Err(SpreadRefused::TooLittleRotation));
        assert_eq!(check(&about_z[..5]), Err(SpreadRefused::TooFewPoses { poses: 5 }));
    }

    #[test]
    fn rotations_about_two_axes_pass() {
        let mut poses: Vec<_> = (0..6).map(|k| pose(Vector3::z(), 0.2 * k as f64, 0.0)).collect();
        poses.push(pose(Vector3::x(), 0.3, 0.0));
        let spread = check(&poses).expect("two axes");
        assert!(spread > 1.0, "{spread}");
    }
}
