//! The per-frame control law, run by the servo on every feature vector. No allocation.
//!
//! With all four marks seen and B at ξ_d ([`Interaction::Desired`]) this is the law as designed:
//! u = −K_ξ (ξ − ξ_d) − Σ K_j u(k − j) (the paper's, or the delay-aware one). Beyond that:
//! - **Three marks.** With one mark missing the law runs the paper's design on the three seen (the rows of
//!   the missing mark zeroed in B; with N = 3 there are no uncontrollable modes), the four gains designed
//!   when the gains arrive, off the per-frame path. The delay-aware law is the paper's gain on the features
//!   predicted through the pipeline (K_j = K B, the crate doc), so it carries over to three marks
//!   as u = −K (ξ̄ + B Σ u(k − j)).
//! - **Scheduled gain** ([`Interaction::Mean`], [`Interaction::Current`]): B at the current features and the
//!   depths of the board pose they give, and the gain designed on every frame ([`crate::frame_design`]).
//! - **Feed-forward** of the target's own image motion ([`crate::target_motion`]) through the delay.
//! - **A barrier** at the image border ([`crate::border`]).

use nalgebra::{Matrix6, SMatrix};
use vservo_scene::{Board, CameraIntrinsics, FEATURES, FeatureVector, IsometryMatrix3, MARKS, MarkDepths};

use crate::border::Barrier;
use crate::frame_design::{self, ALL_MARKS, FrameDesign, MarkSet};
use crate::image_jacobian::{extended_image_jacobian, interaction_matrix};
use crate::pose_features::PoseFeatures;
use crate::pose_law::PoseLaw;
use crate::target_motion::TargetMotion;
use crate::twist_rate::{ArmResponse, TwistRateLimit};
use crate::{
    ControlLaw, FeatureGain, Gains, Interaction, InteractionMatrix, LawOptions, MAX_DELAY_FRAMES, Twist,
};

/// What the law needs of a design: the gain on the feature error, the gains on past commands, ξ_d, and what
/// the law designs from on the frame. This is what crosses from the process that designs gains (off the hot
/// path) to the one that runs the law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawGains {
    /// K_ξ (K for the paper's law).
    pub feature_gain: FeatureGain,
    /// K_j on the command sent j + 1 frames ago.
    pub past_input_gains: [Matrix6<f64>; MAX_DELAY_FRAMES],
    /// How many of `past_input_gains` are used.
    pub used_past_gains: usize,
    /// ξ_d.
    pub desired_features: FeatureVector,
    /// Z_d (m).
    pub desired_depths: MarkDepths,
    /// Q.
    pub q: SMatrix<f64, FEATURES, FEATURES>,
    /// R in SI units.
    pub r_si: Matrix6<f64>,
    /// What the law does beyond the paper's.
    pub options: LawOptions,
    /// The pose features of a pose-based law (which runs the delay-aware image law on three marks); `None` for
    /// the image laws.
    pub pose_features: Option<PoseFeatures>,
}

/// The pose features a law servoes on with all four marks seen; `None` for the image laws.
pub fn pose_features_of(law: ControlLaw) -> Option<PoseFeatures> {
    match law {
        ControlLaw::Paper | ControlLaw::DelayAware => None,
        ControlLaw::Pbvs => Some(PoseFeatures::CameraPath),
        ControlLaw::PbvsTarget => Some(PoseFeatures::TargetPath),
        ControlLaw::TwoAndAHalfD => Some(PoseFeatures::TwoAndAHalfD),
    }
}

impl From<&Gains> for LawGains {
    fn from(gains: &Gains) -> Self {
        Self {
            feature_gain: gains.feature_gain,
            past_input_gains: gains.past_input_gains,
            used_past_gains: gains.active_past_input_gains().len(),
            desired_features: gains.desired_features,
            desired_depths: gains.desired_depths,
            q: *gains.q.matrix(),
            r_si: gains.r_si,
            options: gains.options,
            pose_features: pose_features_of(gains.law),
        }
    }
}

/// What does not change while the cell runs: the camera, the board, the vision period and the pipeline's
/// delay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawGeometry {
    /// The camera.
    pub camera: CameraIntrinsics,
    /// The board (for the depths of its pose).
    pub board: Board,
    /// The vision period T (s).
    pub period_s: f64,
    /// The image pipeline's delay (frames).
    pub delay_frames: usize,
}

