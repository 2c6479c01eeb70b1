//! `[robot]`: which driver, the command it takes, its period and deadline, the camera's speed limits; and the
//! checks that span the robot and the camera.

use vservo_settings::simulation::PlantMode;

use super::checker::Checker;
use crate::raw::{RawArmPreset, RawRobot, RawRobotDriver, RawStart};
use crate::{CommandInterface, ConfigError, PlantSettings, Robot, RobotDriver, Timing, VisionSource};

/// The robot. The simulated driver's command follows from `plant.mode` (dynamic: torque; kinematic:
/// position, the ideal robot), and it runs at the control period.
pub fn robot(
    check: &Checker,
    r: &RawRobot,
    plant: &PlantSettings,
    timing: &Timing,
) -> Result<Robot, ConfigError> {
    let command = command(check, r, plant)?;
    let period_s = period_s(check, r, timing)?;
    let state_timeout_periods = check.whole(
        "robot.state_timeout_periods",
        r.state_timeout_periods,
        2u32,
        1000,
        "must be from 2 to 1000 driver periods",
    )?;
    let max_camera_speed_m_s =
        check.within("robot.max_camera_speed_m_s", r.max_camera_speed_m_s, 0.001, 10.0, "m/s")?;
    let max_camera_rotation_rad_s =
        check.within("robot.max_camera_rotation_rad_s", r.max_camera_rotation_rad_s, 0.001, 20.0, "rad/s")?;
    Ok(Robot {
        driver: driver(r.driver),
        start_held: start_held(r),
        command,
        period_s,
        state_timeout_periods,
        max_camera_speed_m_s,
        max_camera_rotation_rad_s,
    })
}

/// Who drives the arm.
fn driver(raw: RawRobotDriver) -> RobotDriver {
    match raw {
        RawRobotDriver::Simulated => RobotDriver::Simulated,
        RawRobotDriver::External => RobotDriver::External,
        RawRobotDriver::Ros2 => RobotDriver::Ros2,
        RawRobotDriver::Franka => RobotDriver::Franka,
    }
}

/// `robot.start`: as written, else held for an external driver (a real arm's first motion waits for
/// `vservoctl resume`) and servoing for the simulated one.
fn start_held(r: &RawRobot) -> bool {
    match r.start {
        Some(start) => start == RawStart::Held,
        None => r.driver != RawRobotDriver::Simulated,
    }
}

/// `robot.command`: the simulated driver's follows from the plant (a declaration must agree); an external
/// driver must declare one; a ros2_control forward controller takes velocities or positions.
fn command(check: &Checker, r: &RawRobot, plant: &PlantSettings) -> Result<CommandInterface, ConfigError> {
    match r.driver {
        RawRobotDriver::Simulated => {
            let simulated = match plant.mode {
                PlantMode::Dynamic => CommandInterface::Torque,
                PlantMode::Kinematic => CommandInterface::Position,
            };
            match r.command.filter(|declared| *declared != simulated) {
                Some(declared) => Err(check.invalid(
                    "robot.command",
                    format!("{:?}", declared.name()),
                    format!(
                        "the simulated driver with plant.mode = {:?} takes {:?}; leave robot.command out",
                        plant.mode.name(),
                        simulated.name()
                    ),
                )),
                None => Ok(simulated),
            }
        }
        RawRobotDriver::Ros2 => match r.command {
            Some(CommandInterface::Torque) => Err(check.invalid(
                "robot.command",
                "\"torque\"",
                "the ROS 2 driver commands a ros2_control forward controller of velocities or positions: \
                 \"velocity\" or \"position\"",
            )),
            declared => Ok(declared.unwrap_or(CommandInterface::Velocity)),
        },
        RawRobotDriver::Franka => match r.command {
            None | Some(CommandInterface::Velocity) => Ok(CommandInterface::Velocity),
            Some(declared) => Err(check.invalid(
                "robot.command",
                format!("{:?}", declared.name()),
                "the Franka driver runs a joint-velocity motion: \"velocity\" (or leave it out)",
            )),
        },
        RawRobotDriver::External => r.command.ok_or_else(|| {
            check.invalid(
                "robot.command",
                "(missing)",
                "an external driver must declare the command it takes: \"torque\", \"velocity\" or \"position\"",
            )
        }),
    }
}

