//! # vservo-lockstep — the whole loop on virtual time
//!
//! This crate owns the lockstep shell: simulated camera → extractor → (pipeline delay) → servo law →
//! interpolator → joint servo → plant, every component a pure step function, all on one virtual clock.
//! The same configuration gives the same bits; a 30 s experiment takes under a second.

use nalgebra::Vector3;
use vservo_arm::JointVector;
use vservo_config::Config;
use vservo_control::{Gains, Twist};
use vservo_scene::{FeatureVector, IsometryMatrix3};

pub use vservo_cell::CellError as SimError;
pub use vservo_cell::ServoVerdict;
use vservo_cell::{ActuatorCommand, Cell, PlantStage, RmrcStage, ServoInput, ServoStage, VisionStage};
use vservo_sim::plant::Faults;

/// One vision frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameRecord {
    /// Capture time (s).
    pub t_s: f64,
    /// The features extracted from this frame's image (NaN where a mark is not valid); the servo sees
    /// them `pipeline_delay_frames` later.
    pub measured: FeatureVector,
    /// The true projections of the disc centres at capture time.
    pub truth: FeatureVector,
    /// The twist the servo sent at this frame's time (from the features of `delay` frames before).
    pub twist: Twist,
    /// Why it sent that twist (`None` where not known: a frame rebuilt from a recording).
    pub verdict: Option<ServoVerdict>,
    /// The camera's position in the base frame at capture time (m).
    pub camera_position_m: Vector3<f64>,
    /// The camera's position in the desired camera frame at capture time (m): zero at the desired pose.
    pub camera_in_desired_m: Vector3<f64>,
}

/// The joints, every 10 ms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointRecord {
    /// Time (s).
    pub t_s: f64,
    /// Joint angles (rad).
    pub q: JointVector,
    /// Joint velocities (rad/s).
    pub qd: JointVector,
    /// Applied torques (N·m).
    pub torque: JointVector,
}

pub mod summary;

/// What a run produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// One record per vision frame.
    pub frames: Vec<FrameRecord>,
    /// One record per 10 ms.
    pub joints: Vec<JointRecord>,
    /// Every fault flag raised during the run, or-ed together.
    pub faults: Faults,
    /// ξ_d.
    pub desired_features: FeatureVector,
}

/// How many of the latest commands [`Lockstep::run_replaying`] keeps for a replayed late answer.
pub const REPLAY_COMMANDS: usize = 16;

/// The loop.
pub struct Lockstep {
    config: Config,
    cell: Cell,
    gains: Gains,
    plant: PlantStage,
    vision: VisionStage,
    servo: ServoStage,
    rmrc: RmrcStage,
    base_from_desired_camera: IsometryMatrix3<f64>,
}

impl Lockstep {
    /// Sets the loop up from a configuration (its `[plant]`, `[interpolator]`, `[joint_servo]` and
    /// `[scenario]` sections say what to simulate): designs the gains, places the arm by inverse kinematics.
    pub fn new(config: &Config) -> Result<Self, SimError> {
        let cell = Cell::simulated(config)?;
        Ok(Self {
            config: config.clone(),
            cell: cell.clone(),
            gains: cell.gains().clone(),
            plant: cell.plant(),
            vision: cell.vision(),
            servo: cell.servo(),
            rmrc: cell.rmrc(cell.start_joints()),
            base_from_desired_camera: *cell.base_from_desired_camera(),
        })
    }

    /// The designed gains.
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// Runs the scenario; `progress` is called with the simulated time at every vision frame.
    pub fn run(&mut self, progress: impl FnMut(f64)) -> Trace {
        self.run_replaying(progress, |_, frame_tick| frame_tick, Some, |_| false)
    }

    /// [`Lockstep::run`] with each twist taken in at a tick of the caller's choosing: `taken_at(delivered
    /// capture tick, frame tick)` says when the twist computed at `frame tick` (from the features of the image
    /// captured at `delivered capture tick`) reaches the interpolator; [`Lockstep::run`] takes it at once.
    /// This replays a real-time run's own answer latency (its joint commands carry the tick each twist was
    /// taken in), so that the two can be compared frame by frame. A tick earlier than the frame's counts as
    /// the frame's; a twist still waiting when the next one is computed is dropped, as the rmrc, draining
    /// both at once, would keep the newer.
    ///
    /// `applied(tick)` says which command the arm follows over the period from `tick`: `Some(tick)` the one
    /// computed now (as [`Lockstep::run`] does), `Some(older)` one computed at an earlier tick (of the last
    /// [`REPLAY_COMMANDS`]; a driver that kept its last command because the answer came late), `None` none
    /// (the plant holds the arm).
    ///
    /// `resynced(tick)` says whether the rmrc started again at rest from the measured joints at `tick` (a
    /// real-time rmrc does after a stall longer than `robot.state_timeout_periods`; its joint commands say
    /// from which tick their reference runs), dropping the twist it held.
    pub fn run_replaying(
        &mut self,
        progress: impl FnMut(f64),
        taken_at: impl FnMut(u64, u64) -> u64,
        applied: impl FnMut(u64) -> Option<u64>,
        resynced: impl FnMut(u64) -> bool,
    ) -> Trace {
        self.run_inner(progress, taken_at, applied, resynced, |_| false)
    }

