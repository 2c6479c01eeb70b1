//! The vision stage: camera, extractor, mark tracking and the image pipeline's delay.

use std::collections::VecDeque;

use vservo_arm::{JointVector, SerialArm};
use vservo_config::Config;
use vservo_scene::{Board, CameraIntrinsics, FeatureVector, IsometryMatrix3, MARKS};
use vservo_vision::source::SimulatedCamera;
use vservo_vision::{Extraction, Extractor, Prediction};

/// A frame leaving the image pipeline: what the servo sees now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeliveredFrame {
    /// Its frame number.
    pub frame: u64,
    /// The plant tick at which its image was taken.
    pub capture_tick: u64,
    /// ξ (px), NaN where a mark is not valid.
    pub features: FeatureVector,
}

/// What one frame produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisionFrame {
    /// The extraction from this frame's image.
    pub captured: Extraction,
    /// The true projections of the disc centres at capture time (NaN if a mark is behind the camera).
    pub truth: FeatureVector,
    /// Where the camera was.
    pub base_from_camera: IsometryMatrix3<f64>,
    /// The frame leaving the pipeline now (`pipeline_delay_frames` older than this one), if any has yet.
    pub delivered: Option<DeliveredFrame>,
}

/// The simulated camera and the feature extractor, with the tracker's memory and the pipeline.
#[derive(Debug, Clone)]
pub struct VisionStage {
    arm: SerialArm,
    tool_from_camera: IsometryMatrix3<f64>,
    intrinsics: CameraIntrinsics,
    board: Board,
    layout: FeatureVector,
    camera: SimulatedCamera,
    extractor: Extractor,
    /// The latest known position of each mark, once all four have been found.
    tracked: Option<FeatureVector>,
    pipeline: VecDeque<DeliveredFrame>,
    delay_frames: usize,
}

impl VisionStage {
    pub(crate) fn new(config: &Config, arm: SerialArm) -> Self {
        let delay_frames = config.timing.pipeline_delay_frames;
        Self {
            arm,
            tool_from_camera: config.tool_from_camera,
            intrinsics: config.camera,
            board: config.board,
            layout: config.desired.features,
            camera: SimulatedCamera::new(config.camera, config.board, config.vision.render),
            extractor: Extractor::new(
                config.vision.extractor,
                config.camera.width_px(),
                config.camera.height_px(),
            ),
            tracked: None,
            pipeline: VecDeque::with_capacity(delay_frames + 1),
            delay_frames,
        }
    }

    /// Takes frame `frame` at plant tick `tick` with the arm at `q` and the board at `base_from_board`,
    /// extracts it and pushes it into the pipeline.
    pub fn capture(
        &mut self,
        frame: u64,
        tick: u64,
        q: &JointVector,
        base_from_board: &IsometryMatrix3<f64>,
    ) -> VisionFrame {
        let base_from_camera = self.arm.base_from_tool(q) * self.tool_from_camera;
        let camera_from_board = base_from_camera.inverse() * base_from_board;
        let image = self.camera.capture(&camera_from_board, frame);
        let prediction = match self.tracked {
            Some(p) => Prediction::Tracking(p),
            None => Prediction::Layout(self.layout),
        };
        let captured = self.extractor.extract(image, &prediction);
        // track from the latest known position of each mark
        self.tracked = match self.tracked {
            Some(mut known) => {
                for mark in (0..MARKS).filter(|&m| captured.status[m].is_valid()) {
                    known[2 * mark] = captured.features[2 * mark];
                    known[2 * mark + 1] = captured.features[2 * mark + 1];
                }
                Some(known)
            }
            None => captured.all_valid().then_some(captured.features),
        };
        let truth = self
            .intrinsics
            .project_marks(&self.board, &camera_from_board)
            .unwrap_or_else(|_| FeatureVector::from_element(f64::NAN));
        self.pipeline.push_back(DeliveredFrame { frame, capture_tick: tick, features: captured.features });
        let delivered =
            (self.pipeline.len() > self.delay_frames).then(|| self.pipeline.pop_front()).flatten();
        VisionFrame { captured, truth, base_from_camera, delivered }
    }
}
