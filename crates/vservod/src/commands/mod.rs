//! What users do with a running instance: reload the configuration (SIGHUP or the `command` service), send
//! targets and object commands, stop the arm safely and resume (the `command` request-response service).
//! Every request is validated off the hot path by pure modules — [`reload`] (a diff of validated
//! configurations), `vservo_cell::target` (target placement), [`object`] — and gets a reply saying whether
//! it was accepted, and why not ([`outcome`]). Gains are designed here and handed to the servo (`gains`,
//! history 1), object commands to the plant (`object`).

mod joint_move;
mod object;
mod outcome;
mod reload;

use std::path::{Path, PathBuf};

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::{Node, ipc};
use nalgebra::Vector3;
use vservo_arm::JointVector;
use vservo_cell::target::{CellNow, Target, TargetRequest};
use vservo_config::Config;
use vservo_control::{Gains, LawGains};
use vservo_protocol::seal::SealKey;
use vservo_protocol::{
    CommandKind, CommandMsg, CommandReplyMsg, FEATURES, FeaturesMsg, GainsMsg, JointStateMsg,
    MOVE_OUT_OF_HOLD, ObjectMsg, RobotState, SCHEMA_VERSION, SPEED_WHILE_MOVING, Topic,
};
use vservo_runtime::gains::gains_message;
use vservo_scene::FeatureVector;

use crate::faults::Conditions;
use crate::log_limit::LogLimit;
use crate::safety::Safety;
use crate::systemd::Systemd;
pub use joint_move::JointMove;
use object::ObjectMotion;
pub use outcome::GainsRefused;
pub use outcome::{Accepted, CommandRefused};
use reload::{ReloadPlan, ReloadRefused};

/// Commands get a log line each, up to [`COMMAND_LOG_LINES`] per [`COMMAND_LOG_WINDOW`] (journald's default
/// burst limit keeps that); a flood beyond gets one summary line per window.
const COMMAND_LOG_WINDOW: std::time::Duration = std::time::Duration::from_secs(1);
/// See [`COMMAND_LOG_WINDOW`].
const COMMAND_LOG_LINES: u32 = 10;

/// The latest of what the loop published, as the supervisor heard it.
pub struct LoopState<'a> {
    /// The configured arm's joints.
    pub arm_joints: usize,
    /// The latest joint state.
    pub joint_state: Option<&'a JointStateMsg>,
    /// The latest features.
    pub features: Option<&'a FeaturesMsg>,
    /// What a resume depends on.
    pub conditions: Conditions,
}

impl LoopState<'_> {
    /// The cell as target placement sees it: the joints, and the features if all four marks are seen.
    fn cell_now(&self) -> CellNow {
        CellNow {
            joints: self
                .joint_state
                .and_then(|state| state.arm_q_rad(self.arm_joints).map(JointVector::from)),
            features_seen: self
                .features
                .filter(|f| f.valid_mask == 0b1111)
                .map(|f| FeatureVector::from(f.features_px)),
        }
    }
}

/// The daemon's command side: the running configuration and design, and the ports to hand them on.
pub struct Commander {
    config_path: PathBuf,
    /// Where the configuration in force is written for the helpers and clients (the instance's directory).
    instance_dir: vservo_protocol::InstanceDir,
    config: Config,
    config_text: String,
    /// The target a client set (none: the file's `[desired]`).
    target: Option<Target>,
    version: u64,
    object_sequence: u64,
    /// The run's key: gains and object commands are sealed with it (the nodes take no others).
    seal_key: SealKey,
    gains_publisher: Publisher<ipc::Service, GainsMsg, ()>,
    object_publisher: Publisher<ipc::Service, ObjectMsg, ()>,
    server: Server<ipc::Service, CommandMsg, (), CommandReplyMsg, ()>,
    /// One log line per command, up to a rate journald keeps; a summary line for floods.
    log_limit: LogLimit,
    /// A reload changed the camera: the nodes that read it are to restart (`take_node_restart`).
    node_restart: bool,
}

