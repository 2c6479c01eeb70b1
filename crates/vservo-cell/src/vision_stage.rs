//! The vision stage: camera, extractor, mark tracking and the image pipeline's delay.

use std::collections::VecDeque;

use vservo_arm::{JointVector, SerialArm};
use vservo_config::CellConfig;
use vservo_scene::{Board, CameraIntrinsics, CameraMount, FeatureVector, IsometryMatrix3, MARKS};
use vservo_vision::GrayImage;
use vservo_vision::source::SimulatedCamera;
use vservo_vision::{Extraction, Extractor, Prediction, TagExtractor};

use crate::exposure::Exposure;

/// After this many frames in a row with a mark missing, the tracker gives up its prediction and matches
/// the layout again.
pub const RELOCK_AFTER_FRAMES: u32 = 3;

/// Where the lens shows the marks whose pinhole pixels are `pinhole` (the same features without distortion).
fn observed_features(camera: &CameraIntrinsics, pinhole: &FeatureVector) -> FeatureVector {
    let mut observed = *pinhole;
    for mark in 0..MARKS {
        let seen =
            camera.observed_of_pinhole(&nalgebra::Point2::new(pinhole[2 * mark], pinhole[2 * mark + 1]));
        observed[2 * mark] = seen.x;
        observed[2 * mark + 1] = seen.y;
    }
    observed
}

/// A frame leaving the image pipeline: what the servo sees now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeliveredFrame {
    /// Its frame number.
    pub frame: u64,
    /// The plant tick at which its image was taken.
    pub capture_tick: u64,
    /// ξ (px): the marks' pinhole pixels (undistorted, `vision.undistort`), NaN where a mark is not valid
    /// or its observed position has no undistorted one.
    pub features: FeatureVector,
    /// Where the camera was when the image was taken (from the arm's joints then), if known, in the frame
    /// that holds the board still: the arm's base for a hand camera, the tool for a fixed one
    /// (`CameraMount::holder_from_camera`). Its change is the camera's motion relative to the board.
    pub holder_from_camera: Option<IsometryMatrix3<f64>>,
}

/// What one frame produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisionFrame {
    /// The extraction from this frame's image.
    pub captured: Extraction,
    /// The true projections of the disc centres at capture time, by the real camera (`[camera.truth]`) to
    /// its pinhole pixels (NaN if a mark is behind the camera).
    pub truth: FeatureVector,
    /// Where the camera really was (`[camera.truth]`'s mount; the frame delivered to the servo carries the
    /// believed one).
    pub base_from_camera: IsometryMatrix3<f64>,
    /// The board as the real camera saw it (at the end of the exposure).
    pub camera_from_board: IsometryMatrix3<f64>,
    /// How far the board's image moved while the shutter was open (px, the mark that moved most: the
    /// motion blur; 0 for an instant, `vision.render.exposure_s`).
    pub motion_blur_px: f64,
    /// The frame leaving the pipeline now (`pipeline_delay_frames` older than this one), if any has yet.
    pub delivered: Option<DeliveredFrame>,
}

/// The simulated camera and the feature extractor, with the tracker's memory and the pipeline.
#[derive(Debug, Clone)]
pub struct VisionStage {
    arm: SerialArm,
    /// Where the cell believes the camera is (the pose delivered with the features follows from it).
    mount: CameraMount,
    /// Where the simulated camera really is (`[camera.truth]`; the believed mount unless told otherwise).
    true_mount: CameraMount,
    /// The simulated camera's real intrinsics (the believed ones unless told otherwise).
    true_intrinsics: CameraIntrinsics,
    intrinsics: CameraIntrinsics,
    board: Board,
    layout: FeatureVector,
    /// Whether the features are undistorted before they leave (`vision.undistort`).
    undistort: bool,
    camera: SimulatedCamera,
    /// Where the board was over the simulated camera's exposure (its motion blur).
    exposure: Exposure,
    extractor: Extractor,
    /// With an AprilTag target or a bundle, its extractor (the marks' is then not used).
    tag_extractor: Option<TagExtractor>,
    /// The latest known position of each mark, once all four have been found.
    tracked: Option<FeatureVector>,
    /// Frames in a row with a mark missing.
    frames_with_a_mark_missing: u32,
    pipeline: VecDeque<DeliveredFrame>,
    delay_frames: usize,
    /// The scenario's occlusions, and the tick length that turns a tick into their time.
    scenario: vservo_config::Scenario,
    control_period_s: f64,
}

