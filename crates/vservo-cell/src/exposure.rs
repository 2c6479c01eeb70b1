//! The simulated camera's exposure: where the board was, relative to the camera, at instants spread over the
//! time the shutter is open (`vision.render.exposure_s`), so that the renderer blurs the image by the motion
//! as a real camera does.
//!
//! The motion over the exposure is the motion between the last frame's capture and this one's, taken as
//! uniform (translation linear, rotation along the shortest arc): the arm moves smoothly over one frame
//! period. The instants are as many as keep the images of the board's points less than a pixel apart,
//! at most [`MAX_INSTANTS`]; a board that moves less than a quarter pixel is rendered once, at the capture.

use nalgebra::{Translation3, UnitQuaternion};
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS};

/// The most instants an exposure is rendered at (each one a render of the whole image).
pub const MAX_INSTANTS: usize = 12;

/// A motion smaller than this (px, any mark) is not blurred.
const STILL_PX: f64 = 0.25;

/// The exposure's settings and the last capture it interpolates from.
#[derive(Debug, Clone)]
pub struct Exposure {
    exposure_s: f64,
    tick_s: f64,
    /// The last capture's tick, the board in the camera then and where the cell believed the camera was.
    last: Option<(u64, IsometryMatrix3<f64>, IsometryMatrix3<f64>)>,
    /// Where the cell believes the camera was in the middle of the last exposure.
    mid_holder_from_camera: IsometryMatrix3<f64>,
    instants: [IsometryMatrix3<f64>; MAX_INSTANTS],
    /// How far the board's image moved over the last exposure (px, the mark that moved most; 0 for one
    /// instant).
    motion_px: f64,
}

impl Exposure {
    /// An exposure of `exposure_s` (0: an instant) for a cell whose ticks last `tick_s`.
    pub fn new(exposure_s: f64, tick_s: f64) -> Self {
        Self {
            exposure_s,
            tick_s,
            last: None,
            instants: [IsometryMatrix3::identity(); MAX_INSTANTS],
            mid_holder_from_camera: IsometryMatrix3::identity(),
            motion_px: 0.0,
        }
    }

    /// How far the board's image moved over the last exposure (px: the motion blur of the mark that moved
    /// most; 0 when it was rendered at one instant).
    pub fn motion_px(&self) -> f64 {
        self.motion_px
    }

    /// Where the cell believes the camera was in the middle of the last exposure: what a blurred image's
    /// features show is where the board was then, not at the exposure's end (a camera's motion taken at the
    /// end would be read as the board's own motion). The capture's pose when it was one instant.
    pub fn mid_holder_from_camera(&self) -> &IsometryMatrix3<f64> {
        &self.mid_holder_from_camera
    }

    /// The board in the camera at each instant of the exposure that ends at `tick`, where it is
    /// `camera_from_board` and the cell believes the camera is at `holder_from_camera`, in time order;
    /// `project` gives the board's points in the image at a pose (`None` when it cannot), to count the
    /// instants the motion needs. One pose (the capture's) when the exposure is an instant, on the first
    /// frame, or when the board hardly moved.
    pub fn instants(
        &mut self,
        tick: u64,
        (camera_from_board, holder_from_camera): (&IsometryMatrix3<f64>, &IsometryMatrix3<f64>),
        project: impl Fn(&IsometryMatrix3<f64>) -> Option<FeatureVector>,
    ) -> &[IsometryMatrix3<f64>] {
        let last = self.last.replace((tick, *camera_from_board, *holder_from_camera));
        self.instants[0] = *camera_from_board;
        self.mid_holder_from_camera = *holder_from_camera;
        self.motion_px = 0.0;
        let Some((last_tick, last_pose, last_holder)) =
            last.filter(|(t, ..)| *t < tick && self.exposure_s > 0.0)
        else {
            return &self.instants[..1];
        };
        let elapsed_s = (tick - last_tick) as f64 * self.tick_s;
        let fraction_of_frame =
            |fraction_of_exposure: f64| 1.0 - self.exposure_s * (1.0 - fraction_of_exposure) / elapsed_s;
        let pose_at = |fraction_of_exposure: f64| {
            between(&last_pose, camera_from_board, fraction_of_frame(fraction_of_exposure).clamp(0.0, 1.0))
        };
        let motion_px = match (project(&pose_at(0.0)), project(camera_from_board)) {
            (Some(start), Some(end)) => largest_motion_px(&start, &end),
            _ => 0.0,
        };
        let count = instants_for(motion_px);
        if count == 1 {
            return &self.instants[..1];
        }
        self.motion_px = motion_px;
        self.mid_holder_from_camera =
            between(&last_holder, holder_from_camera, fraction_of_frame(0.5).clamp(0.0, 1.0));
        for (k, instant) in self.instants.iter_mut().take(count).enumerate() {
            *instant = pose_at((k as f64 + 0.5) / count as f64);
        }
        &self.instants[..count]
    }
}