impl Commander {
    /// Publishes `gains`, the configuration's design the daemon's start check made, as version 1.
    pub fn new(
        node: &Node<ipc::Service>,
        (config_path, instance_dir): (&Path, &vservo_protocol::InstanceDir),
        config: Config,
        text: String,
        seal_key: SealKey,
        gains: &Gains,
    ) -> anyhow::Result<Self> {
        let instance = config.instance.clone();
        let server =
            vservo_protocol::open_command_service(node, &instance, vservo_protocol::Opening::OpenOrCreate)?
                .server_builder()
                .create()
                .map_err(|e| anyhow::anyhow!("creating the command server: {e}"))?;
        let mut commander = Self {
            config_path: config_path.to_path_buf(),
            instance_dir: instance_dir.clone(),
            config,
            target: None,
            config_text: text,
            version: 0,
            object_sequence: 0,
            seal_key,
            gains_publisher: vservo_protocol::publisher(node, &instance, Topic::Gains)?,
            object_publisher: vservo_protocol::publisher(node, &instance, Topic::Object)?,
            server,
            log_limit: LogLimit::new(COMMAND_LOG_WINDOW, COMMAND_LOG_LINES),
            node_restart: false,
        };
        commander.publish_gains(gains)?;
        Ok(commander)
    }

    /// The configuration text in force: the file as it was last loaded or reloaded successfully.
    pub fn config_text(&self) -> &str {
        &self.config_text
    }

    /// The gains version in force.
    pub fn gains_version(&self) -> u64 {
        self.version
    }

    /// ξ_d in force.
    fn desired_features(&self) -> [f64; FEATURES] {
        let features = self.target.map_or(self.config.cell.desired.features, |t| t.features);
        let mut out = [0.0; FEATURES];
        out.copy_from_slice(features.as_slice());
        out
    }

    /// Publishes `gains` as the next version, which is then the one in force.
    fn publish_gains(&mut self, gains: &Gains) -> Result<(), GainsRefused> {
        let message = gains_message(&LawGains::from(gains), self.version + 1, &self.seal_key);
        let sample = self.gains_publisher.loan_uninit().map_err(|e| GainsRefused::Publish(e.to_string()))?;
        sample.write_payload(message).send().map_err(|e| GainsRefused::Publish(e.to_string()))?;
        self.version += 1;
        Ok(())
    }

    /// Answers every pending request, and hands the latest gains and object command to subscribers that
    /// came since (a restarted servo or plant): iceoryx2 delivers a publisher's history when it updates
    /// its connections.
    pub fn serve(&mut self, heard: &LoopState, systemd: &mut Systemd, safety: &mut Safety) {
        let now = std::time::Instant::now();
        for result in [self.gains_publisher.update_connections(), self.object_publisher.update_connections()]
        {
            if let Err(e) = result {
                tracing::warn!("handing on the latest gains or object command: {e}");
            }
        }
        while let Ok(Some(request)) = self.server.receive() {
            let command = *request.payload();
            let outcome = self.answer(&command, heard, systemd, safety);
            let text = self.describe(&outcome);
            if self.log_limit.admit(now, outcome.is_ok()) {
                let kind = CommandKind::try_from(command.kind).map_or("unknown", CommandKind::name);
                match &outcome {
                    Ok(_) => tracing::info!(id = command.id, kind, "command accepted: {text}"),
                    Err(_) => tracing::warn!(id = command.id, kind, "command refused: {text}"),
                }
            }
            let reply = CommandReplyMsg::new(
                command.id,
                outcome.is_ok(),
                self.version,
                self.desired_features(),
                &text,
            );
            if let Err(e) = request.send_copy(reply) {
                tracing::warn!(id = command.id, "the reply could not be sent: {e}");
            }
        }
        if let Some(summary) = self.log_limit.summary(now) {
            tracing::warn!("{summary}");
        }
    }

