//! The cell mode as the daemon carries it out: the [`FaultMonitor`]'s decisions become sealed `cell_mode`
//! messages (the rmrc ramps the arm to rest at its acceleration limits and holds it, the servo sends zero
//! twists), one log line each, and the fault in the status; and a client's joint move (moving) and its end
//! (servoing). A safe stop ends a move's motion but not the move: a resume takes the arm on to its goal.

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::{Node, ipc};
use vservo_protocol::{CellMode, CellModeMsg, DaemonStatusMsg, Fault, SCHEMA_VERSION, Topic};
use vservo_time::monotonic_ns;

use crate::commands::JointMove;
use crate::faults::{AlreadyHeld, Cause, Conditions, Decision, FaultMonitor, LatchedFault, ResumeRefused};

/// A resume carried out.
#[derive(Debug, Clone, PartialEq)]
pub struct Resumed {
    /// How: "on command", or automatically and why.
    pub how: String,
    /// The fault it ended.
    pub fault: Fault,
    /// How long the cell was held (s).
    pub held_s: f64,
    /// What the cell does again: servoing, or moving on to a joint move's goal.
    pub mode: CellMode,
}

impl std::fmt::Display for Resumed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "resumed {} after {} (held {:.1} s)", self.how, self.fault, self.held_s)?;
        if self.mode == CellMode::Moving {
            write!(f, "; the joint move goes on to its goal")?;
        }
        Ok(())
    }
}

/// Why a client's safe stop or resume is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SafetyRefused {
    /// The resume is refused.
    #[error(transparent)]
    Resume(#[from] ResumeRefused),
    /// The cell is held already.
    #[error(transparent)]
    AlreadyHeld(#[from] AlreadyHeld),
    /// The nodes could not be told.
    #[error("publishing the cell mode: {0}")]
    Publish(String),
    /// A joint move asked for while the cell is held.
    #[error("{}", held_text(*.0))]
    Held(Fault),
    /// The end of a joint move asked for while none is in force.
    #[error("the cell is not moving its joints: it servos already")]
    NotMoving,
    /// A dynamics override outside (0, 1].
    #[error(
        "speed {0}: the dynamics override is a share of the arm's limits, from {min} to 1",
        min = vservo_config::MIN_SPEED_SCALE
    )]
    SpeedOutOfRange(f64),
    /// A raise of the dynamics override while the cell moves, not asked for as such.
    #[error(
        "speed {to} is above the {from} in force while the cell moves: hold it first (`vservoctl safe-stop`), or \
         raise it while moving with `--while-moving`"
    )]
    RaiseWhileMoving {
        /// The override in force.
        from: f64,
        /// The one asked for.
        to: f64,
    },
}

/// What a client is told when its joint move or `servo` finds the cell held.
fn held_text(fault: Fault) -> String {
    if fault == Fault::TargetLost {
        "the cell is in a safe stop (target_lost): `vservoctl move-joints --q …` takes the arm to where the camera \
         sees the four marks (a joint move needs none), or `vservoctl resume` once it sees them"
            .to_string()
    } else {
        format!("the cell is in a safe stop ({fault}): `vservoctl resume` first")
    }
}

/// The monitor and the `cell_mode` publisher.
pub struct Safety {
    monitor: FaultMonitor,
    publisher: Publisher<ipc::Service, CellModeMsg, ()>,
    seal_key: vservo_protocol::seal::SealKey,
    sequence: u64,
    /// A client's joint move in force (held by a safe stop, it goes on after the resume).
    joint_move: Option<JointMove>,
    /// When the mode was last published (ns): again at least every `CELL_MODE_EVERY`, as a heartbeat.
    published_ns: u64,
    /// The process of each node the daemon started, by role (0: none runs), announced with every mode.
    writers: [u32; 4],
    /// The dynamics override in force, announced with every mode.
    speed_scale: f64,
}

