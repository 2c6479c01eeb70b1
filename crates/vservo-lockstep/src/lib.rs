//! # vservo-lockstep — the whole loop on virtual time
//!
//! This crate owns the lockstep shell: simulated camera → extractor → (pipeline delay) → servo law →
//! interpolator → joint servo → plant, every component a pure step function, all on one virtual clock.
//! The same configuration gives the same bits; a 30 s experiment takes under a second. It runs the wholly
//! simulated cell only (`vservo_cell::Cell::simulated`), through the same four stages as the real-time nodes.
//!
//! Per 1 ms tick k (t = k·1 ms): on the first tick of every vision period (85 ticks by default) the camera
//! captures the current state, the extractor finds the features and they enter the pipeline (delay d frames);
//! the features leaving it go to the servo law, whose twist goes to the interpolator (zero until the first
//! features arrive; with one mark missing the law on the other three; with two or more a twist back towards
//! where all were last seen). Then the interpolator advances the joint reference, the joint servo turns it
//! into torques, and the plant integrates 1 ms (or, kinematic, takes the reference).
//!
//! - [`Lockstep::run`]: a scenario, each twist taken in at once and every joint state answered in time.
//! - [`Lockstep::run_replaying`]: a real-time run done again at its pace, from a [`Replay`] (data, no
//!   callback): the tick each twist was taken in (the joint commands' `twist_applied_tick`), the command the arm
//!   followed each period (the joint states' `applied_command_tick`) and the joint states the real-time rmrc
//!   answered (the joint commands' `answers_tick`, `driver_epoch`, `state_stamp_ns`). Its rmrc stage follows
//!   those states and decides its restarts at rest itself, as the node did ([`Lockstep::resyncs`] says where;
//!   a test compares them with the run's `reference_since_tick`), which reproduces that run to rounding
//!   (4e-15 px RMS with the default configuration, an integration test; against [`Lockstep::run`] it differs
//!   by 0.6–3 px with a VM's timing noise).
//! - [`Lockstep::run_until`]: a run ended early (the Monte Carlo of `vservoctl basin`).
//! - [`summary`]: settling, overshoot, tracking errors and camera amplitudes of a [`Trace`].

use std::collections::HashMap;

use nalgebra::Vector3;
use vservo_arm::JointVector;
use vservo_config::Config;
use vservo_control::{Gains, Twist};
use vservo_scene::{FeatureVector, IsometryMatrix3};

pub use vservo_cell::CellError;
pub use vservo_cell::DriverTick;
pub use vservo_cell::ServoVerdict;
use vservo_cell::{
    ActuatorCommand, Cell, CommandReference, Following, PlantStage, RmrcStage, ServoInput, ServoStage,
    TwistLimits, VisionStage,
};
use vservo_sim::plant::{Faults, JointState};

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
    /// How far the board's image moved while the shutter was open (px; 0 for an instant or where not
    /// known): the motion blur of `vision.render.exposure_s`.
    pub motion_blur_px: f64,
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
    /// What the collision guard saw and did, where `[collision]` gives one.
    pub clearance: Option<Clearance>,
}

/// What the collision guard saw and did over a run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Clearance {
    /// The smallest distance it found within its slowdown distance, and between what (m).
    pub nearest: Option<(f64, String, String)>,
    /// The ticks on which it slowed the asked motion.
    pub slowed_ticks: u64,
    /// Where it stopped the arm: the time (s), the pair, the distance and the braking distance it kept (m).
    pub stop: Option<GuardStop>,
}

/// A stop of the collision guard.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardStop {
    /// When (s).
    pub t_s: f64,
    /// Between what.
    pub between: (String, String),
    /// The distance (m).
    pub distance_m: f64,
    /// How far the reference could still close it while braking, at most (m).
    pub braking_m: f64,
    /// The smallest it came to from the stop on, the reference at rest (m).
    pub closest_after_m: f64,
}

/// How many of the latest commands' references [`Lockstep::run_replaying`] keeps for a late answer: as many as
/// the simulated driver may keep following one for (`runtime.hold_after_missed_ticks`), and the newest.
fn commands_kept(config: &Config) -> usize {
    config.runtime.hold_after_missed_ticks as usize + 1
}