    /// Carries out one request.
    fn answer(
        &mut self,
        command: &CommandMsg,
        heard: &LoopState,
        systemd: &mut Systemd,
        safety: &mut Safety,
    ) -> Result<Accepted, CommandRefused> {
        vservo_protocol::inbox::accept(*command).map_err(|_| CommandRefused::Schema(command.schema))?;
        let kind =
            CommandKind::try_from(command.kind).map_err(|_| CommandRefused::UnknownKind(command.kind))?;
        match kind {
            CommandKind::Reload => self.reload(systemd, safety.holding()),
            CommandKind::Resume => Ok(Accepted::Resumed(safety.resume(&heard.conditions)?)),
            CommandKind::SafeStop => Ok(safety.request_safe_stop().map(|()| Accepted::SafeStop)?),
            CommandKind::TargetFeatures | CommandKind::TargetPose | CommandKind::TargetTeach => {
                self.retarget(&target_request(kind, command), heard)
            }
            CommandKind::ObjectHold | CommandKind::ObjectStep | CommandKind::ObjectCircle => {
                self.object(kind, command)
            }
            CommandKind::MoveJoints => {
                // a driver that is not running would take the move up when it comes back, not the servo
                if heard.conditions.robot != RobotState::Running {
                    return Err(CommandRefused::Move(joint_move::MoveRefused::RobotNotRunning(
                        heard.conditions.robot,
                    )));
                }
                let joint_move = joint_move::check(command, &self.config.cell.arm)?;
                let out_of_hold = command.flags & MOVE_OUT_OF_HOLD != 0;
                Ok(match safety.move_joints(joint_move, &heard.conditions, out_of_hold)? {
                    None => Accepted::Moving(joint_move),
                    Some(resumed) => Accepted::MovingOutOfStop { joint_move, resumed },
                })
            }
            CommandKind::Servo => Ok(safety
                .servo()
                .map(|held| if held { Accepted::MoveCancelled } else { Accepted::Servoing })?),
            CommandKind::Speed => {
                let to = command.speed_fraction;
                let from = safety.set_speed_scale(to, command.flags & SPEED_WHILE_MOVING != 0)?;
                Ok(Accepted::Speed { from, to })
            }
        }
    }

    /// Re-reads the configuration file; applies the live keys (`[controller]`, `[desired]`) or refuses the
    /// whole file with the reason. systemd hears RELOADING=1 first and READY=1 after, either way.
    pub fn reload(&mut self, systemd: &mut Systemd, held: bool) -> Result<Accepted, CommandRefused> {
        systemd.reloading();
        let outcome = self.try_reload(held).map_err(CommandRefused::Reload);
        let text = self.describe(&outcome);
        systemd.reloaded(&match &outcome {
            Ok(_) => format!("reloaded: {text}"),
            Err(_) => format!("reload refused: {text}"),
        });
        outcome
    }

    /// What a command came to, as its reply and log line say it.
    pub fn describe(&self, outcome: &Result<Accepted, CommandRefused>) -> String {
        outcome::reply_text(outcome, self.version)
    }

    /// Whether a reload asked for the nodes that read the camera to restart (asked once).
    pub fn take_node_restart(&mut self) -> bool {
        std::mem::take(&mut self.node_restart)
    }

