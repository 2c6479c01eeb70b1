//! Object commands: the simulated board holds, jumps or circles. Checked here against the simulated cell's
//! limits (pure); the commander seals and publishes them to the plant.
//!
//! The limits are constants, not configuration keys: they bound a test command of the simulation (the
//! board leaves the camera's view beyond them), not anything a real cell does, and the simulated scenarios
//! set their own motion in `[scenario]`.

use nalgebra::Vector3;

/// The longest jump the simulated board makes on `object step` (m).
pub const MAX_OBJECT_STEP_M: f64 = 0.2;
/// The largest circle the simulated board follows on `object circle` (m).
pub const MAX_CIRCLE_RADIUS_M: f64 = 0.2;
/// The fastest the simulated board circles on `object circle` (rev/min).
pub const MAX_CIRCLE_REV_PER_MIN: f64 = 60.0;

/// What a client asks the simulated board to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObjectMotion {
    /// Stop where it is.
    Hold,
    /// Jump by this much (m, desired camera frame).
    Step(Vector3<f64>),
    /// Circle at this radius (m) and speed (rev/min).
    Circle {
        /// The radius (m).
        radius_m: f64,
        /// The speed (rev/min).
        rev_per_min: f64,
    },
}

impl std::fmt::Display for ObjectMotion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ObjectMotion::Hold => write!(f, "the board holds still"),
            ObjectMotion::Step(by) => write!(f, "the board jumps by {:?} m", [by.x, by.y, by.z]),
            ObjectMotion::Circle { radius_m, rev_per_min } => {
                write!(f, "the board circles: {radius_m} m at {rev_per_min} rev/min")
            }
        }
    }
}

/// Why an object command is refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ObjectRefused {
    /// An external robot: the board is not the daemon's to move.
    #[error("the board is the simulation's; with robot.driver = \"external\" there is none to move")]
    NotSimulated,
    /// A camera fixed in the world: the board rides on the tool, and only the arm moves it.
    #[error("the board rides on the tool (camera.mount = \"world\"): only the arm moves it")]
    OnTheTool,
    /// A number is NaN or infinite.
    #[error("a number is not finite")]
    NotFinite,
    /// The jump is too long.
    #[error("step: {jump_m:.3} m is more than the {MAX_OBJECT_STEP_M} m the simulated cell allows")]
    StepTooLong {
        /// Its length (m).
        jump_m: f64,
    },
    /// The circle is too large or too fast.
    #[error(
        "circle: radius {radius_m} m and speed {rev_per_min} rev/min must be within 0–{MAX_CIRCLE_RADIUS_M} m and 0–{MAX_CIRCLE_REV_PER_MIN} rev/min"
    )]
    CircleOutOfRange {
        /// The radius asked for (m).
        radius_m: f64,
        /// The speed asked for (rev/min).
        rev_per_min: f64,
    },
}

/// Checks `motion` for a cell whose robot is simulated (`simulated`) or not.
pub fn check(motion: &ObjectMotion, simulated: bool, on_the_tool: bool) -> Result<(), ObjectRefused> {
    if !simulated {
        return Err(ObjectRefused::NotSimulated);
    }
    if on_the_tool && *motion != ObjectMotion::Hold {
        return Err(ObjectRefused::OnTheTool);
    }
    match *motion {
        ObjectMotion::Hold => Ok(()),
        ObjectMotion::Step(by) if !by.iter().all(|v| v.is_finite()) => Err(ObjectRefused::NotFinite),
        ObjectMotion::Step(by) if by.norm() > MAX_OBJECT_STEP_M => {
            Err(ObjectRefused::StepTooLong { jump_m: by.norm() })
        }
        ObjectMotion::Step(_) => Ok(()),
        ObjectMotion::Circle { radius_m, rev_per_min } => {
            if !(radius_m.is_finite() && rev_per_min.is_finite()) {
                return Err(ObjectRefused::NotFinite);
            }
            if !(0.0..=MAX_CIRCLE_RADIUS_M).contains(&radius_m)
                || !(0.0..=MAX_CIRCLE_REV_PER_MIN).contains(&rev_per_min)
            {
                return Err(ObjectRefused::CircleOutOfRange { radius_m, rev_per_min });
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simulated_board_moves_within_its_limits_only() {
        assert_eq!(check(&ObjectMotion::Hold, true, false), Ok(()));
        assert_eq!(check(&ObjectMotion::Hold, false, false), Err(ObjectRefused::NotSimulated));
        assert_eq!(check(&ObjectMotion::Step(Vector3::new(0.2, 0.0, 0.0)), true, false), Ok(()));
        assert!(matches!(
            check(&ObjectMotion::Step(Vector3::new(0.0, 1.0, 0.0)), true, false),
            Err(ObjectRefused::StepTooLong { jump_m }) if jump_m == 1.0
        ));
        assert_eq!(
            check(&ObjectMotion::Step(Vector3::new(f64::NAN, 0.0, 0.0)), true, false),
            Err(ObjectRefused::NotFinite)
        );
        let circle =
            |radius_m, rev_per_min| check(&ObjectMotion::Circle { radius_m, rev_per_min }, true, false);
        assert_eq!(circle(0.1, 60.0), Ok(()));
        assert!(matches!(circle(5.0, 1.0), Err(ObjectRefused::CircleOutOfRange { .. })));
        assert!(matches!(circle(0.1, 1000.0), Err(ObjectRefused::CircleOutOfRange { .. })));
        assert!(matches!(circle(-0.1, 1.0), Err(ObjectRefused::CircleOutOfRange { .. })));
        assert_eq!(circle(0.1, f64::INFINITY), Err(ObjectRefused::NotFinite));
    }

    #[test]
    fn a_board_on_the_tool_is_moved_by_the_arm_only() {
        let step = ObjectMotion::Step(Vector3::new(0.02, 0.0, 0.0));
        assert_eq!(check(&step, true, true), Err(ObjectRefused::OnTheTool));
        let circle = ObjectMotion::Circle { radius_m: 0.05, rev_per_min: 10.0 };
        assert_eq!(check(&circle, true, true), Err(ObjectRefused::OnTheTool));
        // holding still is what it does anyway
        assert_eq!(check(&ObjectMotion::Hold, true, true), Ok(()));
        assert!(ObjectRefused::OnTheTool.to_string().contains("camera.mount"));
    }
}
