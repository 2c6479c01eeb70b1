//! Taking the views through a running vservod (docs/CALIBRATION.md): the arm moved pose by pose with the
//! daemon's joint move (`move_joints`: at a share of the speed limits, within the joint limits, held by a safe
//! stop and taken on by `resume`), each view the first camera frame exposed after the arm has been at rest on
//! its goal for [`SETTLE`], with the joints of the joint state stamped nearest the frame's exposure. At the end
//! the arm goes back to where it started and the cell servos again; a cell that was held by the user when the
//! calibration began (`start_held`, a first motion; or `requested`) leaves its stop by the first move (the
//! calibration's planned, slow moves are then the cell's first motion) and is held again at the end.
//!
//! What goes wrong before the first pose gives the cell back to the servo (the arm is where it was). Later, what
//! goes wrong (a refusal, an arm that does not settle, no frame, SIGINT or SIGTERM) stops the calibration with
//! the reason and leaves the arm held where it is (a joint move to its own joints; in a safe stop, the move
//! cancelled, so that the resume servos instead of taking it on): servoing from a calibration pose, where the
//! target may be out of view, is the user's decision (`vservoctl servo`).

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::ipc;
use image::GrayImage;
use vservo_arm::{JointVector, SerialArm};
use vservo_client::Client;
use vservo_config::Config;
use vservo_protocol::{AT_REST_RAD_S, CameraImageHeader, DaemonState, JointStateMsg, PixelFormat, Topic};

use crate::dataset::View;
use crate::plan::PlannedPose;
use crate::{CalibrateError, Result};

/// How long the arm must be at rest on its goal before a view is taken.
pub const SETTLE: Duration = Duration::from_millis(500);
/// A joint this close to its goal (rad) is on it (the joint servo's steady error is well below).
pub const ON_GOAL_RAD: f64 = 0.005;
/// How long a safe stop is waited out (for `vservoctl resume`) before the calibration gives up.
const HELD_WAIT: Duration = Duration::from_secs(120);
/// How long a camera frame is waited for once the arm has settled.
const FRAME_WAIT: Duration = Duration::from_secs(5);
/// How often the joint states are drained and the status looked at.
const POLL: Duration = Duration::from_millis(5);
const STATUS_EVERY: Duration = Duration::from_millis(100);
/// The joint states kept (the last two seconds at 1 kHz): a frame's joints are looked up among them.
const KEPT_STATES: usize = 2000;

/// A running instance, as the calibration moves and watches it.
pub struct Running {
    client: Client,
    joint_states: Subscriber<ipc::Service, JointStateMsg, ()>,
    images: Subscriber<ipc::Service, [u8], CameraImageHeader>,
    arm: SerialArm,
    acceleration_limit: JointVector,
    image_size: (u32, u32),
    speed_fraction: f64,
    recent: VecDeque<JointStateMsg>,
    /// Set on SIGINT or SIGTERM: the calibration stops, the arm held.
    interrupted: Arc<AtomicBool>,
    /// The cell was held by the user when the calibration began: it is held again at the end.
    started_held: bool,
    /// The next move leaves the user's hold (the first move of a held cell).
    out_of_hold: bool,
}

impl Running {
    /// Connects to the configuration's instance; refused while it is not running, or in a safe stop other than
    /// the user's hold (`start_held`, `requested`).
    pub fn connect(config: &Config, speed_fraction: f64) -> Result<Self> {
        if !(speed_fraction > 0.0 && speed_fraction <= 1.0) {
            return Err(CalibrateError::Refused(format!(
                "--speed-fraction {speed_fraction}: must be in (0, 1]"
            )));
        }
        // before any other thread: the signals are taken by the flag's thread only
        let interrupted = vservo_protocol::signals::stop_flag()
            .map_err(|e| CalibrateError::Cell(format!("taking SIGINT and SIGTERM: {e}")))?;
        let client = Client::connect(&config.instance).map_err(|e| {
            CalibrateError::Cell(format!(
                "{}: no running vservod of instance {:?}: {e}",
                config.origin, config.instance
            ))
        })?;
        let status = client.status(Duration::from_secs(2))?;
        let fault = vservo_protocol::Fault::try_from(status.fault).ok();
        let held_by_user =
            matches!(fault, Some(vservo_protocol::Fault::StartHeld | vservo_protocol::Fault::Requested));
        let started_held = match DaemonState::try_from(status.state) {
            Ok(DaemonState::Running | DaemonState::Moving) => false,
            Ok(DaemonState::SafeStop) if held_by_user => true,
            Ok(DaemonState::SafeStop) => {
                let fault = fault.map_or("unknown", vservo_protocol::Fault::name);
                return Err(CalibrateError::Refused(format!(
                    "the cell is in a safe stop ({fault}): `vservoctl resume` once its cause is gone, then calibrate"
                )));
            }
            other => {
                let state = other.map_or("unknown", DaemonState::name);
                return Err(CalibrateError::Refused(format!(
                    "the cell is {state}, not running: nothing was moved"
                )));
            }
        };
        if started_held {
            eprintln!("the cell is held: its first motion is the calibration's; it is held again at the end");
        }
        let joint_states = client.subscribe::<JointStateMsg>(Topic::JointState)?;
        let images = client.subscribe_camera_images()?;
        Ok(Self {
            client,
            joint_states,
            images,
            arm: config.cell.arm.clone(),
            acceleration_limit: config.cell.interpolator.acceleration_limit,
            image_size: (config.cell.camera.width_px(), config.cell.camera.height_px()),
            speed_fraction,
            recent: VecDeque::with_capacity(KEPT_STATES),
            interrupted,
            started_held,
            out_of_hold: started_held,
        })
    }

