//! What a node's loop has to say to people, said by its telemetry thread: the loop hands a [`Note`] to a
//! bounded channel (no allocation, no I/O, never blocking) and the telemetry thread writes the lines: at
//! most [`NOTES_PER_PERIOD`] a telemetry period, a count of the rest and the newest, so that a mark
//! flickering at the border neither slows the servo nor floods the journal.

use vservo_protocol::{MARKS, MarkStatus, Verdict};

use crate::joint_history::NoJoints;

/// Lines written per telemetry period; the notes beyond are counted in one line.
pub const NOTES_PER_PERIOD: usize = 4;

/// Something a loop noticed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Note {
    /// The servo's (verdict, missing marks) changed; `mark_status` is the frame's per mark.
    ServoVerdict {
        /// Before: the verdict and the marks missing (bit m for mark m).
        before: (Verdict, u8),
        /// Now.
        now: (Verdict, u8),
        /// The frame's status of each mark (`None`: a code this build does not know).
        mark_status: [Option<MarkStatus>; MARKS],
    },
    /// The extractor found more blobs of a mark's size than it considers (`vservo_vision::extract::
    /// MAX_SIZED_BLOBS`): those beyond were not looked at, so a mark among them would be missed.
    BlobsOverCap {
        /// The frame.
        frame: u64,
        /// The blobs of a mark's size not looked at.
        over_cap: usize,
    },
    /// An external camera's frame with no joint state around its exposure: its camera pose is unknown.
    FrameWithoutPose {
        /// The camera's frame number.
        frame: u64,
        /// Its exposure stamp.
        capture_stamp_ns: u64,
        /// Where the stamp fell.
        why: NoJoints,
    },
}

impl Note {
    /// Writes its line (the telemetry thread does, off the loop's path).
    pub fn log(&self) {
        match *self {
            Note::ServoVerdict { before, now, mark_status } => log_servo_verdict(before, now, &mark_status),
            Note::BlobsOverCap { frame, over_cap } => tracing::warn!(
                node = "vision",
                frame,
                "frame {frame}: {over_cap} dark blobs of a mark's size beyond the {} the extractor considers were not looked at (clutter in view?); said when it starts",
                vservo_vision::extract::MAX_SIZED_BLOBS
            ),
            Note::FrameWithoutPose { frame, capture_stamp_ns, why } => {
                let where_ = match why {
                    NoJoints::Empty => "no joint state heard yet",
                    NoJoints::BeforeHistory => "before the joint states kept",
                    NoJoints::AfterNewest => "after the newest joint state (ahead of the robot's clock)",
                    NoJoints::InGap => "in a gap between joint states (a stalled driver)",
                };
                tracing::warn!(
                    node = "vision",
                    frame,
                    "frame {frame}'s exposure (capture_stamp_ns {capture_stamp_ns}) is {where_}: its camera pose is unknown, the feed-forward restarts and reacquiring cannot steer; a camera stamps CLOCK_MONOTONIC at exposure (docs/DRIVERS.md); said once"
                );
            }
        }
    }
}

/// Why the marks of `missing` are missing, for people: "mark 2 (not found)".
fn missing_marks(missing: u8, status: &[Option<MarkStatus>; MARKS]) -> String {
    let reason = |status: Option<MarkStatus>| match status {
        Some(MarkStatus::OutsideImage) => "outside the image",
        Some(MarkStatus::CutByBorder) => "cut by the border",
        Some(MarkStatus::Merged) => "merged with another",
        Some(MarkStatus::Irregular) => "irregular",
        Some(MarkStatus::NotFound) => "not found",
        Some(MarkStatus::BadImage) => "bad image",
        Some(MarkStatus::Ambiguous) => "could be another mark",
        // valid for vision, refused by the servo
        Some(MarkStatus::Valid) => "outside the image",
        None => "unknown reason",
    };
    (0..MARKS)
        .filter(|m| missing & (1 << m) != 0)
        .map(|m| format!("mark {} ({})", m + 1, reason(status[m])))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One line when the servo starts or stops servoing on three marks, reacquiring or holding for lost marks.
fn log_servo_verdict(before: (Verdict, u8), now: (Verdict, u8), status: &[Option<MarkStatus>; MARKS]) {
    match now {
        (Verdict::ServoingOnThree, missing) => {
            tracing::warn!(
                node = "servo",
                "servoing on three marks: {} missing",
                missing_marks(missing, status)
            );
        }
        (Verdict::Reacquiring, missing) => tracing::warn!(
            node = "servo",
            "reacquiring: {} missing; steering the camera back to where all four were last seen",
            missing_marks(missing, status)
        ),
        (Verdict::MarksMissing, missing) => tracing::warn!(
            node = "servo",
            "holding: {} missing and no pose where all four were seen",
            missing_marks(missing, status)
        ),
        (Verdict::Servoing, _)
            if matches!(
                before.0,
                Verdict::ServoingOnThree | Verdict::Reacquiring | Verdict::MarksMissing
            ) =>
        {
            tracing::info!(node = "servo", "servoing on all four marks again");
        }
        _ => {}
    }
}