/// What a real-time run did, as data for [`Lockstep::run_replaying`] to do the same; ticks are the lockstep
/// run's (the real-time run's minus the tick of its first image). Nothing here says what the rmrc decided:
/// the rmrc stage, fed the joint states the real-time rmrc answered, decides again (a restart at rest after a
/// stall or a new driver) exactly as the node did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Replay {
    /// The tick each twist reached the interpolator, by the capture tick of the features it was computed
    /// from (the joint commands' `twist_capture_tick` → `twist_applied_tick`). A twist not listed is taken
    /// in at once; a tick earlier than the frame's counts as the frame's; a twist still waiting when the
    /// next one is computed is dropped, as the rmrc, draining both at once, would keep the newer.
    pub twist_taken_in: HashMap<u64, u64>,
    /// Which command the arm followed over the period from each tick (the joint states'
    /// `applied_command_tick`): `Some(tick)` the one computed at that tick, `Some(older)` one computed at an
    /// earlier tick (a driver that kept its last command, for up to `runtime.hold_after_missed_ticks`
    /// ticks, because the answer came late), `None` none (the plant holds the arm). A tick not listed: the command computed at it.
    pub command_applied: HashMap<u64, Option<u64>>,
    /// The joint states the rmrc answered, by tick (the joint commands' `answers_tick`, `driver_epoch` and
    /// `state_stamp_ns`). The rmrc stage follows these only; between them its reference runs on.
    pub states_answered: HashMap<u64, DriverTick>,
}

/// When the rmrc takes each twist in, which command the arm follows and which joint states the rmrc
/// follows: at once and every one ([`Lockstep::run`]), or as a real-time run did.
enum Pace<'a> {
    /// A simulated driver answered in time every tick (its clock the virtual one).
    Own { period_ns: u64 },
    /// A real-time run's.
    Replay(&'a Replay),
}

impl Pace<'_> {
    /// The tick the twist computed at `frame_tick` (from the image captured at `delivered_capture_tick`) is
    /// taken in.
    fn twist_taken_at(&self, delivered_capture_tick: Option<u64>, frame_tick: u64) -> u64 {
        match (self, delivered_capture_tick) {
            (Pace::Replay(replay), Some(capture)) => {
                replay.twist_taken_in.get(&capture).copied().unwrap_or(frame_tick).max(frame_tick)
            }
            _ => frame_tick,
        }
    }

    /// The tick whose command the arm follows over the period from `tick` (`None`: held).
    fn command_applied(&self, tick: u64) -> Option<u64> {
        match self {
            Pace::Own { .. } => Some(tick),
            Pace::Replay(replay) => replay.command_applied.get(&tick).copied().unwrap_or(Some(tick)),
        }
    }

    /// The joint state the rmrc answers at `tick`, if it answered one.
    fn state_answered(&self, tick: u64) -> Option<DriverTick> {
        match self {
            Pace::Own { period_ns } => {
                Some(DriverTick { epoch: 0, tick, stamp_ns: tick * period_ns, holding: false })
            }
            Pace::Replay(replay) => replay.states_answered.get(&tick).copied(),
        }
    }
}

/// A twist computed and not yet taken in by the rmrc: the tick it will be, the twist, and whether its verdict
/// lets the arm move.
#[derive(Debug, Clone, Copy)]
struct Waiting {
    at: u64,
    twist: Twist,
    moves: bool,
}

/// The loop.
pub struct Lockstep {
    config: Config,
    gains: Gains,
    plant: PlantStage,
    vision: VisionStage,
    servo: ServoStage,
    rmrc: RmrcStage,
    limits: TwistLimits,
    desired_camera_from_base: IsometryMatrix3<f64>,
    /// The ticks the rmrc started again at rest in the last run.
    resyncs: Vec<u64>,
    waiting: Option<Waiting>,
    /// The references of the latest ticks' commands, by tick modulo their number (what the drive follows when an
    /// answer came late).
    computed: Vec<Option<(u64, CommandReference)>>,
}

impl Lockstep {
    /// Sets the loop up from a configuration (its `[plant]`, `[interpolator]`, `[joint_servo]` and
    /// `[scenario]` sections say what to simulate): designs the gains, places the arm by inverse kinematics.
    pub fn new(config: &Config) -> Result<Self, CellError> {
        let cell = Cell::simulated(&config.cell)?;
        Ok(Self {
            config: config.clone(),
            gains: cell.gains().clone(),
            plant: cell.plant(),
            vision: cell.vision(),
            servo: cell.servo(),
            rmrc: cell.rmrc(cell.start_joints()),
            limits: TwistLimits::of(cell.config()),
            desired_camera_from_base: cell.base_from_desired_camera().inverse(),
            resyncs: Vec::new(),
            waiting: None,
            computed: vec![None; commands_kept(config)],
        })
    }