    /// An error when SIGINT or SIGTERM came.
    fn go_on(&self, what: &str) -> Result<()> {
        if vservo_protocol::signals::stopped(&self.interrupted) {
            return Err(CalibrateError::Cell(format!("{what}: interrupted (SIGINT or SIGTERM)")));
        }
        Ok(())
    }

    /// After an error before the first pose: the servo gets the cell back (the arm is where it was); a cell
    /// that began held is held again.
    pub fn give_back(&mut self, error: CalibrateError) -> CalibrateError {
        if self.started_held {
            return match self.hold_again() {
                Ok(()) => error.left("nothing was moved; the cell is held again"),
                Err(e) => error.left(format!("the cell could not be held again: {e}")),
            };
        }
        match self.client.servo() {
            Ok(reply) if reply.accepted => error.left("nothing was moved; the cell servos again"),
            Ok(reply) => {
                error.left(format!("the cell could not be given back to the servo: {}", reply.reason))
            }
            Err(e) => error.left(format!("the cell could not be given back to the servo: {e}")),
        }
    }

    /// A cell that began held, held again: a safe stop (the arm ramps to rest where it is), then the joint move
    /// cancelled, so that `vservoctl resume` servos rather than taking the move on.
    fn hold_again(&mut self) -> Result<()> {
        // refused when held already (the first move never went), and the cancel when no move is in force: what
        // counts is the cell held at the end
        let stopped = self.client.safe_stop_command()?;
        let cancelled = self.client.servo()?;
        // the status is published every 100 ms: it may still say what was before the stop
        let started = Instant::now();
        let mut held = false;
        while !held && started.elapsed() < Duration::from_secs(1) {
            let status = self.client.status(Duration::from_secs(2))?;
            held = DaemonState::try_from(status.state) == Ok(DaemonState::SafeStop);
            std::thread::sleep(STATUS_EVERY / 2);
        }
        if !held {
            return Err(CalibrateError::Cell(format!(
                "holding the cell again: the safe stop: {}; the move's end: {}",
                stopped.reason, cancelled.reason
            )));
        }
        Ok(())
    }

    /// After an error on the way: the arm held where it is (in a safe stop: the move cancelled; a cell that
    /// began held, held again).
    pub fn stop_here(&mut self, error: CalibrateError) -> CalibrateError {
        if self.started_held {
            return match self.hold_again() {
                Ok(()) => error.left("calibration stopped; the cell is held again where the arm is"),
                Err(e) => error.left(format!("calibration stopped; {e}")),
            };
        }
        let held_here = self.joints_now().and_then(|here| {
            let joints = self.arm.joint_count();
            Ok(self.client.move_joints(&here.as_slice()[..joints], self.speed_fraction)?)
        });
        match held_here {
            Ok(reply) if reply.accepted => error
                .left("calibration stopped; the arm is held where it is (`vservoctl servo` servos again)"),
            _ => match self.client.servo() {
                Ok(reply) if reply.accepted => error.left(format!("calibration stopped; {}", reply.reason)),
                Ok(reply) => {
                    error.left(format!("calibration stopped; the move could not be ended: {}", reply.reason))
                }
                Err(e) => error.left(format!("calibration stopped; the move could not be ended: {e}")),
            },
        }
    }