/// The instants a motion of `motion_px` needs: no two images of a point more than a pixel apart.
fn instants_for(motion_px: f64) -> usize {
    if motion_px.is_nan() || motion_px < STILL_PX {
        return 1;
    }
    (motion_px.ceil() as usize + 1).min(MAX_INSTANTS)
}

/// The largest distance a mark moves between two images of the board (px).
fn largest_motion_px(start: &FeatureVector, end: &FeatureVector) -> f64 {
    (0..MARKS)
        .map(|m| (end[2 * m] - start[2 * m]).hypot(end[2 * m + 1] - start[2 * m + 1]))
        .fold(0.0, f64::max)
}

/// The pose a fraction `s` of the way from `from` to `to`.
fn between(from: &IsometryMatrix3<f64>, to: &IsometryMatrix3<f64>, s: f64) -> IsometryMatrix3<f64> {
    let rotation_from = UnitQuaternion::from_rotation_matrix(&from.rotation);
    let rotation_to = UnitQuaternion::from_rotation_matrix(&to.rotation);
    let rotation = rotation_from.try_slerp(&rotation_to, s, 1e-12).unwrap_or(rotation_to);
    let translation = from.translation.vector.lerp(&to.translation.vector, s);
    IsometryMatrix3::from_parts(Translation3::from(translation), rotation.to_rotation_matrix())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    fn pose(x: f64, yaw: f64) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(
            Translation3::new(x, 0.0, 0.5),
            Rotation3::from_axis_angle(&Vector3::z_axis(), yaw),
        )
    }

    /// The board's four points, 1000 px per metre of x, as a stand-in camera.
    fn project(pose: &IsometryMatrix3<f64>) -> Option<FeatureVector> {
        Some(FeatureVector::from_fn(|i, _| if i % 2 == 0 { 1000.0 * pose.translation.x } else { 0.0 }))
    }

    #[test]
    fn an_instant_or_the_first_frame_is_rendered_once_at_the_capture() {
        let mut instant = Exposure::new(0.0, 0.001);
        instant.instants(0, (&pose(0.0, 0.0), &pose(0.0, 0.0)), project);
        assert_eq!(instant.instants(85, (&pose(0.1, 0.0), &pose(0.2, 0.0)), project), &[pose(0.1, 0.0)]);
        assert_eq!(instant.mid_holder_from_camera(), &pose(0.2, 0.0));
        let mut first = Exposure::new(0.02, 0.001);
        assert_eq!(first.instants(85, (&pose(0.1, 0.0), &pose(0.2, 0.0)), project), &[pose(0.1, 0.0)]);
    }

    #[test]
    fn a_moving_board_is_seen_at_instants_over_the_exposure_ending_at_the_capture() {
        let mut exposure = Exposure::new(0.015, 0.001);
        exposure.instants(0, (&pose(0.0, 0.0), &pose(1.0, 0.0)), project);
        // 8.5 mm in 85 ms: over the 15 ms exposure the board moves 1.5 mm, 1.5 px in this camera
        let instants = exposure.instants(85, (&pose(0.0085, 0.17), &pose(1.0085, 0.0)), project).to_vec();
        assert_eq!(instants.len(), 3, "1.5 px of motion: instants 0.5 px apart");
        assert!((exposure.motion_px() - 1.5).abs() < 1e-9, "{}", exposure.motion_px());
        let expected_x = [0.0070 + 0.0015 / 6.0, 0.00775, 0.0085 - 0.0015 / 6.0];
        for (instant, x) in instants.iter().zip(expected_x) {
            assert!((instant.translation.x - x).abs() < 1e-12, "{} against {x}", instant.translation.x);
        }
        // the rotation turns uniformly with the translation
        let yaw = instants[1].rotation.euler_angles().2;
        assert!((yaw - 0.17 * 0.00775 / 0.0085).abs() < 1e-12, "yaw {yaw}");
        // the camera is believed where it was in the middle of the exposure
        let mid = exposure.mid_holder_from_camera().translation.x;
        assert!((mid - 1.00775).abs() < 1e-12, "{mid}");
    }

    #[test]
    fn a_board_that_hardly_moves_is_not_blurred_and_a_fast_one_is_capped() {
        assert_eq!(instants_for(0.2), 1);
        assert_eq!(instants_for(f64::NAN), 1);
        assert_eq!(instants_for(0.3), 2);
        assert_eq!(instants_for(400.0), MAX_INSTANTS);
    }
}