/// What the law did on a frame beyond the law as designed (the servo publishes it with the twist).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LawFlags {
    /// The border barrier changed the twist.
    pub barrier: bool,
    /// The frame's own design (a scheduled interaction) failed, or a pose-based law found no pose in it (a
    /// degenerate image): the fixed gain for its marks was used.
    pub fixed_gain_fallback: bool,
    /// The target's estimated motion was fed forward.
    pub feedforward: bool,
    /// The twist's change was cut to what the arm follows within the frame ([`TwistRateLimit`]).
    pub rate_limited: bool,
}

/// The servo's state: its gains and the commands it sent in the last frames.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoLaw {
    geometry: LawGeometry,
    gains: LawGains,
    /// B at ξ_d, Z_d.
    b_desired: InteractionMatrix,
    /// The fixed design on all four marks (for its pseudo-inverse).
    full: Option<FrameDesign>,
    /// The fixed design on the marks other than m.
    without: [Option<FrameDesign>; MARKS],
    /// The pose-based law, when one is chosen and ξ_d gives a pose.
    pose_law: Option<PoseLaw>,
    r_inverse: Matrix6<f64>,
    /// Commands sent, most recent first.
    history: [Twist; MAX_DELAY_FRAMES],
    /// The depths the law last estimated (Z_d before any).
    depths: MarkDepths,
    target: TargetMotion,
    /// What the law did on the last frame it computed a twist for.
    flags: LawFlags,
    /// The bound on the twist's change between frames, when the arm's limits are known.
    rate_limit: Option<TwistRateLimit>,
    /// The time constant (s) of the first-order lag through which the camera's velocity follows the twist
    /// sent (0: at once, the paper's robot).
    arm_lag_s: f64,
    /// e^(−T/τ) of that lag: how much of the camera's velocity is left after a frame (0 without a lag).
    velocity_decay: f64,
    /// The camera's velocity as the lag gives it, estimated from the twists sent: at the start of the coming
    /// frame first, then of the frames of `history`.
    velocity: [Twist; MAX_DELAY_FRAMES + 1],
    /// How long (s) the camera has moved since the frame's capture beyond the pipeline's whole frames: motion
    /// the image cannot show.
    unseen_s: f64,
}

impl ServoLaw {
    /// A law at rest (no command sent yet) with these gains.
    pub fn new(geometry: LawGeometry, gains: &Gains) -> Self {
        let law_gains = LawGains::from(gains);
        let mut law = Self {
            geometry,
            gains: law_gains,
            b_desired: InteractionMatrix::zeros(),
            full: None,
            without: [None; MARKS],
            pose_law: None,
            r_inverse: Matrix6::identity(),
            history: [Twist::zeros(); MAX_DELAY_FRAMES],
            depths: gains.desired_depths,
            target: TargetMotion::default(),
            flags: LawFlags::default(),
            rate_limit: None,
            arm_lag_s: 0.0,
            velocity_decay: 0.0,
            velocity: [Twist::zeros(); MAX_DELAY_FRAMES + 1],
            unseen_s: 0.0,
        };
        law.set_law_gains(&law_gains);
        law
    }

    /// Swaps in new gains (and their ξ_d), keeping the command history so that the twist does not jump
    /// beyond what the new gain itself implies.
    pub fn set_gains(&mut self, gains: &Gains) {
        self.set_law_gains(&LawGains::from(gains));
    }

    /// [`ServoLaw::set_gains`] from the law's part of a design; designs the gains on three marks.
    pub fn set_law_gains(&mut self, gains: &LawGains) {
        let target_changed = gains.desired_features != self.gains.desired_features;
        self.gains = *gains;
        self.gains.used_past_gains = gains.used_past_gains.min(MAX_DELAY_FRAMES);
        let g = &self.geometry;
        self.b_desired =
            interaction_matrix(&g.camera, &gains.desired_features, &gains.desired_depths, g.period_s);
        self.full = frame_design::design(&self.b_desired, &gains.q, &gains.r_si).ok();
        for mark in 0..MARKS {
            let b = frame_design::masked(&self.b_desired, ALL_MARKS & !(1 << mark));
            self.without[mark] = frame_design::design(&b, &gains.q, &gains.r_si).ok();
        }
        self.r_inverse = gains.r_si.try_inverse().unwrap_or_else(Matrix6::identity);
        self.pose_law = gains.pose_features.and_then(|features| {
            PoseLaw::new(features, &g.camera, &g.board, &gains.desired_features, &gains.options, g.period_s)
        });
        if target_changed {
            self.target.reset();
        }
    }

