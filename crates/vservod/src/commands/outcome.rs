//! What a command comes to: accepted (what was done) or refused (why), each a type; the reply's text is
//! made from them once, where the reply is written ([`reply_text`]).

use vservo_cell::target::TargetRefused;

use super::joint_move::{JointMove, MoveRefused};
use super::object::{ObjectMotion, ObjectRefused};
use super::reload::ReloadRefused;
use crate::safety::{Resumed, SafetyRefused};

/// Why the gains cannot be adopted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GainsRefused {
    /// The design fails.
    #[error("the gain cannot be designed: {0}")]
    Design(#[from] vservo_control::GainsError),
    /// The servo cannot be handed them.
    #[error("publishing the gains: {0}")]
    Publish(String),
}

/// A command done.
#[derive(Debug, Clone, PartialEq)]
pub enum Accepted {
    /// The configuration was reloaded: its live keys that changed, and the gains version now.
    Reloaded {
        /// The configuration file.
        path: String,
        /// The changed keys.
        changed: Vec<&'static str>,
        /// The gains version in force.
        gains_version: u64,
        /// Whether the nodes that read the camera restart with it (the cell held meanwhile).
        restarting_nodes: bool,
    },
    /// The file holds what runs already.
    NothingChanged {
        /// The configuration file.
        path: String,
        /// The gains version in force.
        gains_version: u64,
    },
    /// A new target, designed as this version.
    Target {
        /// The gains version in force.
        gains_version: u64,
    },
    /// The simulated board moves.
    Object(ObjectMotion),
    /// The cell is held.
    SafeStop,
    /// The cell servos again.
    Resumed(Resumed),
    /// The arm moves its joints to a goal.
    Moving(JointMove),
    /// The arm moves its joints to a goal, out of the `target_lost` stop it ended.
    MovingOutOfStop {
        /// The move.
        joint_move: JointMove,
        /// The stop it ended.
        resumed: crate::safety::Resumed,
    },
    /// A joint move ended: the cell servos again.
    Servoing,
    /// A joint move cancelled while the cell is held in a safe stop.
    MoveCancelled,
    /// The dynamics override changed.
    Speed {
        /// The one before.
        from: f64,
        /// The one in force.
        to: f64,
    },
}

impl std::fmt::Display for Accepted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Accepted::Reloaded { path, changed, gains_version, restarting_nodes } => {
                write!(f, "{path}: {} changed; gains version {gains_version}", changed.join(", "))?;
                if *restarting_nodes {
                    write!(f, "; {}", vservo_client::RELOAD_RESTARTS_NODES)?;
                }
                Ok(())
            }
            Accepted::NothingChanged { path, gains_version } => {
                write!(f, "{path}: nothing changed; gains version {gains_version}")
            }
            Accepted::Target { gains_version } => write!(f, "new target; gains version {gains_version}"),
            Accepted::Object(motion) => write!(f, "{motion}"),
            Accepted::SafeStop => {
                write!(f, "safe stop: the arm is brought to rest and held; `vservoctl resume` servos again")
            }
            Accepted::Resumed(resumed) => write!(f, "{resumed}"),
            Accepted::Moving(joint_move) => {
                write!(f, "{joint_move}; it holds there until `servo` (a safe stop holds it on the way)")
            }
            Accepted::MovingOutOfStop { joint_move, resumed } => write!(
                f,
                "{joint_move}, out of the safe stop ({}, held {:.1} s): a joint move needs no marks; it holds there \
                 until `servo`, which servos once the camera sees the four marks",
                resumed.fault, resumed.held_s
            ),
            Accepted::Servoing => write!(f, "the joint move ended: servoing again"),
            Accepted::MoveCancelled => write!(
                f,
                "the joint move is cancelled; the cell stays in its safe stop, and `vservoctl resume` servos from where the arm is"
            ),
            Accepted::Speed { from, to } => write!(
                f,
                "speed scale {to} (was {from}): the reference keeps {to} of the joints' speed, acceleration and jerk \
                 limits and of the tool's caps from the next tick on"
            ),
        }
    }
}

/// Why a command is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CommandRefused {
    /// Another schema than this daemon's.
    #[error("schema {0} is not this daemon's ({expected})", expected = vservo_protocol::SCHEMA_VERSION)]
    Schema(u32),
    /// A kind this daemon does not know.
    #[error("unknown command kind {0}")]
    UnknownKind(u32),
    /// The reload is refused.
    #[error(transparent)]
    Reload(#[from] ReloadRefused),
    /// A safe stop or resume is refused.
    #[error(transparent)]
    Safety(#[from] SafetyRefused),
    /// The target is refused (`request` names the command: target, target pose, teach).
    #[error("{request}: {why}")]
    Target {
        /// The command.
        request: &'static str,
        /// Why.
        why: TargetRefused,
    },
    /// The target's gains cannot be adopted.
    #[error("target: {0}")]
    TargetGains(GainsRefused),
    /// The object command is refused.
    #[error("object: {0}")]
    Object(#[from] ObjectRefused),
    /// The joint move is refused.
    #[error("move joints: {0}")]
    Move(#[from] MoveRefused),
    /// The object command cannot be handed to the plant.
    #[error("object: {0}")]
    ObjectPublish(String),
}

/// The reply's text: what was done, or why not — for a refused reload, with the gains that stay.
pub fn reply_text(outcome: &Result<Accepted, CommandRefused>, gains_version: u64) -> String {
    match outcome {
        Ok(accepted) => accepted.to_string(),
        Err(CommandRefused::Reload(why @ ReloadRefused::RestartOnly { .. })) => why.to_string(),
        Err(CommandRefused::Reload(why)) => {
            format!("{why}; the running gains (version {gains_version}) stay")
        }
        Err(why) => why.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_reload_says_the_running_gains_stay_and_other_refusals_say_why_once() {
        let unreadable = Err(CommandRefused::Reload(ReloadRefused::Unreadable {
            path: "f.toml".into(),
            reason: "gone".into(),
        }));
        assert_eq!(
            reply_text(&unreadable, 2),
            "f.toml: cannot be read (gone); the running gains (version 2) stay"
        );
        let restart = Err(CommandRefused::Reload(ReloadRefused::RestartOnly {
            path: "f".into(),
            keys: vec!["plant.mode"],
        }));
        assert!(reply_text(&restart, 2).ends_with("nothing was applied"));
        let target = Err(CommandRefused::Target { request: "target pose", why: TargetRefused::Unreachable });
        assert!(reply_text(&target, 2).starts_with("target pose: out of the arm's reach"));
        let object = Err(CommandRefused::Object(ObjectRefused::StepTooLong { jump_m: 1.0 }));
        assert_eq!(
            reply_text(&object, 2),
            "object: step: 1.000 m is more than the 0.2 m the simulated cell allows"
        );
        let accepted = Ok(Accepted::Reloaded {
            path: "f".into(),
            changed: vec!["controller.q"],
            gains_version: 3,
            restarting_nodes: false,
        });
        assert_eq!(reply_text(&accepted, 3), "f: controller.q changed; gains version 3");
    }
}