    /// The designed gains.
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// The ticks at which the rmrc started again at rest from the measured joints in the last run: its
    /// start (the first joint state it followed), and after a stall or a new driver epoch.
    pub fn resyncs(&self) -> &[u64] {
        &self.resyncs
    }

    /// Runs the scenario; `progress` is called with the simulated time at every vision frame.
    pub fn run(&mut self, progress: impl FnMut(f64)) -> Trace {
        let pace = self.own_pace();
        self.run_paced(&pace, progress, |_| false)
    }

    /// [`Lockstep::run`] at a real-time run's pace: each twist taken in, each command applied and each joint
    /// state followed when that run did ([`Replay`]), so that the two can be compared frame by frame. The
    /// rmrc stage decides its restarts at rest itself from the joint states it is fed, as the real-time
    /// node does ([`Lockstep::resyncs`] says where).
    pub fn run_replaying(&mut self, progress: impl FnMut(f64), replay: &Replay) -> Trace {
        self.run_paced(&Pace::Replay(replay), progress, |_| false)
    }

    /// [`Lockstep::run`], ended early at the first frame for which `stop(frames so far)` says so (a Monte
    /// Carlo of starts stops a run once it has settled long enough).
    pub fn run_until(&mut self, stop: impl FnMut(&[FrameRecord]) -> bool) -> Trace {
        let pace = self.own_pace();
        self.run_paced(&pace, |_| {}, stop)
    }