    /// What the arm follows of the twist (`None`: all of it at once, the paper's ideal robot): every twist the
    /// law computes is shaped to its rate limit, and the law's prediction of the motion still to come takes
    /// its lag.
    pub fn set_arm_response(&mut self, response: Option<ArmResponse>) {
        self.rate_limit = response.map(|r| r.rate_limit);
        self.arm_lag_s = response.map_or(0.0, |r| r.lag_s).max(0.0);
        self.velocity_decay =
            if self.arm_lag_s > 0.0 { (-self.geometry.period_s / self.arm_lag_s).exp() } else { 0.0 };
        self.velocity = [Twist::zeros(); MAX_DELAY_FRAMES + 1];
    }

    /// The dynamics override in force (0–1]: the rate limit follows the share of the arm's limits the
    /// reference keeps.
    pub fn set_speed_scale(&mut self, speed_scale: f64) {
        self.rate_limit = self.rate_limit.map(|limit| limit.at_speed_scale(speed_scale));
    }

    /// How long (s, 0 to one vision period) the camera has moved since the capture of the frame the law takes
    /// next, beyond the pipeline's whole frames of delay: with an arm response set, the law predicts that
    /// motion (the camera's estimated velocity over that time) too. The lockstep's pipeline is whole frames
    /// (0); a real camera's frame reaches the servo some milliseconds after its capture.
    pub fn set_unseen_s(&mut self, unseen_s: f64) {
        self.unseen_s = if unseen_s.is_finite() { unseen_s.clamp(0.0, self.geometry.period_s) } else { 0.0 };
    }

    /// The desired features ξ_d.
    pub fn desired_features(&self) -> &FeatureVector {
        &self.gains.desired_features
    }

    /// What the law did beyond the law as designed on the last frame: all false after a frame it did not
    /// compute the twist for ([`ServoLaw::step`] gave none, or [`ServoLaw::hold`], [`ServoLaw::sent`]).
    pub fn flags(&self) -> LawFlags {
        self.flags
    }

    /// The twist for a measured feature vector with all four marks: u = −K_ξ (ξ − ξ_d) − Σ K_j u(k − j).
    pub fn command(&mut self, measured: &FeatureVector) -> Twist {
        let delay = self.geometry.delay_frames.min(MAX_DELAY_FRAMES);
        let error = measured - self.gains.desired_features + self.b_desired * self.lag_correction(delay);
        let twist = self.designed_law(&error);
        let to_go = self
            .rate_limit
            .and(self.full)
            .map(|full| -(full.pseudo_inverse * (error + self.in_pipeline(&self.b_desired, delay))));
        self.remember_shaped(twist, to_go.as_ref())
    }

    /// What the arm's lag changes in the motion still to come from the twists sent, as a twist held for one
    /// frame: in each frame of the pipeline the camera moved (v − u)(τ/T)(1 − e^(−T/τ)) less or more than its
    /// twist u asked, v its velocity at the frame's start; from now on it goes on by vτ before it comes to
    /// rest; and since the capture it moved by v over the time the image cannot show. Zero without a lag.
    fn lag_correction(&self, delay: usize) -> Twist {
        let lag_s = self.arm_lag_s;
        if lag_s <= 0.0 {
            return Twist::zeros();
        }
        let period_s = self.geometry.period_s;
        let spill = (lag_s / period_s) * (1.0 - self.velocity_decay);
        let mut correction = self.velocity[0] * ((lag_s + self.unseen_s) / period_s);
        for (sent, at_start) in self.history.iter().zip(&self.velocity[1..]).take(delay) {
            correction += (at_start - sent) * spill;
        }
        correction
    }

    /// What the commands still in the pipeline (the last `delay`) do to the features through `b`, with what the
    /// arm's lag changes in the motion still to come ([`ServoLaw::lag_correction`]).
    fn in_pipeline(&self, b: &InteractionMatrix, delay: usize) -> FeatureVector {
        let mut in_pipeline = FeatureVector::zeros();
        for past in self.history.iter().take(delay) {
            in_pipeline += b * past;
        }
        in_pipeline + b * self.lag_correction(delay)
    }

    /// The law as designed, on the error of all four marks: −K_ξ e − Σ K_j u(k − j).
    fn designed_law(&self, error: &FeatureVector) -> Twist {
        let mut twist = -(self.gains.feature_gain * error);
        for (gain, past) in
            self.gains.past_input_gains.iter().zip(&self.history).take(self.gains.used_past_gains)
        {
            twist -= gain * past;
        }
        twist
    }