impl VisionStage {
    pub(crate) fn new(config: &CellConfig, arm: SerialArm) -> Self {
        let truth = config.true_camera();
        // the simulated camera's pipeline delay is modelled here; a camera driver's is physical: its frames
        // are worked on as they arrive and published at once
        let delay_frames =
            if config.vision.source.from_camera_driver() { 0 } else { config.timing.pipeline_delay_frames };
        Self {
            arm,
            mount: config.mount(),
            true_mount: config.true_mount(),
            true_intrinsics: truth.intrinsics,
            intrinsics: config.camera,
            board: config.board,
            layout: observed_features(&config.camera, &config.desired.features),
            undistort: config.vision.undistort,
            // the camera renders as it really is
            camera: SimulatedCamera::new(truth.intrinsics, config.board, config.vision.render),
            exposure: Exposure::new(config.vision.render.exposure_s, config.timing.control_period_s),
            extractor: Extractor::new(
                config.vision.extractor,
                config.camera.width_px(),
                config.camera.height_px(),
            ),
            tag_extractor: TagExtractor::for_board(&config.board, &config.camera),
            tracked: None,
            frames_with_a_mark_missing: 0,
            pipeline: VecDeque::with_capacity(delay_frames + 1),
            delay_frames,
            scenario: config.scenario,
            control_period_s: config.timing.control_period_s,
        }
    }

    /// Updates the prediction for the next frame. A found mark is predicted where it was found; a missing
    /// one moves with the mean displacement of the found ones (so it is looked for where the image has
    /// shifted to). When a mark has been missing for [`RELOCK_AFTER_FRAMES`] frames in a row, or none was
    /// found, tracking is dropped and the next frame matches the layout again: a stale prediction would
    /// otherwise keep a mark lost for good while the servo, missing it, holds the arm still.
    fn update_tracking(&mut self, captured: &Extraction) {
        if captured.all_valid() {
            self.frames_with_a_mark_missing = 0;
            self.tracked = Some(captured.features);
            return;
        }
        self.frames_with_a_mark_missing += 1;
        let Some(mut known) = self.tracked else { return };
        let (mut shift, mut found) = (nalgebra::Vector2::zeros(), 0.0);
        for mark in (0..MARKS).filter(|&m| captured.status[m].is_valid()) {
            let now = nalgebra::Vector2::new(captured.features[2 * mark], captured.features[2 * mark + 1]);
            shift += now - nalgebra::Vector2::new(known[2 * mark], known[2 * mark + 1]);
            found += 1.0;
        }
        if found == 0.0 || self.frames_with_a_mark_missing >= RELOCK_AFTER_FRAMES {
            self.tracked = None;
            return;
        }
        shift /= found;
        for mark in 0..MARKS {
            if captured.status[mark].is_valid() {
                known[2 * mark] = captured.features[2 * mark];
                known[2 * mark + 1] = captured.features[2 * mark + 1];
            } else {
                known[2 * mark] += shift.x;
                known[2 * mark + 1] += shift.y;
            }
        }
        self.tracked = Some(known);
    }

    /// Starts tracking from known mark positions instead of matching the layout: a restarted vision node
    /// takes them from the last features published before it (matching the layout alone is ambiguous for
    /// a nearly point-symmetric set of marks far from the desired pose).
    /// The features are as published (pinhole pixels): the tracker is given where the lens shows them.
    pub fn resume_tracking(&mut self, features: &FeatureVector) {
        if !features.iter().all(|v| v.is_finite()) {
            return;
        }
        self.tracked =
            Some(if self.undistort { observed_features(&self.intrinsics, features) } else { *features });
    }

    /// The frame that leaves the pipeline at the start of this frame period, before this period's image is
    /// taken: with a pipeline delay of d ≥ 1 frames, the one captured d frames ago, whose processing is done.
    /// A real-time shell publishes it at once, so that the processing time of the new image does not add to
    /// the loop's delay. `None` with no delay (the frame must be processed first) or before the pipeline
    /// is full. After this call, [`VisionStage::capture`] delivers nothing for the same period.
    pub fn take_delivered(&mut self) -> Option<DeliveredFrame> {
        if self.delay_frames > 0 && self.pipeline.len() >= self.delay_frames {
            self.pipeline.pop_front()
        } else {
            None
        }
    }

