//! The servo stage: the LQ law, and what it does with a frame it cannot fully use.
//!
//! - A mark outside the image is no measurement: taken as missing, and said ([`ServoStep::outside`]).
//! - All four marks: the law's twist ([`ServoVerdict::Servoing`]).
//! - Three: the law on those three ([`ServoVerdict::ServoingOnThree`]).
//! - Two or fewer: the camera is steered back towards where it was when all four were last seen, its own
//!   motion since then known from the joint states at capture ([`ServoVerdict::Reacquiring`]). Before all four
//!   have ever been seen (a start with part of the target out of view), towards where the configuration
//!   predicts them: the camera's pose at `desired.joints_rad`. Without the camera's pose (no joint state at
//!   capture), the camera turns the marks it sees towards their desired image points ([`acquiring_turn`], also
//!   `Reacquiring`); with none seen, zero twist ([`ServoVerdict::MarksMissing`]). Either way the daemon's
//!   `faults.target_lost_s` bounds how long the servo may look: then a named safe stop (`target_lost`).
//! - Held in a safe stop: zero twist, the law remembering it ([`ServoVerdict::Held`]).

use nalgebra::Point2;
use vservo_config::Reacquire;
use vservo_control::{ArmResponse, Gains, LawFlags, LawGains, LawGeometry, ServoLaw, Twist};
use vservo_scene::{CameraIntrinsics, FeatureVector, IsometryMatrix3, MARKS};

/// Why the servo sent the twist it sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoVerdict {
    /// No frame has come through the pipeline yet: zero twist.
    Waiting,
    /// The law's twist for a frame with all four marks.
    Servoing,
    /// The law's twist on the three marks seen (bit m set for the missing mark m).
    ServoingOnThree(u8),
    /// Two or more marks missing (bit m set for mark m), or one and no design for the three seen (their
    /// desired images in a line): steering back to where all were last seen.
    Reacquiring(u8),
    /// Marks missing and nowhere known to go back to: zero twist.
    MarksMissing(u8),
    /// The cell is held in a safe stop: zero twist.
    Held,
}

impl ServoVerdict {
    /// Whether the twist sent with this verdict may move the arm (servoing on four or three marks, or
    /// reacquiring); any other means stop, whatever the twist's numbers say.
    pub fn moves(&self) -> bool {
        matches!(self, Self::Servoing | Self::ServoingOnThree(_) | Self::Reacquiring(_))
    }

    /// The marks missing (bit m set for mark m); none when waiting, servoing on four or held.
    pub fn missing_mask(&self) -> u8 {
        match *self {
            Self::ServoingOnThree(mask) | Self::Reacquiring(mask) | Self::MarksMissing(mask) => mask,
            Self::Waiting | Self::Servoing | Self::Held => 0,
        }
    }
}

/// A frame leaving the pipeline, as the servo takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoInput<'a> {
    /// The frame number.
    pub frame: u64,
    /// ξ (px), NaN where a mark is not valid.
    pub features: &'a FeatureVector,
    /// The camera's pose at capture, if known, in the frame that holds the board still (the base for a hand
    /// camera, the tool for a fixed one: [`crate::DeliveredFrame::holder_from_camera`]).
    pub holder_from_camera: Option<&'a IsometryMatrix3<f64>>,
    /// How long (s) since the capture beyond the pipeline's whole frames of delay: the camera's motion the
    /// image cannot show (0 in the lockstep, whose pipeline is whole frames).
    pub unseen_s: f64,
}

/// What the servo made of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoStep {
    /// The twist to send.
    pub twist: Twist,
    /// Why.
    pub verdict: ServoVerdict,
    /// The marks refused as outside the image (bit m set for mark m): taken as missing.
    pub outside: u8,
    /// RMS of ξ − ξ_d over the marks taken (px); NaN when none is (or no frame yet).
    pub error_px: f64,
}

/// The servo: the law, its command history, and the pose where all marks were last seen.
#[derive(Debug, Clone)]
pub struct ServoStage {
    law: ServoLaw,
    camera: CameraIntrinsics,
    period_s: f64,
    reacquire: Reacquire,
    /// Where the camera last saw all four marks (in the frame that holds the board still); before it has,
    /// where the configuration predicts it would (the camera's pose at the desired joints).
    last_seen_whole: Option<IsometryMatrix3<f64>>,
}

impl ServoStage {
    pub(crate) fn new(
        geometry: LawGeometry,
        gains: &Gains,
        reacquire: Reacquire,
        holder_from_desired_camera: IsometryMatrix3<f64>,
    ) -> Self {
        Self {
            law: ServoLaw::new(geometry, gains),
            camera: geometry.camera,
            period_s: geometry.period_s,
            reacquire,
            last_seen_whole: Some(holder_from_desired_camera),
        }
    }