    /// The twist for frame `frame` with the features seen (NaN where a mark is not), and the camera's pose
    /// at capture when known. `None` (and nothing remembered) with fewer than three marks: the caller
    /// decides what to send, and tells the law with [`ServoLaw::sent`].
    pub fn step(
        &mut self,
        frame: u64,
        measured: &FeatureVector,
        base_from_camera: Option<&IsometryMatrix3<f64>>,
    ) -> Option<Twist> {
        let marks = frame_design::finite_marks(measured);
        let options = self.gains.options;
        self.flags = LawFlags::default();
        let pose_based = self.gains.pose_features.is_some();
        let board_pose = if (options.needs_depths() || pose_based) && marks == ALL_MARKS {
            let g = &self.geometry;
            g.camera.board_pose_from_features(&g.board, measured)
        } else {
            None
        };
        if let Some(pose) = &board_pose {
            self.take_depths(pose);
        }
        if options.feedforward {
            self.target.update(&self.geometry.camera, frame, measured, &self.depths, marks, base_from_camera);
        }
        if frame_design::mark_count(marks) < 3 {
            return None;
        }
        if pose_based && marks == ALL_MARKS {
            if let Some(twist) = board_pose.and_then(|pose| self.pose_twist(measured, &pose)) {
                return Some(self.remember_shaped(twist, None));
            }
            // no pose or no pose error on this frame (a degenerate image): the image law
            self.flags.fixed_gain_fallback = true;
        }
        let plain = marks == ALL_MARKS && options.image_law_as_designed();
        if plain {
            return Some(self.command(measured));
        }

        let mut error = measured - self.gains.desired_features;
        for value in error.iter_mut() {
            if !value.is_finite() {
                *value = 0.0;
            }
        }
        let (b, design) = self.design_on_frame(measured, marks);
        // the marks seen with no design for them (a degenerate ξ_d): hold
        let Some(design) = design else {
            self.flags = LawFlags::default();
            return None;
        };

        let use_fixed_full = marks == ALL_MARKS && options.interaction == Interaction::Desired;
        let delay = self.geometry.delay_frames.min(MAX_DELAY_FRAMES);
        // the features as they are now: the delayed error plus what the commands in the pipeline did
        let in_pipeline = self.in_pipeline(&b, delay);
        self.flags.feedforward = options.feedforward && self.target.settled();
        let (drift_to_now, drift_next) = self.target_drift(delay, marks);
        let mut twist = if use_fixed_full {
            self.designed_law(&error) - self.gains.feature_gain * drift_to_now
        } else {
            // the delay-aware law is the paper's gain on the predicted features (K_j = K B)
            let mut predicted = error + drift_to_now;
            if self.gains.used_past_gains > 0 || self.arm_lag_s > 0.0 {
                predicted += in_pipeline;
            }
            -(design.gain * predicted)
        };
        // cancel the target's motion over the coming frame
        twist -= design.pseudo_inverse * drift_next;
        if options.border_margin_px > 0.0 {
            let predicted = measured_or_zero(measured) + in_pipeline + drift_to_now;
            let barrier = Barrier::new(&self.geometry.camera, options.border_margin_px, self.r_inverse);
            let (kept, corrections) = barrier.keep_inside(twist, &b, &predicted, &drift_next, marks);
            self.flags.barrier = corrections > 0;
            twist = kept;
        }
        let to_go = -(design.pseudo_inverse * (error + in_pipeline + drift_to_now));
        Some(self.remember_shaped(twist, Some(&to_go)))
    }

    /// B and the design for the marks seen on this frame: at ξ_d, or scheduled on the frame (the fixed gain for
    /// its marks when the frame's own design fails); no design for marks whose desired images are degenerate.
    fn design_on_frame(
        &mut self,
        measured: &FeatureVector,
        marks: MarkSet,
    ) -> (InteractionMatrix, Option<FrameDesign>) {
        let fixed = if marks == ALL_MARKS {
            self.full
        } else {
            let missing = (0..MARKS).find(|m| marks & (1 << m) == 0).unwrap_or(0);
            self.without[missing]
        };
        // a frame whose own design fails (a degenerate image) takes the fixed gain for its marks
        match self.gains.options.interaction {
            Interaction::Desired => (frame_design::masked(&self.b_desired, marks), fixed),
            Interaction::Mean | Interaction::Current => {
                let g = &self.geometry;
                let filled = filled_with(measured, &self.gains.desired_features);
                let seen = extended_image_jacobian(&g.camera, &filled, &self.depths);
                let jacobian = if self.gains.options.interaction == Interaction::Mean {
                    let desired = extended_image_jacobian(
                        &g.camera,
                        &self.gains.desired_features,
                        &self.gains.desired_depths,
                    );
                    (seen + desired) * 0.5
                } else {
                    seen
                };
                let b = frame_design::masked(&(jacobian * g.period_s), marks);
                match frame_design::design(&b, &self.gains.q, &self.gains.r_si) {
                    Ok(design) => (b, Some(design)),
                    Err(_) => {
                        self.flags.fixed_gain_fallback = true;
                        (frame_design::masked(&self.b_desired, marks), fixed)
                    }
                }
            }
        }
    }

