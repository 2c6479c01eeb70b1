//! The collision guard as the status shows it: the nearest checked distance at the rmrc's reference, named,
//! measured here off the loop's path by a copy of the cell's guard; and the names of the distance a
//! `joint_command.guard` word points at.

use vservo_arm::{JointVector, SerialArm};
use vservo_collision::{Between, Guard};
use vservo_protocol::guard_bits::{self, Distance};
use vservo_protocol::{CLEARANCE_NAME_BYTES, DaemonStatusMsg, JointCommandMsg};

/// Beyond this the status says nothing is near (m).
const SHOWN_WITHIN_M: f64 = 1.0;

/// The cell's guard, where it has one, and its arm.
pub struct ClearanceWatch {
    guard: Option<(Guard, SerialArm)>,
}

impl ClearanceWatch {
    /// The watch of `cell`'s guard (none: the status's clearance stays NaN).
    pub fn new(cell: &vservo_cell::Cell) -> Self {
        Self { guard: cell.guard().map(|guard| (guard.clone(), cell.arm().clone())) }
    }

    /// The names of the distance a guard word points at: "camera – table".
    pub fn named(&self, word: u32) -> Option<String> {
        let (guard, _) = self.guard.as_ref()?;
        let between = match guard_bits::distance(word)? {
            Distance::Pair(pair) if (pair as usize) < guard.model().pair_count() => {
                Between::Pair(pair as usize)
            }
            Distance::WorkspacePoint(point) => Between::Workspace { point: point as usize },
            Distance::Pair(_) => return None,
        };
        let (first, second) = guard.names(between);
        Some(format!("{first} – {second}"))
    }

    /// The status's clearance: the nearest distance at `command`'s reference, and between what.
    pub fn fill(&mut self, command: Option<&JointCommandMsg>, status: &mut DaemonStatusMsg) {
        let (Some((guard, arm)), Some(command)) = (self.guard.as_mut(), command) else { return };
        let joints = arm.joint_count();
        let Some(q) = vservo_arm::joint_vector(&command.q_ref_rad[..joints]) else { return };
        if command.joint_count as usize != joints || !q.iter().all(|v| v.is_finite()) {
            return;
        }
        let q: JointVector = q;
        let Some((between, distance_m)) = guard.nearest(&arm.placement(&q), SHOWN_WITHIN_M) else { return };
        let (first, second) = guard.names(between);
        status.clearance_m = distance_m;
        status.clearance_between = name_bytes(&format!("{first} – {second}"));
    }
}

/// `text` zero-padded (cut at a character boundary to fit).
fn name_bytes(text: &str) -> [u8; CLEARANCE_NAME_BYTES] {
    let mut bytes = [0u8; CLEARANCE_NAME_BYTES];
    let mut end = text.len().min(CLEARANCE_NAME_BYTES);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    bytes[..end].copy_from_slice(&text.as_bytes()[..end]);
    bytes
}
