//! The plant stage: the simulated arm and the board it looks at.

use nalgebra::Vector3;
use vservo_arm::{JointVector, SerialArm};
use vservo_config::CellConfig;
use vservo_scene::IsometryMatrix3;
use vservo_sim::interpolator::Reference;
use vservo_sim::joint_servo::JointServo;
use vservo_sim::plant::{JointState, Plant, PlantMode};
use vservo_sim::world::ObjectMotion;

use crate::ActuatorCommand;

/// Below this speed (rad/s) on every joint, a braking drive locks where the arm is.
const LOCKS_BELOW_RAD_S: f64 = 0.01;

/// The reference a command was computed on, q_d at the end of its period and q̇_d over it (the joint command's
/// `q_ref_rad` and `qd_ref_rad_s`): what the drive's own servo follows over a period whose answer came late.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandReference {
    /// q_d (rad).
    pub q: JointVector,
    /// q̇_d (rad/s).
    pub qd: JointVector,
}

/// The simulated PUMA 560 and its world, one tick at a time.
#[derive(Debug, Clone)]
pub struct PlantStage {
    plant: Plant,
    control_period_s: f64,
    object: ObjectMotion,
    /// Where the current motion starts (desired camera frame, m) and when (simulated s).
    object_origin_m: Vector3<f64>,
    object_since_s: f64,
    base_from_desired_camera: IsometryMatrix3<f64>,
    base_from_board_desired: IsometryMatrix3<f64>,
    /// With a fixed camera, the board on the tool (it moves with the arm; no scenario moves it).
    tool_from_board: Option<IsometryMatrix3<f64>>,
    /// The drive's own servo, used only to hold the arm when no command comes (a brake).
    holding_servo: JointServo,
    held_at: Option<JointVector>,
}

impl PlantStage {
    pub(crate) fn new(
        config: &CellConfig,
        arm: SerialArm,
        q: JointVector,
        tick: u64,
        base_from_desired_camera: IsometryMatrix3<f64>,
        base_from_board_desired: IsometryMatrix3<f64>,
    ) -> Self {
        let holding_servo = JointServo::new(
            arm.clone(),
            config.joint_servo.law,
            config.joint_servo.kp,
            config.joint_servo.kv,
        );
        Self {
            plant: Plant::new(arm, config.plant.mode, config.plant.rk4_substeps, q)
                .with_kinematic_response(config.plant.kinematic)
                .starting_at_tick(tick),
            control_period_s: config.timing.control_period_s,
            object: config.scenario.object,
            object_origin_m: Vector3::zeros(),
            object_since_s: 0.0,
            base_from_desired_camera,
            base_from_board_desired,
            tool_from_board: config.fixed_camera.map(|fixed| fixed.tool_from_board),
            holding_servo,
            held_at: None,
        }
    }

    /// The state after the last tick.
    pub fn state(&self) -> &JointState {
        self.plant.state()
    }

    /// The simulated arm.
    pub fn arm(&self) -> &vservo_arm::SerialArm {
        self.plant.arm()
    }

    /// The plant's mode.
    pub fn mode(&self) -> PlantMode {
        self.plant.mode()
    }

    /// Simulated time at the current tick (s).
    pub fn time_s(&self) -> f64 {
        self.plant.state().tick as f64 * self.control_period_s
    }

    /// The board's displacement from its desired-pose position at the current tick (desired camera frame).
    fn object_offset_m(&self) -> Vector3<f64> {
        self.object_origin_m + self.object.offset_in_desired_camera(self.time_s() - self.object_since_s)
    }

    /// Where the board is at the current tick, in the base frame: on the tool with a fixed camera.
    pub fn base_from_board(&self) -> IsometryMatrix3<f64> {
        if let Some(tool_from_board) = &self.tool_from_board {
            return self.plant.arm().base_from_tool(&self.plant.state().q) * tool_from_board;
        }
        let mut pose = self.base_from_board_desired;
        pose.translation.vector += self.base_from_desired_camera.rotation * self.object_offset_m();
        pose
    }

    /// From now on the board moves as `motion` says, starting where it is, with `motion`'s time counted from
    /// now (a `Step` at 0 s jumps at once).
    pub fn set_object_motion(&mut self, motion: ObjectMotion) {
        self.object_origin_m = self.object_offset_m();
        self.object_since_s = self.time_s();
        self.object = motion;
    }

    /// Whether the last tick held the arm instead of following a command.
    pub fn is_holding(&self) -> bool {
        self.held_at.is_some()
    }

    /// Advances one tick under a command from the rmrc. A command that does not fit the plant's mode (a
    /// torque for the kinematic plant, a reference for the dynamic one) is not applied: the arm is held.
    pub fn apply(&mut self, command: &ActuatorCommand) -> &JointState {
        match (self.plant.mode(), command) {
            (PlantMode::Dynamic, ActuatorCommand::Torque(torque)) => {
                self.held_at = None;
                self.plant.step_dynamic(torque, self.control_period_s)
            }
            (PlantMode::Kinematic, ActuatorCommand::Reference { q, qd }) => {
                self.held_at = None;
                self.plant.step_kinematic(q, qd, self.control_period_s)
            }
            _ => self.hold(),
        }
    }