    /// The target's own image motion over the pipeline's delay and over the coming frame, on the marks seen;
    /// zero unless it is fed forward.
    fn target_drift(&self, delay: usize, marks: MarkSet) -> (FeatureVector, FeatureVector) {
        if !self.flags.feedforward {
            return (FeatureVector::zeros(), FeatureVector::zeros());
        }
        (
            masked_features(&self.target.motion_over(delay), marks),
            masked_features(&self.target.motion_in_frame(delay), marks),
        )
    }

    /// The depths of the marks at the board's pose, where finite and in front of the camera.
    fn take_depths(&mut self, camera_from_board: &IsometryMatrix3<f64>) {
        for (depth, mark) in self.depths.iter_mut().zip(&self.geometry.board.marks_in_board) {
            let z = (camera_from_board * mark).z;
            if z.is_finite() && z > 0.0 {
                *depth = z;
            }
        }
    }

    /// The pose-based law's twist on a frame with all four marks, within the barrier when one is set; `None`
    /// when the law gives none.
    fn pose_twist(
        &mut self,
        measured: &FeatureVector,
        camera_from_board: &IsometryMatrix3<f64>,
    ) -> Option<Twist> {
        let pose_law = self.pose_law?;
        let delay = self.geometry.delay_frames.min(MAX_DELAY_FRAMES);
        let in_pipeline: Twist = self.history.iter().take(delay).sum();
        let twist = pose_law.twist(camera_from_board, &in_pipeline).ok()?;
        let margin_px = self.gains.options.border_margin_px;
        if margin_px <= 0.0 {
            return Some(twist);
        }
        let g = &self.geometry;
        let b = extended_image_jacobian(&g.camera, measured, &self.depths) * g.period_s;
        let predicted = measured + b * in_pipeline;
        let barrier = Barrier::new(&g.camera, margin_px, self.r_inverse);
        let (kept, corrections) =
            barrier.keep_inside(twist, &b, &predicted, &FeatureVector::zeros(), ALL_MARKS);
        self.flags.barrier = corrections > 0;
        Some(kept)
    }

    /// No usable features this frame: command zero, and remember that zero was sent.
    pub fn hold(&mut self) -> Twist {
        self.sent(Twist::zeros());
        Twist::zeros()
    }

    /// Tells the law the twist sent this frame when it did not compute it (reacquiring the marks). What it
    /// estimated of the target's own motion is forgotten: the marks' motion while it looked, with the depths of
    /// before, is no estimate to feed forward once it servoes again.
    pub fn sent(&mut self, twist: Twist) {
        self.flags = LawFlags::default();
        self.target.reset();
        self.remember(twist);
    }

    /// The law's twist shaped by the rate limit (when one is set; braking in time for `to_go`, the twist that
    /// would close the predicted error within a frame), remembered as sent.
    fn remember_shaped(&mut self, twist: Twist, to_go: Option<&Twist>) -> Twist {
        let sent = match &self.rate_limit {
            Some(limit) => limit.shape(&self.history[0], &twist, to_go),
            None => twist,
        };
        self.flags.rate_limited = sent != twist;
        self.remember(sent);
        sent
    }

    fn remember(&mut self, twist: Twist) {
        self.history.rotate_right(1);
        self.history[0] = twist;
        let decay = self.velocity_decay;
        let next = self.velocity[0] * decay + twist * (1.0 - decay);
        self.velocity.rotate_right(1);
        self.velocity[0] = next;
    }
}

/// ξ with the marks not seen set to ξ_d (their rows are zeroed in B anyway; J needs finite numbers).
fn filled_with(measured: &FeatureVector, desired: &FeatureVector) -> FeatureVector {
    measured.zip_map(desired, |m, d| if m.is_finite() { m } else { d })
}

fn measured_or_zero(measured: &FeatureVector) -> FeatureVector {
    measured.map(|v| if v.is_finite() { v } else { 0.0 })
}

fn masked_features(features: &FeatureVector, marks: MarkSet) -> FeatureVector {
    let mut out = *features;
    for mark in (0..MARKS).filter(|m| marks & (1 << m) == 0) {
        out[2 * mark] = 0.0;
        out[2 * mark + 1] = 0.0;
    }
    out
}
