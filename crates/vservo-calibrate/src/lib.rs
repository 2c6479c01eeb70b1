//! vservo's calibration (docs/CALIBRATION.md): the camera's intrinsics and lens and the hand-eye transform
//! (`tool_from_camera`; a fixed camera's `base_from_camera`, the eye-to-hand case, the same problem with the
//! arm's poses inverted), from views of the calibration board (`[calibration]`) at poses spread over a half sphere
//! around it. `vservoctl calibrate` is its command line.
//!
//! The steps, a module each: find the board ([`live`]: through a running vservod, from a view where the arm is
//! now; in lockstep where the configuration's world puts it); plan the poses ([`plan`]: each reachable and with
//! the board in view, checked before anything moves) and check their spread ([`spread`]); take the views
//! ([`live`]: moving the arm through the daemon and taking the camera's frames; [`capture`]: the simulated cell
//! in lockstep, its camera as `[camera.truth]` says it is); hand them to the solver ([`dataset`], [`solver`]:
//! OpenCV and SciPy); report the residuals and, when the truth is known, the errors against it ([`report`]);
//! write the calibration file ([`mod@file`]); make the configuration read it and have the running instance take it
//! ([`apply`]).

pub mod apply;
pub mod capture;
pub mod dataset;
pub mod file;
pub mod live;
pub mod plan;
pub mod report;
pub mod solver;
pub mod spread;

use std::path::PathBuf;

/// What a calibration refuses or fails at, naming what and where.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// Refused as asked, before anything moved or once the views were taken (a plan out of reach, views too
    /// poorly spread, a configuration without `[calibration]`, the solver's refusal): the user's to act on.
    #[error("{0}")]
    Refused(String),
    /// A file or folder could not be read or written.
    #[error("{what} {}: {source}", path.display())]
    File {
        /// What was being done (`making`, `writing`, `reading`…).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
    /// An image could not be written.
    #[error("writing {}: {source}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// The encoder's reason.
        source: image::ImageError,
    },
    /// A file whose name may not be written, or that failed to be (vservo_config::new_file).
    #[error(transparent)]
    NewFile(#[from] vservo_config::new_file::NewFileError),
    /// The solver could not be run, failed, or answered what cannot be read.
    #[error("{0}")]
    Solver(String),
    /// The running cell: the daemon's refusal or silence, a stream that did not answer.
    #[error("{0}")]
    Cell(String),
    /// The running instance could not be reached or asked.
    #[error(transparent)]
    Client(#[from] vservo_client::ClientError),
    /// The calibration stopped: how the cell was left, and why it stopped.
    #[error("{left}: {cause}")]
    Stopped {
        /// How the cell was left (held where it is, servoing again…).
        left: String,
        /// What stopped it.
        cause: Box<CalibrateError>,
    },
}

impl CalibrateError {
    /// Whether it is a refusal of what was asked (vservoctl ends with its usage code, 2), through a stop too.
    pub fn is_refusal(&self) -> bool {
        match self {
            CalibrateError::Refused(_) => true,
            CalibrateError::Stopped { cause, .. } => cause.is_refusal(),
            _ => false,
        }
    }

    /// The error of doing `what` to `path`, for `map_err`.
    pub(crate) fn file(what: &'static str, path: &std::path::Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| CalibrateError::File { what, path, source }
    }

    /// This error, with how the cell was left.
    pub(crate) fn left(self, left: impl Into<String>) -> Self {
        CalibrateError::Stopped { left: left.into(), cause: Box::new(self) }
    }
}

/// A calibration step's result.
pub type Result<T, E = CalibrateError> = std::result::Result<T, E>;