impl Safety {
    /// Opens `cell_mode` and publishes "servoing", or with `start_held` a safe stop `start_held` (sequence 1),
    /// with the dynamics override `speed_scale`: call before any node starts, so that every node finds the mode
    /// in the service's history.
    pub fn new(
        node: &Node<ipc::Service>,
        instance: &str,
        (settings, start_held, speed_scale): (vservo_config::Faults, bool, f64),
        arm_joints: u32,
        seal_key: vservo_protocol::seal::SealKey,
    ) -> anyhow::Result<Self> {
        let mut safety = Self {
            monitor: FaultMonitor::new(settings, arm_joints),
            publisher: vservo_protocol::publisher(node, instance, Topic::CellMode)?,
            seal_key,
            sequence: 0,
            joint_move: None,
            published_ns: 0,
            writers: [0; 4],
            speed_scale,
        };
        if start_held {
            let fault = safety.monitor.hold_at_start(monotonic_ns());
            tracing::warn!(
                fault = fault.code.name(),
                "the cell starts held (robot.start = \"held\"): nothing moves until `vservoctl resume`"
            );
            safety.publish(CellMode::SafeStop, Some(&fault))?;
        } else {
            safety.publish(CellMode::Servoing, None)?;
        }
        Ok(safety)
    }

    /// The monitor, to feed it what the loop published.
    pub fn monitor(&mut self) -> &mut FaultMonitor {
        &mut self.monitor
    }

    /// Whether the cell is held in a safe stop.
    pub fn holding(&self) -> bool {
        self.monitor.latched().is_some()
    }

    /// The joint move in force, if any (moving, or held in a safe stop that interrupted one).
    pub fn joint_move(&self) -> Option<&JointMove> {
        self.joint_move.as_ref()
    }

    /// Publishes the mode; a joint move's goal goes with "moving".
    fn publish(&mut self, mode: CellMode, fault: Option<&LatchedFault>) -> anyhow::Result<()> {
        let joint_move = self.joint_move.filter(|_| mode == CellMode::Moving);
        let mut message = CellModeMsg {
            schema: SCHEMA_VERSION,
            mode: mode.into(),
            sequence: self.sequence + 1,
            fault: fault.map_or(Fault::None, |f| f.code).into(),
            fault_joints: fault.map_or(0, |f| f.joints),
            speed_fraction: joint_move.map_or(0.0, |m| m.speed_fraction),
            speed_scale: self.speed_scale,
            goal_rad: joint_move.map_or([0.0; vservo_protocol::MAX_JOINTS], |m| m.goal_rad),
            writers: self.writers,
            stamp_ns: monotonic_ns(),
            seal: 0,
        };
        self.seal_key.sign(&mut message);
        let sample = self.publisher.loan_uninit()?;
        sample.write_payload(message).send()?;
        self.sequence += 1;
        self.published_ns = message.stamp_ns;
        Ok(())
    }

    fn enter(&mut self, fault: &LatchedFault, how: &str) {
        tracing::error!(
            fault = fault.code.name(),
            "safe stop ({how}): {}; the arm is brought to rest and held; `vservoctl resume` servos again once the cause is gone",
            fault.cause
        );
        if let Err(e) = self.publish(CellMode::SafeStop, Some(fault)) {
            // the nodes cannot hear it: the rmrc is out of reach, which the supervisor sees as unhealthy
            tracing::error!("publishing the safe stop: {e}");
        }
    }

    /// The mode the cell is in when not held: moving while a joint move is in force, else servoing.
    fn running_mode(&self) -> CellMode {
        if self.joint_move.is_some() { CellMode::Moving } else { CellMode::Servoing }
    }

    fn leave(&mut self, fault: &LatchedFault, how: &str) -> Result<Resumed, SafetyRefused> {
        let mode = self.running_mode();
        self.publish(mode, None).map_err(|e| SafetyRefused::Publish(e.to_string()))?;
        let held_s = vservo_time::seconds_between(monotonic_ns(), fault.since_ns);
        let resumed = Resumed { how: how.to_string(), fault: fault.code, held_s, mode };
        tracing::warn!("{resumed}");
        Ok(resumed)
    }

