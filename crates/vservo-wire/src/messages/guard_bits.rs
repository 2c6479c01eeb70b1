//! The bits of `joint_command.guard`: the collision guard's state as the rmrc sends it.

/// The guard slows the asked motion (it closes a distance within the slowdown distance).
pub const SLOWING: u32 = 1;
/// The guard holds the arm: it stopped it (a `collision` stop) and takes no motion until the cell resumes.
pub const HOLDING: u32 = 2;
/// Where the distance's code starts: 1 + the pair's index in the guard's model, or
/// [`WORKSPACE`] + 1 + a workspace point's; 0: none.
pub const DISTANCE_SHIFT: u32 = 2;
/// The codes of workspace points start here.
pub const WORKSPACE: u32 = 1 << 28;

/// Which distance a guard word names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Distance {
    /// The guard model's pair of this index.
    Pair(u32),
    /// The workspace point of this index and its nearest face.
    WorkspacePoint(u32),
}

/// The guard word of `slowing`, `holding` and the distance named (one out of range is named as none).
pub fn word(slowing: bool, holding: bool, distance: Option<Distance>) -> u32 {
    let code = match distance {
        Some(Distance::Pair(pair)) if pair < WORKSPACE - 1 => pair + 1,
        Some(Distance::WorkspacePoint(point)) if point < (u32::MAX >> DISTANCE_SHIFT) - WORKSPACE => {
            WORKSPACE + point + 1
        }
        _ => 0,
    };
    (u32::from(slowing) * SLOWING) | (u32::from(holding) * HOLDING) | (code << DISTANCE_SHIFT)
}

/// The distance a guard word names.
pub fn distance(word: u32) -> Option<Distance> {
    match word >> DISTANCE_SHIFT {
        0 => None,
        code if code < WORKSPACE => Some(Distance::Pair(code - 1)),
        code if code > WORKSPACE => Some(Distance::WorkspacePoint(code - WORKSPACE - 1)),
        _ => None,
    }
}