    fn own_pace(&self) -> Pace<'static> {
        Pace::Own { period_ns: vservo_time::nanos(self.config.cell.timing.control_period_s) }
    }

    /// Every tick of the scenario: a frame every vision period, then the rmrc and the plant.
    fn run_paced(
        &mut self,
        pace: &Pace<'_>,
        mut progress: impl FnMut(f64),
        mut stop: impl FnMut(&[FrameRecord]) -> bool,
    ) -> Trace {
        let dt = self.config.cell.timing.control_period_s;
        let ticks_per_frame = u64::from(self.config.cell.timing.control_ticks_per_frame);
        let ticks = (self.config.cell.scenario.duration_s / dt).round() as u64;
        let mut frames = Vec::with_capacity((ticks / ticks_per_frame + 1) as usize);
        let mut joints = Vec::with_capacity((ticks / 10 + 1) as usize);
        let mut faults = Faults::default();
        let joints_every = (0.01 / dt).round().max(1.0) as u64;
        let mut clearance = Some(Clearance::default());
        (self.resyncs, self.waiting) = (Vec::new(), None);
        self.computed.fill(None);
        for tick in 0..ticks {
            if tick % ticks_per_frame == 0 {
                frames.push(self.frame(tick, tick / ticks_per_frame, pace));
                progress(tick as f64 * dt);
                if stop(&frames) {
                    break;
                }
            }
            let command = self.rmrc_tick(tick, pace);
            if let Some(clearance) = clearance.as_mut() {
                self.watch_guard(clearance, tick as f64 * dt + dt);
            }
            let state = self.plant_tick(tick, command, pace);
            faults.position_limit |= state.faults.position_limit;
            faults.velocity_limit |= state.faults.velocity_limit;
            faults.torque_saturated |= state.faults.torque_saturated;
            faults.integration_failed |= state.faults.integration_failed;
            if (tick + 1) % joints_every == 0 {
                let t_s = tick as f64 * dt + dt;
                joints.push(JointRecord { t_s, q: state.q, qd: state.qd, torque: state.applied_torque });
            }
        }
        let clearance = clearance.filter(|_| self.rmrc.guard().is_some());
        Trace { frames, joints, faults, desired_features: self.gains.desired_features, clearance }
    }

    /// The camera captures the current state; the servo acts on the frame that leaves the pipeline now, its
    /// twist waiting to be taken in by the rmrc.
    fn frame(&mut self, tick: u64, frame: u64, pace: &Pace<'_>) -> FrameRecord {
        let state = *self.plant.state();
        let taken = self.vision.capture(frame, tick, &state.q, &self.plant.base_from_board());
        let step = self.servo.step(taken.delivered.as_ref().map(|d| ServoInput {
            frame: d.frame,
            features: &d.features,
            holder_from_camera: d.holder_from_camera.as_ref(),
            // the pipeline is whole frames: the image shows the camera at the capture it is stamped with
            unseen_s: 0.0,
        }));
        let at = pace.twist_taken_at(taken.delivered.as_ref().map(|d| d.capture_tick), tick);
        self.waiting = Some(Waiting { at, twist: step.twist, moves: step.verdict.moves() });
        FrameRecord {
            t_s: tick as f64 * self.config.cell.timing.control_period_s,
            measured: taken.captured.features,
            truth: taken.truth,
            twist: step.twist,
            verdict: Some(step.verdict),
            camera_position_m: taken.base_from_camera.translation.vector,
            motion_blur_px: taken.motion_blur_px,
            camera_in_desired_m: match self.config.cell.fixed_camera {
                None => (self.desired_camera_from_base * taken.base_from_camera).translation.vector,
                // where the camera is relative to the board, in the desired camera frame
                Some(_) => {
                    (self.config.cell.desired.camera_from_board * taken.camera_from_board.inverse())
                        .translation
                        .vector
                }
            },
        }
    }

    /// As the real-time rmrc: the joint state followed (a restart at rest first, if it does not carry on),
    /// then the twist that came in, then the command for this tick (its reference kept for a late answer).
    fn rmrc_tick(&mut self, tick: u64, pace: &Pace<'_>) -> ActuatorCommand {
        let state = *self.plant.state();
        if let Some(answered) = pace.state_answered(tick)
            && self.rmrc.follow(answered, &state.q, &state.qd) == Following::Resynced
        {
            self.resyncs.push(tick);
        }
        if let Some(waiting) = self.waiting
            && waiting.at == tick
        {
            self.rmrc.take_twist(&waiting.twist, waiting.moves, &self.limits, tick);
            self.waiting = None;
        }
        let command = self.rmrc.step(tick, &state.q, &state.qd);
        let reference = self.rmrc.reference();
        let kept = self.computed.len() as u64;
        self.computed[(tick % kept) as usize] =
            Some((tick, CommandReference { q: reference.q, qd: reference.qd }));
        command
    }

    /// What the guard made of the tick that ended at `t_s`, taken into the run's record.
    fn watch_guard(&self, clearance: &mut Clearance, t_s: f64) {
        let (Some(guard), Some(assessed)) = (self.rmrc.guard(), self.rmrc.assessed()) else { return };
        let named = |between| {
            let (first, second) = guard.names(between);
            (first.to_string(), second.to_string())
        };
        if let Some(near) = assessed.nearest
            && clearance.nearest.as_ref().is_none_or(|(d, _, _)| near.distance_m < *d)
        {
            let (first, second) = named(near.between);
            clearance.nearest = Some((near.distance_m, first, second));
        }
        clearance.slowed_ticks += u64::from(assessed.speed_share < 1.0);
        if let (None, Some(stop)) = (&clearance.stop, self.rmrc.guard_stop()) {
            clearance.stop = Some(GuardStop {
                t_s,
                between: named(stop.between),
                distance_m: stop.distance_m,
                braking_m: stop.braking_m,
                closest_after_m: stop.distance_m,
            });
        }
        if let (Some(record), Some(stop)) = (clearance.stop.as_mut(), self.rmrc.guard_stop()) {
            let placement = self.rmrc.arm().placement(&self.rmrc.reference().q);
            if let Some(now_m) = guard.distance_of(stop.between, &placement) {
                record.closest_after_m = record.closest_after_m.min(now_m);
            }
        }
    }

    /// The plant over the period from `tick`, on the command the pace says the arm followed.
    fn plant_tick(&mut self, tick: u64, command: ActuatorCommand, pace: &Pace<'_>) -> JointState {
        match pace.command_applied(tick) {
            Some(answered) if answered == tick => *self.plant.apply(&command),
            Some(answered) => match self.computed[(answered % self.computed.len() as u64) as usize] {
                Some((at, older)) if at == answered => {
                    *self.plant.follow_late(&older, tick.saturating_sub(answered))
                }
                _ => *self.plant.hold(),
            },
            None => *self.plant.hold(),
        }
    }
}