    /// One supervisor cycle: hands subscribers that came since (a restarted node) the mode in force, and
    /// acts on the monitor's decision.
    pub fn cycle(&mut self, conditions: &Conditions) {
        if let Err(e) = self.publisher.update_connections() {
            tracing::warn!("handing on the cell mode: {e}");
        }
        self.notice_own_silence(conditions.now_ns);
        match self.monitor.cycle(conditions) {
            Decision::Same => {}
            Decision::SafeStop(fault) => self.enter(&fault, "fault"),
            Decision::ResumeAutomatically => {
                if let Ok(fault) = self.monitor.resume(conditions) {
                    let _ = self
                        .leave(&fault, "automatically (faults.resume = \"automatic\"): the cause is gone");
                }
            }
        }
        self.heartbeat(conditions.now_ns);
    }

    /// The nodes heard no mode for `DAEMON_SILENT_AFTER` (the daemon was stopped between two cycles): they held
    /// the arm on their own, and the cell stays held until a resume on command.
    fn notice_own_silence(&mut self, now_ns: u64) {
        let silent = std::time::Duration::from_nanos(now_ns.saturating_sub(self.published_ns));
        if self.published_ns != 0 && silent > vservo_protocol::supervision::DAEMON_SILENT_AFTER {
            self.supervision_stalled(silent);
        }
    }

    /// The mode in force again when none was published for `CELL_MODE_EVERY`: the nodes hold the arm when
    /// they hear nothing for `DAEMON_SILENT_AFTER` (docs/PROTOCOL.md, "Safe stop").
    fn heartbeat(&mut self, now_ns: u64) {
        let every = vservo_protocol::supervision::CELL_MODE_EVERY.as_nanos() as u64;
        if now_ns.saturating_sub(self.published_ns) < every {
            return;
        }
        if let Err(e) = self.publish_in_force() {
            tracing::warn!("publishing the cell mode's heartbeat: {e}");
        }
    }

    /// Announces the process of each node the daemon started (by role; 0 while none runs), with the mode in
    /// force, when one changed: a consumer takes a sealed stream only from its writer's process, of its run
    /// now (`vservo_protocol::freshness::Origin`).
    pub fn announce_writers(&mut self, writers: [u32; 4]) {
        if writers == self.writers {
            return;
        }
        self.writers = writers;
        if let Err(e) = self.publish_in_force() {
            tracing::error!("announcing the nodes' processes: {e}");
        }
    }

    /// Publishes the mode in force again.
    fn publish_in_force(&mut self) -> anyhow::Result<()> {
        match self.monitor.latched().cloned() {
            Some(fault) => self.publish(CellMode::SafeStop, Some(&fault)),
            None => self.publish(self.running_mode(), None),
        }
    }

    /// A client's `resume`.
    pub fn resume(&mut self, conditions: &Conditions) -> Result<Resumed, SafetyRefused> {
        let fault = self.monitor.resume(conditions)?;
        self.leave(&fault, "on command")
    }

    /// A client's joint move: the rmrc takes the joints to the goal instead of following the servo's twists.
    /// Refused while the cell is held, except in a `target_lost` stop that only the lost marks keep (a joint
    /// move needs none), and, `out_of_hold`, in a cell held by the user (`start_held`, `requested`: the move is
    /// the user's own motion) or by the collision guard (`collision`: the guard stops a move towards what it is
    /// near, so that a move away is the way out): the move ends that stop, and the resume is returned.
    pub fn move_joints(
        &mut self,
        joint_move: JointMove,
        conditions: &Conditions,
        out_of_hold: bool,
    ) -> Result<Option<Resumed>, SafetyRefused> {
        let before = self.joint_move.replace(joint_move);
        let out = |safety: &mut Self, how: &str| {
            safety
                .monitor
                .resume_into_joint_move(conditions)
                .map_err(SafetyRefused::from)
                .and_then(|fault| safety.leave(&fault, how).map(Some))
        };
        let moved = match self.monitor.latched().map(|f| f.code) {
            None => self
                .publish(CellMode::Moving, None)
                .map(|()| None)
                .map_err(|e| SafetyRefused::Publish(e.to_string())),
            Some(Fault::TargetLost) => out(self, "by a joint move (it needs no marks)"),
            Some(Fault::StartHeld | Fault::Requested) if out_of_hold => {
                out(self, "by the user's joint move out of the held cell")
            }
            // the guard stops a move towards what it is near as it stopped the servo: a move away is the way out
            Some(Fault::Collision) if out_of_hold => {
                out(self, "by the user's joint move out of the collision stop")
            }
            Some(code) => Err(SafetyRefused::Held(code)),
        };
        if moved.is_err() {
            self.joint_move = before;
        }
        moved
    }