    /// What the arm follows of the twist (`None`: all of it at once, the paper's ideal robot).
    pub fn set_arm_response(&mut self, response: Option<ArmResponse>) {
        self.law.set_arm_response(response);
    }

    /// The dynamics override in force: the rate limit follows the share of the arm's limits the reference
    /// keeps.
    pub fn set_speed_scale(&mut self, speed_scale: f64) {
        self.law.set_speed_scale(speed_scale);
    }

    /// The desired features ξ_d.
    pub fn desired_features(&self) -> &FeatureVector {
        self.law.desired_features()
    }

    /// Swaps in new gains, keeping the command history (no twist jump beyond the new gain's own).
    pub fn set_gains(&mut self, gains: &LawGains) {
        self.law.set_law_gains(gains);
    }

    /// What the law did beyond the law as designed on the last frame [`ServoStage::step`] took (all false
    /// when it reacquired or held).
    pub fn law_flags(&self) -> LawFlags {
        self.law.flags()
    }

    /// The frame leaving the pipeline now while the cell is held in a safe stop: zero twist, and the law
    /// remembers that zero was sent (so that a delay-aware law resumes from what the arm really got).
    pub fn held(&mut self, input: ServoInput<'_>) -> ServoStep {
        let (features, outside) = self.taken_inside_image(input.features);
        let error_px = feature_error_px(&features, self.desired_features());
        ServoStep { twist: self.law.hold(), verdict: ServoVerdict::Held, outside, error_px }
    }

    /// The twist for the frame leaving the pipeline now (`None` before the first one has).
    pub fn step(&mut self, delivered: Option<ServoInput<'_>>) -> ServoStep {
        let Some(input) = delivered else {
            let verdict = ServoVerdict::Waiting;
            return ServoStep { twist: Twist::zeros(), verdict, outside: 0, error_px: f64::NAN };
        };
        let (features, outside) = self.taken_inside_image(input.features);
        let error_px = feature_error_px(&features, self.desired_features());
        self.law.set_unseen_s(input.unseen_s);
        let (twist, verdict) = self.law_on(input.frame, &features, input.holder_from_camera);
        ServoStep { twist, verdict, outside, error_px }
    }

    /// The features with each mark outside the image set to NaN, and those marks (bit m for mark m). The
    /// features are pinhole pixels; whether a mark is in the image is judged where the lens shows it (its
    /// observed pixel).
    fn taken_inside_image(&self, seen: &FeatureVector) -> (FeatureVector, u8) {
        let mut features = *seen;
        let mut outside = 0u8;
        for mark in 0..MARKS {
            let pixel = Point2::new(seen[2 * mark], seen[2 * mark + 1]);
            let measured = pixel.x.is_finite() && pixel.y.is_finite();
            if measured && !self.camera.contains(&self.camera.observed_of_pinhole(&pixel)) {
                features[2 * mark] = f64::NAN;
                features[2 * mark + 1] = f64::NAN;
                outside |= 1 << mark;
            }
        }
        (features, outside)
    }

    /// The law's twist on the marks seen, or the way back to where all were last seen.
    fn law_on(
        &mut self,
        frame: u64,
        seen: &FeatureVector,
        holder_from_camera: Option<&IsometryMatrix3<f64>>,
    ) -> (Twist, ServoVerdict) {
        let missing = missing_marks(seen);
        if missing == 0 {
            self.last_seen_whole = holder_from_camera.copied();
        }
        match self.law.step(frame, seen, holder_from_camera) {
            Some(twist) if missing == 0 => (twist, ServoVerdict::Servoing),
            Some(twist) => (twist, ServoVerdict::ServoingOnThree(missing)),
            None => {
                let turn = match (self.last_seen_whole, holder_from_camera) {
                    (Some(then), Some(now)) => {
                        Some(steer_towards(now, &then, self.period_s, &self.reacquire))
                    }
                    // the camera's own pose unknown: turn the marks it sees towards their desired points
                    _ => acquiring_turn(&self.camera, seen, self.law.desired_features(), &self.reacquire),
                };
                match turn {
                    Some(twist) => {
                        self.law.sent(twist);
                        (twist, ServoVerdict::Reacquiring(missing))
                    }
                    None => (self.law.hold(), ServoVerdict::MarksMissing(missing)),
                }
            }
        }
    }
}

/// The marks not seen (bit m set for mark m): a coordinate that is not finite.
fn missing_marks(seen: &FeatureVector) -> u8 {
    let mut missing = 0u8;
    for mark in 0..seen.len() / 2 {
        if !(seen[2 * mark].is_finite() && seen[2 * mark + 1].is_finite()) {
            missing |= 1 << mark;
        }
    }
    missing
}