    /// Keeps the joint states that came (this build's schema, the arm's joint count).
    fn drain_states(&mut self) -> Result<()> {
        let joints = self.arm.joint_count();
        while let Some(sample) = self
            .joint_states
            .receive()
            .map_err(|e| CalibrateError::Cell(format!("reading the joint states: {e}")))?
        {
            let Ok(state) = vservo_protocol::inbox::accept(*sample) else { continue };
            if state.arm_q_rad(joints).is_none() {
                continue;
            }
            if self.recent.len() == KEPT_STATES {
                self.recent.pop_front();
            }
            self.recent.push_back(state);
        }
        Ok(())
    }

    /// The arm's joints now (waiting up to two seconds for a joint state).
    pub fn joints_now(&mut self) -> Result<JointVector> {
        let started = Instant::now();
        loop {
            self.drain_states()?;
            if let Some(q) = self.recent.back().and_then(|s| s.arm_q_rad(self.arm.joint_count())) {
                return Ok(JointVector::from(q));
            }
            if started.elapsed() > Duration::from_secs(2) {
                return Err(CalibrateError::Cell("no joint state from the robot driver within 2 s".into()));
            }
            std::thread::sleep(POLL);
        }
    }

    /// Waits up to `wait` for the arm to have been at rest for [`SETTLE`] (wherever it is); the stamp of the
    /// joint state that completed the wait (CLOCK_MONOTONIC, ns: the camera stamps its frames on the same
    /// clock).
    pub fn at_rest(&mut self, wait: Duration) -> Result<u64> {
        let started = Instant::now();
        loop {
            self.drain_states()?;
            if let Some(stamp_ns) = self.settled(None) {
                return Ok(stamp_ns);
            }
            self.go_on("waiting for the arm to come to rest")?;
            if started.elapsed() > wait {
                return Err(CalibrateError::Refused(format!(
                    "the arm did not come to rest within {} s (is the cell still servoing towards its target?); \
                     nothing was moved",
                    wait.as_secs()
                )));
            }
            std::thread::sleep(POLL);
        }
    }

    /// Holds the arm where it is (a joint move to the joints it has now) and waits until it is at rest there.
    pub fn hold_here(&mut self) -> Result<(JointVector, u64)> {
        let here = self.joints_now()?;
        let settled_ns = self.move_to("holding the arm where it is", &here)?;
        Ok((self.joints_now()?, settled_ns))
    }

    /// Moves the arm to `goal` and waits until it has been at rest on it for [`SETTLE`]; returns the stamp
    /// (CLOCK_MONOTONIC, ns) of the joint state that completed the wait. A safe stop on the way is waited out
    /// for `vservoctl resume` (the daemon then takes the move on); a move ended by another client, a refusal
    /// or a timeout stops the calibration.
    pub fn move_to(&mut self, what: &str, goal: &JointVector) -> Result<u64> {
        let from = self.joints_now()?;
        self.ask_to_move(what, goal)?;
        let expected = move_duration(&self.arm, &self.acceleration_limit, &from, goal, self.speed_fraction);
        let allowed = expected.mul_f64(2.0) + Duration::from_secs(10);
        let mut moving_for = Duration::ZERO;
        let mut held_for = Duration::ZERO;
        let mut told_held = false;
        let mut last_status = Instant::now();
        let mut last_poll = Instant::now();
        loop {
            std::thread::sleep(POLL);
            self.go_on(what)?;
            let step = last_poll.elapsed();
            last_poll = Instant::now();
            self.drain_states()?;
            if let Some(stamp_ns) = self.settled(Some(goal)) {
                return Ok(stamp_ns);
            }
            let held = if last_status.elapsed() >= STATUS_EVERY {
                last_status = Instant::now();
                self.held(what, &mut told_held)?
            } else {
                told_held
            };
            if held {
                held_for += step;
                if held_for > HELD_WAIT {
                    return Err(CalibrateError::Cell(format!(
                        "{what}: the cell stayed in a safe stop for {} s; calibration stopped",
                        HELD_WAIT.as_secs()
                    )));
                }
            } else {
                moving_for += step;
                if moving_for > allowed {
                    return Err(CalibrateError::Cell(format!(
                        "{what}: the arm did not settle on its goal within {:.1} s (the move should take {:.1} s)",
                        allowed.as_secs_f64(),
                        expected.as_secs_f64()
                    )));
                }
            }
        }
    }