    /// A client's end of a joint move (refused when none is in force): servoing again; held in a safe stop,
    /// the move is cancelled (nothing moves; the resume then servos instead of taking the move on). Whether the
    /// cell is still held is returned.
    pub fn servo(&mut self) -> Result<bool, SafetyRefused> {
        let Some(before) = self.joint_move.take() else {
            // held with no move: `servo` is not the way out, the resume is
            return Err(self
                .monitor
                .latched()
                .map_or(SafetyRefused::NotMoving, |f| SafetyRefused::Held(f.code)));
        };
        if self.monitor.latched().is_some() {
            return Ok(true);
        }
        self.publish(CellMode::Servoing, None).map_err(|e| {
            self.joint_move = Some(before);
            SafetyRefused::Publish(e.to_string())
        })?;
        Ok(false)
    }

    /// A client's dynamics override: lowering it is always taken; raising it only while the cell is held, or
    /// `while_moving`. The override before is returned.
    pub fn set_speed_scale(&mut self, speed_scale: f64, while_moving: bool) -> Result<f64, SafetyRefused> {
        if !(vservo_config::MIN_SPEED_SCALE..=1.0).contains(&speed_scale) {
            return Err(SafetyRefused::SpeedOutOfRange(speed_scale));
        }
        let before = self.speed_scale;
        if speed_scale > before && !self.holding() && !while_moving {
            return Err(SafetyRefused::RaiseWhileMoving { from: before, to: speed_scale });
        }
        self.speed_scale = speed_scale;
        self.publish_in_force().map_err(|e| {
            self.speed_scale = before;
            SafetyRefused::Publish(e.to_string())
        })?;
        tracing::warn!(
            "speed scale {before} → {speed_scale}: the reference keeps that share of the arm's limits"
        );
        Ok(before)
    }

    /// A client's `safe-stop`.
    pub fn request_safe_stop(&mut self) -> Result<(), SafetyRefused> {
        let fault = self.monitor.request_safe_stop(monotonic_ns())?;
        self.enter(&fault, "on command");
        Ok(())
    }

    /// The daemon published nothing for `silent` (it was stopped): the nodes held the arm on their own; a safe
    /// stop `supervision_stalled` unless the cell is held already.
    fn supervision_stalled(&mut self, silent: std::time::Duration) {
        let silent_ms = silent.as_millis() as u64;
        match self.monitor.supervision_stalled(silent_ms, monotonic_ns()) {
            Some(fault) => self.enter(&fault, "on waking"),
            None => tracing::error!(
                silent_ms,
                "vservod stopped supervising for {silent_ms} ms; the nodes held the arm; the cell was held already"
            ),
        }
    }

    /// A safe stop asked for on the safe-stop path (docs/PROTOCOL.md): refused (nothing to do) when the cell
    /// is held already.
    pub fn request_safe_stop_by_path(&mut self) -> Result<(), AlreadyHeld> {
        let fault = self.monitor.request_safe_stop(monotonic_ns())?;
        self.enter(&fault, "asked for on the safe-stop path");
        Ok(())
    }

    /// The fault fields and the dynamics override of the status.
    pub fn fill(&self, status: &mut DaemonStatusMsg) {
        status.speed_scale = self.speed_scale;
        if let Some(fault) = self.monitor.shown() {
            status.fault = fault.code.into();
            status.fault_joints = fault.joints;
            status.fault_since_ns = fault.since_ns;
            if let Cause::DriverFault(reason) = fault.cause {
                status.driver_error = reason.into();
            }
        }
        status.safe_stops = self.monitor.safe_stops();
    }
}