/// RMS of ξ − ξ_d over the finite features (px); NaN when none is.
pub fn feature_error_px(features: &FeatureVector, desired: &FeatureVector) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (f, d) in features.iter().zip(desired.iter()) {
        if f.is_finite() {
            sum += (f - d) * (f - d);
            n += 1;
        }
    }
    if n == 0 { f64::NAN } else { (sum / n as f64).sqrt() }
}

/// The camera twist (in the camera frame) that moves the camera from `now` towards `then` with the
/// `[reacquire]` gain, its speeds capped, and never beyond `then` within one frame.
pub fn steer_towards(
    now: &IsometryMatrix3<f64>,
    then: &IsometryMatrix3<f64>,
    period_s: f64,
    reacquire: &Reacquire,
) -> Twist {
    let now_from_then = now.inverse() * then;
    let translation = now_from_then.translation.vector;
    let rotation = now_from_then.rotation.scaled_axis();
    let gain = reacquire.gain_per_s.min(1.0 / period_s);
    let mut v = translation * gain;
    let mut w = rotation * gain;
    if v.norm() > reacquire.max_speed_m_s {
        v *= reacquire.max_speed_m_s / v.norm();
    }
    if w.norm() > reacquire.max_rotation_rad_s {
        w *= reacquire.max_rotation_rad_s / w.norm();
    }
    Twist::new(v.x, v.y, v.z, w.x, w.y, w.z)
}

