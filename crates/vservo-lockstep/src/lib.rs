//! # vservo-lockstep — the whole loop on virtual time
//!
//! This crate owns the lockstep shell: simulated camera → extractor → (pipeline delay) → servo law →
//! interpolator → joint servo → plant, every component a pure step function, all on one virtual clock.
//! The same configuration gives the same bits; a 30 s experiment takes under a second.

use std::collections::VecDeque;

use nalgebra::{Rotation3, Translation3, Vector3};
use vservo_arm::{JointVector, puma560};
use vservo_config::Config;
use vservo_control::{Gains, ServoLaw, Twist};
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS};
use vservo_vision::source::SimulatedCamera;
use vservo_vision::{Extractor, Prediction};

use vservo_sim::interpolator::Interpolator;
use vservo_sim::joint_servo::JointServo;
use vservo_sim::plant::{Faults, Plant, PlantMode};

/// Why a simulation could not start.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// No inverse-kinematics solution inside the joint limits for the starting camera pose.
    #[error("the starting camera pose has no inverse-kinematics solution inside the joint limits")]
    Unreachable,
    /// The gains could not be designed.
    #[error("gain design: {0}")]
    Gains(#[from] vservo_control::GainsError),
    /// The configuration asks for recorded images, which cannot close a simulated loop.
    #[error(
        "vision.source = \"directory\": recorded images do not move with the simulated arm; the lockstep simulator renders its own (vision.source = \"simulated\")"
    )]
    RecordedImages,
}

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

/// The loop.
pub struct Lockstep {
    config: Config,
    gains: Gains,
    plant: Plant,
    interpolator: Interpolator,
    joint_servo: JointServo,
    camera: SimulatedCamera,
    extractor: Extractor,
    servo: ServoLaw,
    base_from_desired_camera: IsometryMatrix3<f64>,
    base_from_board_desired: IsometryMatrix3<f64>,
}

impl Lockstep {
    /// Sets the loop up from a configuration (its `[plant]`, `[interpolator]`, `[joint_servo]` and
    /// `[scenario]` sections say what to simulate): designs the gains, places the arm by inverse kinematics.
    pub fn new(config: &Config) -> Result<Self, SimError> {
        if config.vision.source != vservo_config::VisionSource::Simulated {
            return Err(SimError::RecordedImages);
        }
        let scenario = &config.scenario;
        let arm = puma560::puma560();
        let gains = Gains::design(&config.gains_spec())?;
        let base_from_desired_camera = arm.base_from_tool(&config.desired.joints) * config.tool_from_camera;
        let base_from_board_desired = config.base_from_board(&arm);
        let displacement = IsometryMatrix3::from_parts(
            Translation3::from(scenario.initial_camera_translation_m),
            Rotation3::from_scaled_axis(scenario.initial_camera_rotation),
        );
        let base_from_tool_start =
            base_from_desired_camera * displacement * config.tool_from_camera.inverse();
        let solutions = arm.inverse_kinematics(&base_from_tool_start).map_err(|_| SimError::Unreachable)?;
        let q0 = solutions.nearest(&arm, &config.desired.joints).ok_or(SimError::Unreachable)?.q;
        // the kinematic plant is the ideal robot of DESIGN §5, which moves the camera exactly as commanded:
        // no acceleration limit between it and the twist
        let mut interpolator_settings = config.interpolator;
        if config.plant.mode == PlantMode::Kinematic {
            interpolator_settings.acceleration_limit = JointVector::from_element(f64::INFINITY);
        }
        Ok(Self {
            config: config.clone(),
            servo: ServoLaw::new(&gains),
            gains,
            plant: Plant::new(arm.clone(), config.plant.mode, config.plant.rk4_substeps, q0),
            interpolator: Interpolator::new(interpolator_settings, arm.clone(), config.tool_from_camera, q0),
            joint_servo: JointServo::new(
                arm,
                config.joint_servo.law,
                config.joint_servo.kp,
                config.joint_servo.kv,
            ),
            camera: SimulatedCamera::new(config.camera, config.board, config.vision.render),
            extractor: Extractor::new(
                config.vision.extractor,
                config.camera.width_px(),
                config.camera.height_px(),
            ),
            base_from_desired_camera,
            base_from_board_desired,
        })
    }