    /// Sends the move; while the cell is held in a safe stop (which refuses it), waits for the resume first.
    /// The status is published every 100 ms, so it can lag the daemon's decision (a safe stop, or a resume,
    /// just taken): a refusal the status does not explain is asked again once before it stops the calibration.
    fn ask_to_move(&mut self, what: &str, goal: &JointVector) -> Result<()> {
        let joints = self.arm.joint_count();
        let started = Instant::now();
        let mut told_held = false;
        let mut asked_again = false;
        loop {
            let goal = &goal.as_slice()[..joints];
            let reply = if self.out_of_hold {
                self.client.move_joints_out_of_hold(goal, self.speed_fraction)?
            } else {
                self.client.move_joints(goal, self.speed_fraction)?
            };
            if reply.accepted {
                self.out_of_hold = false;
                return Ok(());
            }
            let status = self.client.status(Duration::from_secs(2))?;
            let held = DaemonState::try_from(status.state) == Ok(DaemonState::SafeStop);
            if !held && asked_again {
                return Err(CalibrateError::Refused(format!(
                    "{what}: the daemon refused the move: {}",
                    reply.reason
                )));
            }
            asked_again = !held;
            if held {
                self.held(what, &mut told_held)?;
            }
            self.go_on(what)?;
            if started.elapsed() > HELD_WAIT {
                return Err(CalibrateError::Cell(format!(
                    "{what}: the cell stayed in a safe stop for {} s; calibration stopped",
                    HELD_WAIT.as_secs()
                )));
            }
            std::thread::sleep(2 * STATUS_EVERY);
        }
    }

    /// Whether the cell is held in a safe stop (said once per stop on stderr); an error when the move was
    /// ended by someone else.
    fn held(&mut self, what: &str, told: &mut bool) -> Result<bool> {
        let status = self.client.status(Duration::from_secs(2))?;
        match DaemonState::try_from(status.state) {
            Ok(DaemonState::SafeStop) => {
                if !*told {
                    let fault =
                        vservo_protocol::Fault::try_from(status.fault).map_or("unknown", |f| f.name());
                    eprintln!(
                        "{what}: the cell is in a safe stop ({fault}); waiting up to {} s for `vservoctl resume`, which takes the move on",
                        HELD_WAIT.as_secs()
                    );
                }
                *told = true;
                Ok(true)
            }
            Ok(DaemonState::Running) => Err(CalibrateError::Cell(format!(
                "{what}: the joint move was ended (by `vservoctl servo` or another client): calibration stopped"
            ))),
            _ => {
                if *told {
                    eprintln!("{what}: resumed");
                }
                *told = false;
                Ok(false)
            }
        }
    }

    /// The newest joint state's stamp if the states of the last [`SETTLE`] all have the arm at rest (and on
    /// `goal`, if given).
    fn settled(&self, goal: Option<&JointVector>) -> Option<u64> {
        let joints = self.arm.joint_count();
        let newest = self.recent.back()?;
        let settled = |state: &JointStateMsg| {
            (0..joints).all(|j| {
                let on_goal = goal.is_none_or(|goal| (state.q_rad[j] - goal[j]).abs() < ON_GOAL_RAD);
                on_goal && state.qd_rad_s[j].abs() < AT_REST_RAD_S
            })
        };
        let since = SETTLE.as_nanos() as u64;
        let mut covered = false;
        for state in self.recent.iter().rev() {
            if !settled(state) {
                return None;
            }
            if newest.stamp_ns.saturating_sub(state.stamp_ns) >= since {
                covered = true;
                break;
            }
        }
        covered.then_some(newest.stamp_ns)
    }

    /// The first frame exposed after `after_ns`, with the joints of the joint state stamped nearest it.
    pub fn take_view(&mut self, what: &str, after_ns: u64) -> Result<View> {
        let started = Instant::now();
        loop {
            // kept meanwhile: the frame's joints are looked up among them
            self.drain_states()?;
            while let Some(sample) = self
                .images
                .receive()
                .map_err(|e| CalibrateError::Cell(format!("reading the camera images: {e}")))?
            {
                let header = *sample.user_header();
                if header.capture_stamp_ns <= after_ns {
                    continue;
                }
                let image = self.image_of(&header, sample.payload())?;
                return self.view_at(what, image, header.capture_stamp_ns);
            }
            if started.elapsed() > FRAME_WAIT {
                return Err(CalibrateError::Cell(format!(
                    "{what}: no camera frame within {} s of the arm settling",
                    FRAME_WAIT.as_secs()
                )));
            }
            self.go_on(what)?;
            std::thread::sleep(POLL);
        }
    }

