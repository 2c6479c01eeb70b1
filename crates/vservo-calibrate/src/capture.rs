//! Taking the views on the simulated cell in lockstep: the arm put at each planned pose, the board where the
//! configuration's world puts it, and the cell's own vision stage rendering what the camera sees, the camera as
//! `[camera.truth]` says it really is (with the configured noise).

use vservo_cell::{Cell, VisionStage};
use vservo_config::Config;
use vservo_scene::IsometryMatrix3;

use crate::dataset::View;
use crate::plan::PlannedPose;
use crate::{CalibrateError, Result};

/// The simulated cell's camera and world.
pub struct Simulated {
    cell: Cell,
    /// Where a hand camera's board stands.
    base_from_board: IsometryMatrix3<f64>,
    /// Where the camera is (a fixed one's board rides on the tool).
    mount: vservo_scene::CameraMount,
}

impl Simulated {
    /// The cell the configuration describes; refused unless its camera is the simulated one.
    pub fn new(config: &Config) -> Result<Self> {
        if config.cell.vision.source != vservo_config::VisionSource::Simulated {
            return Err(CalibrateError::Refused(format!(
                "{}: --lockstep calibrates the simulated camera; camera.source is not \"simulated\"",
                config.origin
            )));
        }
        let cell = Cell::simulated(&config.cell)
            .map_err(|e| CalibrateError::Refused(format!("{}: {e}", config.origin)))?;
        let base_from_board = config.cell.base_from_board(cell.arm());
        Ok(Self { cell, base_from_board, mount: config.cell.mount() })
    }

    /// Where the board is in the arm's base (a fixed camera's: at the desired joints).
    pub fn base_from_board(&self) -> IsometryMatrix3<f64> {
        self.base_from_board
    }

    /// One view at each pose, the arm exactly at the planned joints.
    pub fn take_views(&self, planned: &[PlannedPose]) -> Vec<View> {
        let mut vision: VisionStage = self.cell.vision();
        planned
            .iter()
            .enumerate()
            .map(|(k, pose)| {
                let base_from_tool = self.cell.arm().base_from_tool(&pose.q);
                let board = self.mount.base_from_board(&base_from_tool, &self.base_from_board);
                vision.capture(k as u64, 0, &pose.q, &board);
                View { image: vision.image().clone(), q: pose.q, base_from_tool }
            })
            .collect()
    }
}