/// `robot.period_s`: an external driver's, 10 kHz to 10 Hz; the simulated driver's is the control period.
/// The Franka's FCI sends a robot state every millisecond.
const FRANKA_PERIOD_S: f64 = 0.001;

fn period_s(check: &Checker, r: &RawRobot, timing: &Timing) -> Result<f64, ConfigError> {
    match (r.driver, r.period_s) {
        (RawRobotDriver::Simulated, Some(p)) if p != timing.control_period_s => Err(check.invalid(
            "robot.period_s",
            p,
            format!(
                "the simulated driver runs at timing.control_period_s ({} s); leave it out",
                timing.control_period_s
            ),
        )),
        (RawRobotDriver::Franka, Some(p)) if p != FRANKA_PERIOD_S => Err(check.invalid(
            "robot.period_s",
            p,
            "the Franka's FCI runs at 1 kHz: 0.001 s (or leave it out)",
        )),
        (RawRobotDriver::Franka, _) => Ok(FRANKA_PERIOD_S),
        (_, Some(p)) => {
            let p = check.positive("robot.period_s", p)?;
            if !(1e-4..=0.1).contains(&p) {
                return Err(check.invalid(
                    "robot.period_s",
                    p,
                    "must be from 0.0001 to 0.1 s (10 kHz to 10 Hz)",
                ));
            }
            Ok(p)
        }
        (_, None) => Ok(timing.control_period_s),
    }
}

/// What the simulated driver and camera can do: the PUMA 560's dynamics, any other arm's kinematics, and a
/// simulated world the simulated camera sees, which an external driver has none of (but for franka-sim:
/// `simulator`, whose arm the simulated camera sees by its measured joints). An arm without a dynamics model
/// cannot take torques.
pub fn driver_and_camera_agree(
    check: &Checker,
    r: &RawRobot,
    robot: &Robot,
    (source, simulator): (&VisionSource, bool),
) -> Result<(), ConfigError> {
    let preset = match r.arm.preset {
        RawArmPreset::Puma560 => "puma560",
        RawArmPreset::Custom => "custom",
        RawArmPreset::Urdf => "urdf",
    };
    if robot.driver == RobotDriver::Simulated
        && r.arm.preset != RawArmPreset::Puma560
        && robot.command == CommandInterface::Torque
    {
        return Err(check.invalid(
            "plant.mode",
            "\"dynamic\"",
            format!(
                "the simulated driver simulates the PUMA 560's dynamics only; robot.arm.preset = {preset:?} is simulated kinematically: set plant.mode = \"kinematic\""
            ),
        ));
    }
    if r.arm.preset == RawArmPreset::Urdf && robot.command == CommandInterface::Torque {
        return Err(check.invalid(
            "robot.command",
            "\"torque\"",
            "an arm from a URDF has no dynamics model in vservo: its driver must take \"velocity\" or \"position\"",
        ));
    }
    // franka-sim, not a robot: vservo's simulated camera renders the board from the arm's measured joints
    let simulated_franka = r.driver == RawRobotDriver::Franka && simulator;
    if *source == VisionSource::Simulated && !robot.driver.is_simulated() && !simulated_franka {
        return Err(check.invalid(
            "camera.source",
            "\"simulated\"",
            "the simulated camera sees the simulated world, which an external robot driver has none of; set camera.source = \"external\" (a camera driver), \"ros2\" (a ROS camera) or robot.driver = \"simulated\"",
        ));
    }
    Ok(())
}