    /// The frame's pixels, checked against the configured camera.
    fn image_of(&self, header: &CameraImageHeader, pixels: &[u8]) -> Result<GrayImage> {
        let (width, height) = (header.width, header.height);
        if PixelFormat::try_from(header.format) != Ok(PixelFormat::Mono8)
            || (width, height) != self.image_size
            || header.stride_bytes < width
            || pixels.len() < (header.stride_bytes as usize) * (height as usize)
        {
            return Err(CalibrateError::Cell(format!(
                "a camera frame of {width} × {height} (stride {}, format {}, {} bytes) is not the configured \
                 {} × {} 8-bit gray camera's",
                header.stride_bytes,
                header.format,
                pixels.len(),
                self.image_size.0,
                self.image_size.1
            )));
        }
        let mut raw = Vec::with_capacity((width * height) as usize);
        for row in pixels.chunks(header.stride_bytes as usize).take(height as usize) {
            raw.extend_from_slice(&row[..width as usize]);
        }
        GrayImage::from_raw(width, height, raw)
            .ok_or_else(|| CalibrateError::Cell("the frame's pixels do not fill its size".into()))
    }

    /// The view of `image`, exposed at `stamp_ns`: the joints of the nearest joint state, which must be at rest.
    fn view_at(&mut self, what: &str, image: GrayImage, stamp_ns: u64) -> Result<View> {
        let started = Instant::now();
        // a state stamped at or after the exposure, so that the nearest one is among those kept
        while self.recent.back().is_none_or(|s| s.stamp_ns < stamp_ns) && started.elapsed() < FRAME_WAIT {
            std::thread::sleep(POLL);
            self.drain_states()?;
        }
        let nearest = self
            .recent
            .iter()
            .min_by_key(|s| s.stamp_ns.abs_diff(stamp_ns))
            .ok_or_else(|| CalibrateError::Cell(format!("{what}: no joint state kept")))?;
        let gap_ms = nearest.stamp_ns.abs_diff(stamp_ns) as f64 / 1e6;
        let joints = self.arm.joint_count();
        if gap_ms > 20.0 {
            return Err(CalibrateError::Cell(format!(
                "{what}: no joint state within 20 ms of the frame's exposure (nearest {gap_ms:.1} ms)"
            )));
        }
        if nearest.qd_rad_s[..joints].iter().any(|v| v.abs() >= AT_REST_RAD_S) {
            return Err(CalibrateError::Cell(format!(
                "{what}: the arm was moving when the frame was exposed"
            )));
        }
        let q = JointVector::from(
            nearest
                .arm_q_rad(joints)
                .ok_or_else(|| CalibrateError::Cell(format!("{what}: the arm's joints")))?,
        );
        Ok(View { image, q, base_from_tool: self.arm.base_from_tool(&q) })
    }

    /// One view at each planned pose, in order (progress on stderr).
    pub fn take_views(&mut self, planned: &[PlannedPose]) -> Result<Vec<View>> {
        let mut views = Vec::with_capacity(planned.len());
        for (k, pose) in planned.iter().enumerate() {
            let what = format!("pose {}/{}", k + 1, planned.len());
            let settled_ns = self.move_to(&what, &pose.q)?;
            views.push(self.take_view(&what, settled_ns)?);
            eprintln!("{what}: view taken");
        }
        Ok(views)
    }

    /// Takes the arm back to `start` and servos again; a cell that began held is held again there.
    pub fn finish(&mut self, start: &JointVector) -> Result<()> {
        self.move_to("back to the start", start)?;
        if self.started_held {
            self.hold_again()?;
            eprintln!("back at the start: the cell is held again (`vservoctl resume` servos)");
            return Ok(());
        }
        let reply = self.client.servo()?;
        if !reply.accepted {
            return Err(CalibrateError::Cell(format!("ending the joint move: {}", reply.reason)));
        }
        Ok(())
    }
}

/// How long a joint move of `speed_fraction` from `from` to `to` takes: the slowest joint's trapezoid (or
/// triangle) at that share of its speed limit and its square of the acceleration limit, as the daemon moves it.
pub fn move_duration(
    arm: &SerialArm,
    acceleration_limit: &JointVector,
    from: &JointVector,
    to: &JointVector,
    speed_fraction: f64,
) -> Duration {
    let seconds = (0..arm.joint_count())
        .map(|j| {
            let distance = (to[j] - from[j]).abs();
            let speed = speed_fraction * arm.links[j].limits.velocity_max;
            let acceleration = speed_fraction * speed_fraction * acceleration_limit[j];
            if distance >= speed * speed / acceleration {
                distance / speed + speed / acceleration
            } else {
                2.0 * (distance / acceleration).sqrt()
            }
        })
        .fold(0.0, f64::max);
    Duration::from_secs_f64(if seconds.is_finite() { seconds } else { 0.0 })
}