    /// [`Lockstep::run`], ended early at the first frame for which `stop(frames so far)` says so (a Monte
    /// Carlo of starts stops a run once it has settled long enough).
    pub fn run_until(&mut self, stop: impl FnMut(&[FrameRecord]) -> bool) -> Trace {
        self.run_inner(|_| {}, |_, frame_tick| frame_tick, Some, |_| false, stop)
    }

    fn run_inner(
        &mut self,
        mut progress: impl FnMut(f64),
        mut taken_at: impl FnMut(u64, u64) -> u64,
        mut applied: impl FnMut(u64) -> Option<u64>,
        mut resynced: impl FnMut(u64) -> bool,
        mut stop: impl FnMut(&[FrameRecord]) -> bool,
    ) -> Trace {
        let dt = self.config.timing.control_period_s;
        let ticks_per_frame = u64::from(self.config.timing.control_ticks_per_frame);
        let ticks = (self.config.scenario.duration_s / dt).round() as u64;
        let frames_expected = (ticks / ticks_per_frame + 1) as usize;
        let mut frames = Vec::with_capacity(frames_expected);
        let mut joints = Vec::with_capacity((ticks / 10 + 1) as usize);
        let mut faults = Faults::default();
        let joints_every = (0.01 / dt).round().max(1.0) as u64;
        let desired_camera_from_base = self.base_from_desired_camera.inverse();

        let mut waiting: Option<(u64, Twist)> = None;
        let mut computed: [Option<(u64, ActuatorCommand)>; REPLAY_COMMANDS] = [None; REPLAY_COMMANDS];
        for tick in 0..ticks {
            let t = tick as f64 * dt;
            let state = *self.plant.state();
            if tick % ticks_per_frame == 0 {
                let frame = self.vision.capture(
                    tick / ticks_per_frame,
                    tick,
                    &state.q,
                    &self.plant.base_from_board(),
                );
                // the servo acts on the frame that leaves the pipeline now
                let (twist, verdict) = self.servo.step(frame.delivered.as_ref().map(|d| ServoInput {
                    frame: d.frame,
                    features: &d.features,
                    base_from_camera: d.base_from_camera.as_ref(),
                }));
                let at = frame.delivered.as_ref().map_or(tick, |d| taken_at(d.capture_tick, tick).max(tick));
                waiting = Some((at, twist));
                frames.push(FrameRecord {
                    t_s: t,
                    measured: frame.captured.features,
                    truth: frame.truth,
                    twist,
                    verdict: Some(verdict),
                    camera_position_m: frame.base_from_camera.translation.vector,
                    camera_in_desired_m: (desired_camera_from_base * frame.base_from_camera)
                        .translation
                        .vector,
                });
                progress(t);
                if stop(&frames) {
                    break;
                }
            }
            // as the real-time rmrc: a resync first, then the twists that came in
            if resynced(tick) {
                self.rmrc = self.cell.rmrc(&state.q);
            }
            if let Some((at, twist)) = waiting
                && at == tick
            {
                self.rmrc.set_twist(twist, t);
                waiting = None;
            }
            let command = self.rmrc.step(t + dt, &state.q, &state.qd);
            computed[(tick % REPLAY_COMMANDS as u64) as usize] = Some((tick, command));
            let state = match applied(tick) {
                Some(answered) if answered == tick => *self.plant.apply(&command),
                Some(answered) => match computed[(answered % REPLAY_COMMANDS as u64) as usize] {
                    Some((at, older)) if at == answered => *self.plant.apply(&older),
                    _ => *self.plant.hold(),
                },
                None => *self.plant.hold(),
            };
            faults.position_limit |= state.faults.position_limit;
            faults.velocity_limit |= state.faults.velocity_limit;
            faults.torque_saturated |= state.faults.torque_saturated;
            faults.integration_failed |= state.faults.integration_failed;
            if (tick + 1) % joints_every == 0 {
                joints.push(JointRecord {
                    t_s: t + dt,
                    q: state.q,
                    qd: state.qd,
                    torque: state.applied_torque,
                });
            }
        }
        Trace { frames, joints, faults, desired_features: self.gains.desired_features }
    }
}