    /// Takes frame `frame` at plant tick `tick` with the arm at `q` and the board at `base_from_board` (a
    /// fixed camera's board rides on the tool: it is where `q` puts it, whatever is given) with the simulated
    /// camera, extracts it and pushes it into the pipeline. The image stays available
    /// ([`VisionStage::image`]) until the next capture.
    pub fn capture(
        &mut self,
        frame: u64,
        tick: u64,
        q: &JointVector,
        base_from_board: &IsometryMatrix3<f64>,
    ) -> VisionFrame {
        let base_from_tool = self.arm.base_from_tool(q);
        // where the cell believes the camera is (what the servo is told), and where it is (what it sees from)
        let holder_from_camera = self.mount.holder_from_camera(&base_from_tool);
        let base_from_true_camera = self.true_mount.base_from_camera(&base_from_tool);
        let base_from_board = self.true_mount.base_from_board(&base_from_tool, base_from_board);
        let camera_from_board = base_from_true_camera.inverse() * base_from_board;
        let hidden = self.scenario.hidden_marks(tick as f64 * self.control_period_s);
        let (intrinsics, board) = (&self.true_intrinsics, &self.board);
        let instants = self.exposure.instants(tick, (&camera_from_board, &holder_from_camera), |pose| {
            intrinsics.project_marks(board, pose).ok()
        });
        self.camera.capture_exposure(instants, frame, hidden);
        // a blurred image shows the board where it was in the middle of the exposure
        let holder_from_camera = *self.exposure.mid_holder_from_camera();
        let captured = Self::extract_with(
            &mut self.extractor,
            self.tag_extractor.as_ref(),
            self.camera.image(),
            self.tracked,
            self.layout,
        );
        let truth = self
            .true_intrinsics
            .project_marks(&self.board, &camera_from_board)
            .unwrap_or_else(|_| FeatureVector::from_element(f64::NAN));
        let delivered = self.finish(frame, tick, &captured, Some(holder_from_camera));
        VisionFrame {
            captured,
            truth,
            base_from_camera: base_from_true_camera,
            camera_from_board,
            motion_blur_px: self.exposure.motion_px(),
            delivered,
        }
    }

    /// The simulated camera's last image.
    pub fn image(&self) -> &GrayImage {
        self.camera.image()
    }

    /// Extracts frame `frame`, an image from a camera driver taken when the robot's latest tick was `tick`
    /// and its joints `q` (if known), and pushes it into the pipeline. Returns the extraction and the frame
    /// leaving the pipeline.
    pub fn process_image(
        &mut self,
        frame: u64,
        tick: u64,
        q: Option<&JointVector>,
        image: &GrayImage,
    ) -> (Extraction, Option<DeliveredFrame>) {
        let captured = self.extract(image);
        let holder_from_camera = q
            .filter(|q| q.iter().all(|v| v.is_finite()))
            .map(|q| self.mount.holder_from_camera(&self.arm.base_from_tool(q)));
        let delivered = self.finish(frame, tick, &captured, holder_from_camera);
        (captured, delivered)
    }

    /// The features the law takes: the observed marks (the extractor's, in the distorted image) mapped to
    /// their pinhole pixels through the lens; as observed without distortion or with `vision.undistort`
    /// off. A mark the lens cannot undistort is NaN (missing).
    fn pinhole_features(&self, observed: &FeatureVector) -> FeatureVector {
        if !self.undistort || self.intrinsics.distortion().is_none() {
            return *observed;
        }
        let mut features = *observed;
        for mark in 0..MARKS {
            let seen = nalgebra::Point2::new(observed[2 * mark], observed[2 * mark + 1]);
            if !(seen.x.is_finite() && seen.y.is_finite()) {
                continue;
            }
            let pinhole = self
                .intrinsics
                .pinhole_of_observed(&seen)
                .unwrap_or(nalgebra::Point2::new(f64::NAN, f64::NAN));
            features[2 * mark] = pinhole.x;
            features[2 * mark + 1] = pinhole.y;
        }
        features
    }

    /// The features of `image`: the tag's corners with an AprilTag target (looked for near the tracked
    /// ones first), else the marks (tracked, or matched to the layout).
    fn extract(&mut self, image: &GrayImage) -> Extraction {
        Self::extract_with(&mut self.extractor, self.tag_extractor.as_ref(), image, self.tracked, self.layout)
    }