/// Before all four marks have been seen: the camera's rotation that moves the mean of the marks it sees towards
/// the mean of their desired image points (the rotational part of the point's image Jacobian, which needs no
/// depth), at the `[reacquire]` gain and within its rotation cap. `None` with no mark seen.
pub fn acquiring_turn(
    camera: &CameraIntrinsics,
    seen: &FeatureVector,
    desired: &FeatureVector,
    reacquire: &Reacquire,
) -> Option<Twist> {
    let (mut now, mut wanted, mut count) = (Point2::origin(), Point2::origin(), 0.0);
    for mark in (0..MARKS).filter(|m| seen[2 * m].is_finite() && seen[2 * m + 1].is_finite()) {
        let normalized =
            |f: &FeatureVector| camera.normalized_of_pixel(&Point2::new(f[2 * mark], f[2 * mark + 1]));
        now += normalized(seen).coords;
        wanted += normalized(desired).coords;
        count += 1.0;
    }
    if count == 0.0 {
        return None;
    }
    let (now, wanted) = (now / count, wanted / count);
    // ẋ = −(1 + x²) ω_y + y ω_z …, ẏ = (1 + y²) ω_x − x ω_z …: turn about x and y only
    let gain = reacquire.gain_per_s;
    let mut w = nalgebra::Vector3::new(
        -gain * (now.y - wanted.y) / (1.0 + now.y * now.y),
        gain * (now.x - wanted.x) / (1.0 + now.x * now.x),
        0.0,
    );
    if w.norm() > reacquire.max_rotation_rad_s {
        w *= reacquire.max_rotation_rad_s / w.norm();
    }
    Some(Twist::new(0.0, 0.0, 0.0, w.x, w.y, w.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3, Vector3};

    fn servo() -> ServoStage {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default config loads")
                .cell;
        crate::Cell::new(&config).expect("the default cell").servo()
    }

    #[test]
    fn a_mark_outside_the_image_is_taken_as_missing_and_said() {
        let mut servo = servo();
        let mut features = *servo.desired_features();
        features[2] = 600.0; // mark 2 beyond the right border of the 512 px image
        let step = servo.step(Some(ServoInput {
            frame: 1,
            features: &features,
            holder_from_camera: None,
            unseen_s: 0.0,
        }));
        assert_eq!(step.outside, 0b10);
        assert_eq!(step.verdict, ServoVerdict::ServoingOnThree(0b10));
        assert_eq!(step.error_px, 0.0, "the other three are at ξ_d; the refused mark is not counted");
        // a mark already missing is not refused again; one on the border is inside
        features[2] = f64::NAN;
        features[0] = 512.0;
        let step = servo.step(Some(ServoInput {
            frame: 2,
            features: &features,
            holder_from_camera: None,
            unseen_s: 0.0,
        }));
        assert_eq!((step.outside, step.verdict.missing_mask()), (0, 0b10));
    }

    #[test]
    fn held_and_waiting_send_zero_and_do_not_move() {
        let mut servo = servo();
        let waiting = servo.step(None);
        assert_eq!((waiting.twist, waiting.verdict), (Twist::zeros(), ServoVerdict::Waiting));
        assert!(waiting.error_px.is_nan());
        let mut features = *servo.desired_features();
        features[1] = -3.0;
        let held =
            servo.held(ServoInput { frame: 1, features: &features, holder_from_camera: None, unseen_s: 0.0 });
        assert_eq!((held.twist, held.verdict, held.outside), (Twist::zeros(), ServoVerdict::Held, 0b1));
        assert!(!held.verdict.moves() && !waiting.verdict.moves() && !ServoVerdict::MarksMissing(3).moves());
        assert!(ServoVerdict::Servoing.moves() && ServoVerdict::Reacquiring(3).moves());
    }

    #[test]
    fn before_any_whole_view_the_seen_marks_are_turned_towards_their_desired_points() {
        let mut servo = servo();
        let desired = *servo.desired_features();
        // only marks 1 and 2 seen, 60 px right of and 40 px below their desired points
        let mut seen = FeatureVector::from_element(f64::NAN);
        for mark in 0..2 {
            seen[2 * mark] = desired[2 * mark] + 60.0;
            seen[2 * mark + 1] = desired[2 * mark + 1] + 40.0;
        }
        let step = servo.step(Some(ServoInput {
            frame: 1,
            features: &seen,
            holder_from_camera: None,
            unseen_s: 0.0,
        }));
        assert_eq!(step.verdict, ServoVerdict::Reacquiring(0b1100));
        // turning about +y moves image points left (ẋ = −(1 + x²) ω_y), about −x moves them up
        assert!(step.twist[4] > 0.0 && step.twist[3] < 0.0, "{}", step.twist);
        assert!(step.twist.fixed_rows::<3>(0).norm() == 0.0 && step.twist[5] == 0.0, "a turn only");
        let reacquire = Reacquire::default();
        assert!(step.twist.fixed_rows::<3>(3).norm() <= reacquire.max_rotation_rad_s + 1e-12);
        // the turn moves the image points towards their desired ones: one small step of it, through the
        // rotational columns of the point image Jacobian, lowers the error
        let camera = servo.camera;
        let error_after = |dt: f64| {
            (0..2)
                .map(|m| {
                    let p = camera.normalized_of_pixel(&Point2::new(seen[2 * m], seen[2 * m + 1]));
                    let (wx, wy) = (step.twist[3], step.twist[4]);
                    let x = p.x + dt * (p.x * p.y * wx - (1.0 + p.x * p.x) * wy);
                    let y = p.y + dt * ((1.0 + p.y * p.y) * wx - p.x * p.y * wy);
                    let moved = camera.pixel_of_normalized(&Point2::new(x, y));
                    let (dx, dy) = (moved.x - desired[2 * m], moved.y - desired[2 * m + 1]);
                    dx * dx + dy * dy
                })
                .sum::<f64>()
        };
        assert!(error_after(0.01) < error_after(0.0));
        // no mark seen and none ever: nothing to turn towards
        let none = FeatureVector::from_element(f64::NAN);
        let step = servo.step(Some(ServoInput {
            frame: 2,
            features: &none,
            holder_from_camera: None,
            unseen_s: 0.0,
        }));
        assert_eq!((step.twist, step.verdict), (Twist::zeros(), ServoVerdict::MarksMissing(0b1111)));
    }

    #[test]
    fn steering_back_points_the_camera_to_where_it_was_and_stays_within_its_limits() {
        let then = IsometryMatrix3::identity();
        let now = IsometryMatrix3::from_parts(Translation3::new(0.02, 0.0, 0.0), Rotation3::identity());
        let reacquire = Reacquire::default();
        let twist = steer_towards(&now, &then, 0.085, &reacquire);
        // back along −x of the camera, at the gain
        assert!((twist[0] + 0.02 * reacquire.gain_per_s).abs() < 1e-12, "{twist}");
        assert!(twist.rows(1, 5).amax() < 1e-12);
        let far = IsometryMatrix3::from_parts(
            Translation3::new(1.0, 0.5, 0.0),
            Rotation3::from_axis_angle(&Vector3::z_axis(), 1.0),
        );
        let twist = steer_towards(&far, &then, 0.085, &reacquire);
        assert!(twist.fixed_rows::<3>(0).norm() <= reacquire.max_speed_m_s + 1e-12);
        assert!(twist.fixed_rows::<3>(3).norm() <= reacquire.max_rotation_rad_s + 1e-12);
        assert!(twist[5] < 0.0, "turns back");
        // slower caps, as configured
        let gentle = Reacquire { gain_per_s: 0.5, max_speed_m_s: 0.02, max_rotation_rad_s: 0.1 };
        let twist = steer_towards(&far, &then, 0.085, &gentle);
        assert!((twist.fixed_rows::<3>(0).norm() - 0.02).abs() < 1e-12, "{twist}");
        assert!((twist.fixed_rows::<3>(3).norm() - 0.1).abs() < 1e-12, "{twist}");
        let twist = steer_towards(&now, &then, 0.085, &gentle);
        assert!((twist[0] + 0.02 * 0.5).abs() < 1e-12, "{twist}");
    }
}