    /// Advances one tick on a command that answered the state of `late_ticks` periods ago (its answer to this
    /// one came late): the drive's own servo follows that command's reference carried on at its speed. Never the
    /// command's torque again: it was computed for a state the arm has left, and a braking torque held on turns
    /// a joint back.
    pub fn follow_late(&mut self, reference: &CommandReference, late_ticks: u64) -> &JointState {
        self.held_at = None;
        let ahead_s = late_ticks as f64 * self.control_period_s;
        let q = reference.q + reference.qd * ahead_s;
        match self.plant.mode() {
            PlantMode::Kinematic => self.plant.step_kinematic(&q, &reference.qd, self.control_period_s),
            PlantMode::Dynamic => {
                let state = *self.plant.state();
                let torque =
                    self.holding_servo.torque(&state.q, &state.qd, &servo_reference(q, reference.qd));
                self.plant.step_dynamic(&torque, self.control_period_s)
            }
        }
    }

    /// Advances one tick with no command: the drives brake the arm to rest with the joint servo's damping (no
    /// pull back towards where commands stopped, which would turn a fast joint back), then hold it where it
    /// came to rest (a real drive's controller watchdog).
    pub fn hold(&mut self) -> &JointState {
        let state = *self.plant.state();
        let moving = state.qd.iter().any(|v| v.abs() >= LOCKS_BELOW_RAD_S);
        let held_at = match self.held_at {
            Some(_) if moving && self.plant.mode() == PlantMode::Dynamic => state.q,
            Some(at) => at,
            None => state.q,
        };
        self.held_at = Some(held_at);
        match self.plant.mode() {
            PlantMode::Kinematic => {
                self.plant.step_kinematic(&held_at, &JointVector::zeros(), self.control_period_s)
            }
            PlantMode::Dynamic => {
                let reference = servo_reference(held_at, JointVector::zeros());
                let torque = self.holding_servo.torque(&state.q, &state.qd, &reference);
                self.plant.step_dynamic(&torque, self.control_period_s)
            }
        }
    }
}

/// A reference for the drive's servo: at `q` with speed `qd`, not accelerating.
fn servo_reference(q: JointVector, qd: JointVector) -> Reference {
    Reference { q, qd, qdd: JointVector::zeros(), stopping: true, damped: false, velocity_limited: false }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Cell;

    #[test]
    fn a_new_object_motion_starts_where_the_board_is_and_when_it_is_set() {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default config loads")
                .cell;
        let cell = Cell::new(&config).expect("the default cell");
        let mut plant = cell.plant_resumed(cell.start_joints(), 1000);
        let desired_rotation = cell.base_from_desired_camera().rotation;
        let start = plant.base_from_board().translation.vector;
        let step = Vector3::new(0.0, 0.02, 0.0);
        plant.set_object_motion(ObjectMotion::Step { at_s: 0.0, translation_m: step });
        let after_step = plant.base_from_board().translation.vector;
        assert!((after_step - start - desired_rotation * step).norm() < 1e-12, "jumps by the step at once");
        // a circle from there: the same place at its start, then moving
        plant.set_object_motion(ObjectMotion::Circle { radius_m: 0.1, rev_per_min: 5.0 });
        assert!((plant.base_from_board().translation.vector - after_step).norm() < 1e-12);
        for _ in 0..100 {
            plant.hold();
        }
        let moved = plant.base_from_board().translation.vector - after_step;
        let expected = desired_rotation
            * ObjectMotion::Circle { radius_m: 0.1, rev_per_min: 5.0 }.offset_in_desired_camera(0.1);
        assert!((moved - expected).norm() < 1e-12, "{moved} vs {expected}");
    }

    #[test]
    fn the_drive_follows_a_late_reference_with_its_own_servo_and_brakes_to_rest_without_turning_back() {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default config loads")
                .cell;
        assert_eq!(config.plant.mode, PlantMode::Dynamic);
        let cell = Cell::new(&config).expect("the default cell");
        let start = *cell.start_joints();
        let mut plant = cell.plant_resumed(&start, 0);
        // a reference sweeping the waist and the shoulder at 1 rad/s, followed by the drive's servo alone
        let qd = JointVector::from_fn(|j, _| if j < 2 { 1.0 } else { 0.0 });
        for late in 1..=300 {
            let reference = CommandReference { q: start, qd };
            plant.follow_late(&reference, late);
            assert!(!plant.is_holding());
        }
        let moving = plant.state().qd;
        assert!((moving[0] - 1.0).abs() < 0.02 && (moving[1] - 1.0).abs() < 0.02, "{moving}");
        // then no command: braked to rest, never turned back, and held where it came to rest
        let mut slowest = f64::INFINITY;
        for _ in 0..300 {
            let qd = plant.hold().qd;
            assert!(plant.is_holding());
            slowest = slowest.min(qd[0]).min(qd[1]);
        }
        assert!(slowest > -0.002, "a joint turned back at {slowest} rad/s");
        let rest = *plant.state();
        assert!(rest.qd.iter().all(|v| v.abs() < LOCKS_BELOW_RAD_S), "{}", rest.qd);
        for _ in 0..100 {
            plant.hold();
        }
        // (a creep of a few 0.1 mrad stays: the drive's friction against the servo, as before)
        let moved = (plant.state().q - rest.q).norm();
        assert!(moved < 1e-3, "held where it came to rest: moved {moved} rad");
    }
}