    fn try_reload(&mut self, held: bool) -> Result<Accepted, ReloadRefused> {
        let path = self.config_path.display().to_string();
        // the file with the bases it extends merged in, as at start
        let (config, text) = Config::load_with_text(&self.config_path).map_err(|e| match e {
            vservo_config::ConfigError::Read { reason, .. } => {
                ReloadRefused::Unreadable { path: path.clone(), reason }
            }
            other => ReloadRefused::from(other),
        })?;
        let (target, changed, restart_nodes) =
            match reload::plan(&path, (&self.config, held), self.target.as_ref(), &config)? {
                ReloadPlan::Nothing => {
                    return Ok(Accepted::NothingChanged { path, gains_version: self.version });
                }
                ReloadPlan::Design { target, changed, restart_nodes } => (target, changed, restart_nodes),
            };
        let refused = |why| ReloadRefused::Gains { path: path.clone(), why };
        let gains =
            vservo_cell::gains::design(&config.cell, target.as_ref()).map_err(|e| refused(e.into()))?;
        self.publish_gains(&gains).map_err(refused)?;
        self.config = config;
        self.config_text = text;
        self.target = target;
        // the helpers vservod starts from here on, and clients that look, read the reloaded configuration
        if let Err(error) = self.instance_dir.write_configuration(&self.config_text) {
            tracing::warn!(%error, "the reloaded configuration could not be written for the helpers and clients");
        }
        self.node_restart |= restart_nodes;
        Ok(Accepted::Reloaded { path, changed, gains_version: self.version, restarting_nodes: restart_nodes })
    }

    /// Places the target a client asks for and designs gains for it.
    fn retarget(&mut self, request: &TargetRequest, heard: &LoopState) -> Result<Accepted, CommandRefused> {
        let margin_px = self.config.cell.controller.options.border_margin_px;
        let target = vservo_cell::target::place(&self.config.cell, margin_px, request, &heard.cell_now())
            .map_err(|why| CommandRefused::Target { request: request.name(), why })?;
        let gains = vservo_cell::gains::design(&self.config.cell, Some(&target))
            .map_err(|e| CommandRefused::TargetGains(e.into()))?;
        self.publish_gains(&gains).map_err(CommandRefused::TargetGains)?;
        self.target = Some(target);
        Ok(Accepted::Target { gains_version: self.version })
    }

    /// Checks an object command, seals it and hands it to the plant.
    fn object(&mut self, kind: CommandKind, command: &CommandMsg) -> Result<Accepted, CommandRefused> {
        let motion = object_motion(kind, command);
        let simulated = self.config.cell.robot.driver == vservo_config::RobotDriver::Simulated;
        object::check(&motion, simulated, self.config.cell.fixed_camera.is_some())?;
        let mut message = ObjectMsg {
            schema: SCHEMA_VERSION,
            kind: kind.into(),
            sequence: self.object_sequence + 1,
            translation_m: command.translation_m,
            radius_m: command.radius_m,
            rev_per_min: command.rev_per_min,
            stamp_ns: vservo_time::monotonic_ns(),
            seal: 0,
        };
        self.seal_key.sign(&mut message);
        let publish = |e: &dyn std::fmt::Display| CommandRefused::ObjectPublish(e.to_string());
        let sample = self.object_publisher.loan_uninit().map_err(|e| publish(&e))?;
        sample.write_payload(message).send().map_err(|e| publish(&e))?;
        self.object_sequence += 1;
        Ok(Accepted::Object(motion))
    }
}

/// The target a target command asks for (its kind is one of the three).
fn target_request(kind: CommandKind, command: &CommandMsg) -> TargetRequest {
    match kind {
        CommandKind::TargetFeatures => TargetRequest::Features(FeatureVector::from(command.features_px)),
        CommandKind::TargetPose => TargetRequest::Pose {
            translation_m: Vector3::from(command.translation_m),
            rotation_rpy_rad: Vector3::from(command.rotation_rpy_rad),
        },
        _ => TargetRequest::Teach,
    }
}

/// The motion an object command asks for (its kind is one of the three).
fn object_motion(kind: CommandKind, command: &CommandMsg) -> ObjectMotion {
    match kind {
        CommandKind::ObjectStep => ObjectMotion::Step(Vector3::from(command.translation_m)),
        CommandKind::ObjectCircle => {
            ObjectMotion::Circle { radius_m: command.radius_m, rev_per_min: command.rev_per_min }
        }
        _ => ObjectMotion::Hold,
    }
}