    fn extract_with(
        extractor: &mut Extractor,
        tag_extractor: Option<&TagExtractor>,
        image: &GrayImage,
        tracked: Option<FeatureVector>,
        layout: FeatureVector,
    ) -> Extraction {
        if let Some(tag) = tag_extractor {
            return tag.extract(image, tracked.as_ref()).to_extraction();
        }
        let prediction = match tracked {
            Some(p) => Prediction::Tracking(p),
            None => Prediction::Layout(layout),
        };
        extractor.extract(image, &prediction)
    }

    /// Updates the tracker with a frame's extraction and moves the pipeline on.
    fn finish(
        &mut self,
        frame: u64,
        tick: u64,
        captured: &Extraction,
        holder_from_camera: Option<IsometryMatrix3<f64>>,
    ) -> Option<DeliveredFrame> {
        self.update_tracking(captured);
        let features = self.pinhole_features(&captured.features);
        self.pipeline.push_back(DeliveredFrame { frame, capture_tick: tick, features, holder_from_camera });
        (self.pipeline.len() > self.delay_frames).then(|| self.pipeline.pop_front()).flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Cell;

    fn stage_and_poses() -> (VisionStage, Vec<(u64, JointVector)>, IsometryMatrix3<f64>) {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default config loads")
                .cell;
        let cell = Cell::new(&config).expect("the default cell");
        let q0 = *cell.start_joints();
        let poses = (0..6u64).map(|k| (85 * k, q0 + JointVector::from_element(0.002 * k as f64))).collect();
        (cell.vision(), poses, cell.plant().base_from_board())
    }

    fn extraction(features: [f64; 8], missing: &[usize]) -> Extraction {
        let mut status = [vservo_vision::MarkStatus::Valid; MARKS];
        let mut features = FeatureVector::from(features);
        for &m in missing {
            status[m] = vservo_vision::MarkStatus::NotFound;
            features[2 * m] = f64::NAN;
            features[2 * m + 1] = f64::NAN;
        }
        Extraction {
            features,
            status,
            extra_blobs: 0,
            threshold: 128,
            sized_blobs_over_cap: 0,
            tag_quality: None,
        }
    }

    #[test]
    fn a_missing_mark_moves_with_the_found_ones_and_the_layout_is_matched_again_after_three_frames() {
        let (mut stage, _, _) = stage_and_poses();
        let first = [100.0, 100.0, 200.0, 100.0, 200.0, 200.0, 100.0, 200.0];
        stage.update_tracking(&extraction(first, &[]));
        // the image shifts by (+4, −2); mark 1 is not found
        let shifted: [f64; 8] = std::array::from_fn(|i| first[i] + if i % 2 == 0 { 4.0 } else { -2.0 });
        stage.update_tracking(&extraction(shifted, &[1]));
        let tracked = stage.tracked.expect("still tracking");
        assert_eq!(tracked[2], 204.0);
        assert_eq!(tracked[3], 98.0);
        stage.update_tracking(&extraction(shifted, &[1]));
        assert!(stage.tracked.is_some());
        stage.update_tracking(&extraction(shifted, &[1]));
        assert_eq!(stage.tracked, None, "three frames with a mark missing: match the layout again");
        // none found at all: match the layout at once
        stage.update_tracking(&extraction(first, &[]));
        stage.update_tracking(&extraction(first, &[0, 1, 2, 3]));
        assert_eq!(stage.tracked, None);
    }

    #[test]
    fn delivering_at_the_start_of_a_period_gives_the_same_frames_as_after_the_capture() {
        let (mut after, poses, board) = stage_and_poses();
        let mut before = after.clone();
        let (mut late, mut early) = (Vec::new(), Vec::new());
        for (frame, (tick, q)) in poses.iter().enumerate() {
            late.extend(after.capture(frame as u64, *tick, q, &board).delivered);
            early.extend(before.take_delivered());
            let taken = before.capture(frame as u64, *tick, q, &board);
            assert_eq!(taken.delivered, None, "the period's frame was already taken");
        }
        // the last frame of the early shell leaves at the next period's start
        early.extend(before.take_delivered());
        late.extend(
            after.capture(poses.len() as u64, 85 * poses.len() as u64, &poses[0].1, &board).delivered,
        );
        assert_eq!(early.len(), poses.len());
        assert_eq!(early, late);
        assert_eq!(early[0].frame, 0);
    }
}