    /// The designed gains.
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// Runs the scenario; `progress` is called with the simulated time at every vision frame.
    pub fn run(&mut self, mut progress: impl FnMut(f64)) -> Trace {
        let dt = self.config.timing.control_period_s;
        let ticks_per_frame = u64::from(self.config.timing.control_ticks_per_frame);
        let ticks = (self.config.scenario.duration_s / dt).round() as u64;
        let delay = self.config.timing.pipeline_delay_frames;
        let frames_expected = (ticks / ticks_per_frame + 1) as usize;
        let mut frames = Vec::with_capacity(frames_expected);
        let mut joints = Vec::with_capacity((ticks / 10 + 1) as usize);
        let mut pipeline: VecDeque<FeatureVector> = VecDeque::with_capacity(delay + 1);
        let mut previous: Option<FeatureVector> = None;
        let mut faults = Faults::default();
        let arm = self.plant.arm().clone();
        let joints_every = (0.01 / dt).round().max(1.0) as u64;

        for tick in 0..ticks {
            let t = tick as f64 * dt;
            let state = *self.plant.state();
            if tick % ticks_per_frame == 0 {
                // capture
                let base_from_camera = arm.base_from_tool(&state.q) * self.config.tool_from_camera;
                let base_from_board = self.config.scenario.object.base_from_board(
                    t,
                    &self.base_from_desired_camera,
                    &self.base_from_board_desired,
                );
                let camera_from_board = base_from_camera.inverse() * base_from_board;
                let image = self.camera.capture(&camera_from_board, tick / ticks_per_frame);
                let prediction = match previous {
                    Some(p) => Prediction::Tracking(p),
                    None => Prediction::Layout(self.config.desired.features),
                };
                let found = self.extractor.extract(image, &prediction);
                // track from the latest known position of each mark
                previous = match previous {
                    Some(mut known) => {
                        for mark in (0..MARKS).filter(|&m| found.status[m].is_valid()) {
                            known[2 * mark] = found.features[2 * mark];
                            known[2 * mark + 1] = found.features[2 * mark + 1];
                        }
                        Some(known)
                    }
                    None => found.all_valid().then_some(found.features),
                };
                let truth = self
                    .config
                    .camera
                    .project_marks(&self.config.board, &camera_from_board)
                    .unwrap_or_else(|_| FeatureVector::from_element(f64::NAN));
                pipeline.push_back(found.features);
                // the servo acts on the frame that leaves the pipeline now; before the first one has, and
                // whenever a mark is missing, it commands zero
                let twist = match (pipeline.len() > delay).then(|| pipeline.pop_front()).flatten() {
                    Some(seen) if seen.iter().all(|v| v.is_finite()) => self.servo.command(&seen),
                    Some(_) => self.servo.hold(),
                    None => Twist::zeros(),
                };
                self.interpolator.set_twist(twist, t);
                frames.push(FrameRecord {
                    t_s: t,
                    measured: found.features,
                    truth,
                    twist,
                    camera_position_m: base_from_camera.translation.vector,
                    camera_in_desired_m: (self.base_from_desired_camera.inverse() * base_from_camera)
                        .translation
                        .vector,
                });
                progress(t);
            }
            let reference = *self.interpolator.step(t + dt);
            let state = match self.plant.mode() {
                PlantMode::Kinematic => *self.plant.step_kinematic(&reference.q, &reference.qd),
                PlantMode::Dynamic => {
                    let torque = self.joint_servo.torque(&state.q, &state.qd, &reference);
                    *self.plant.step_dynamic(&torque, dt)
                }
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
