//! What users do with a running instance: reload the configuration (SIGHUP or the `command` service), send
//! targets and object commands, stop the arm safely and resume (the `command` request-response service). Every request is validated
//! here, off the hot path; gains are designed here and handed to the servo (`gains`, history 1), object
//! commands to the plant (`object`). Each request gets a reply saying whether it was accepted, and why not.

use std::path::{Path, PathBuf};

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::{Node, ipc};
use nalgebra::Vector3;
use vservo_arm::{JointVector, SerialArm};
use vservo_config::Config;
use vservo_control::{Gains, GainsSpec, LawGains};
use vservo_protocol::{
    CommandMsg, CommandReplyMsg, FEATURES, FeaturesMsg, GainsMsg, JointStateMsg, ObjectMsg, SCHEMA_VERSION,
    Topic, command_kind,
};
use vservo_runtime::wire::gains_message;
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS};

use crate::faults::Conditions;
use crate::log_limit::LogLimit;
use crate::safety::Safety;
use crate::systemd::Systemd;

/// Keys a reload may change while the arm runs; every other key shapes the running processes.
const LIVE_SECTIONS: [&str; 2] = ["controller", "desired"];

/// Features closer than this to the image border are refused as targets (px): a mark there is cut by the
/// border or leaves the image at the first disturbance.
const TARGET_BORDER_MARGIN_PX: f64 = 10.0;
/// A feature target must be the image of the board from some camera pose to within this (px).
const TARGET_POSE_FIT_PX: f64 = 3.0;
/// Two target marks closer than this (px) would merge in the image.
const TARGET_MIN_SEPARATION_PX: f64 = 20.0;

/// The latest of what the loop published, as the supervisor heard it.
pub struct LoopState<'a> {
    /// The latest joint state.
    pub joint_state: Option<&'a JointStateMsg>,
    /// The latest features.
    pub features: Option<&'a FeaturesMsg>,
    /// What a resume depends on.
    pub conditions: Conditions,
}

/// The daemon's command side: the running configuration and design, and the ports to hand them on.
pub struct Commander {
    config_path: PathBuf,
    config: Config,
    config_text: String,
    arm: SerialArm,
    spec: GainsSpec,
    version: u64,
    object_sequence: u64,
    /// The run's key: gains and object commands are sealed with it (the nodes take no others).
    seal_key: vservo_protocol::seal::SealKey,
    gains_publisher: Publisher<ipc::Service, GainsMsg, ()>,
    object_publisher: Publisher<ipc::Service, ObjectMsg, ()>,
    server: Server<ipc::Service, CommandMsg, (), CommandReplyMsg, ()>,
    /// One log line per command, up to a rate journald keeps; a summary line for floods.
    log_limit: LogLimit,
}

impl Commander {
    /// Designs the configured gains (version 1) and publishes them.
    pub fn new(
        node: &Node<ipc::Service>,
        config_path: &Path,
        config: Config,
        text: String,
        seal_key: vservo_protocol::seal::SealKey,
    ) -> anyhow::Result<Self> {
        let instance = config.instance.clone();
        let spec = config.gains_spec();
        let mut commander = Self {
            config_path: config_path.to_path_buf(),
            arm: config.arm.clone(),
            spec,
            config,
            config_text: text,
            version: 0,
            object_sequence: 0,
            seal_key,
            gains_publisher: vservo_protocol::publisher(node, &instance, Topic::Gains)?,
            object_publisher: vservo_protocol::publisher(node, &instance, Topic::Object)?,
            server: vservo_protocol::open_command_service(
                node,
                &instance,
                vservo_protocol::Opening::OpenOrCreate,
            )?
            .server_builder()
            .create()
            .map_err(|e| anyhow::anyhow!("creating the command server: {e}"))?,
            log_limit: LogLimit::new(std::time::Duration::from_secs(1), 10),
        };
        commander.adopt(spec).map_err(anyhow::Error::msg)?;
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
    pub fn target(&self) -> [f64; FEATURES] {
        let mut out = [0.0; FEATURES];
        out.copy_from_slice(self.spec.desired_features.as_slice());
        out
    }

    /// Designs gains for `spec`, publishes them as the next version and makes them current.
    fn adopt(&mut self, spec: GainsSpec) -> Result<(), String> {
        let gains = Gains::design(&spec).map_err(|e| format!("the gain cannot be designed: {e}"))?;
        let message = gains_message(&LawGains::from(&gains), self.version + 1, &self.seal_key);
        let sample = self.gains_publisher.loan_uninit().map_err(|e| format!("publishing the gains: {e}"))?;
        sample.write_payload(message).send().map_err(|e| format!("publishing the gains: {e}"))?;
        self.version += 1;
        self.spec = spec;
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
            let outcome = if command.schema != SCHEMA_VERSION {
                Err(format!("schema {} is not this daemon's ({SCHEMA_VERSION})", command.schema))
            } else if command.kind == command_kind::RELOAD {
                self.reload(systemd)
            } else if command.kind == command_kind::RESUME {
                safety.resume(&heard.conditions)
            } else if command.kind == command_kind::SAFE_STOP {
                safety.request_safe_stop()
            } else {
                self.handle(&command, heard)
            };
            if self.log_limit.admit(now, outcome.is_ok()) {
                match &outcome {
                    Ok(what) => {
                        tracing::info!(id = command.id, kind = command.kind, "command accepted: {what}")
                    }
                    Err(why) => {
                        tracing::warn!(id = command.id, kind = command.kind, "command refused: {why}")
                    }
                }
            }
            let (accepted, text) = match outcome {
                Ok(what) => (true, what),
                Err(why) => (false, why),
            };
            let reply = CommandReplyMsg::new(command.id, accepted, self.version, self.target(), &text);
            if let Err(e) = request.send_copy(reply) {
                tracing::warn!(id = command.id, "the reply could not be sent: {e}");
            }
        }
        if let Some(summary) = self.log_limit.summary(now) {
            tracing::warn!("{summary}");
        }
    }

    /// Re-reads the configuration file; applies the live keys (`[controller]`, `[desired]`) or refuses the
    /// whole file with the reason. systemd hears RELOADING=1 first and READY=1 after, either way.
    pub fn reload(&mut self, systemd: &mut Systemd) -> Result<String, String> {
        systemd.reloading();
        let result = self.try_reload();
        systemd.reloaded(&match &result {
            Ok(what) => format!("reloaded: {what}"),
            Err(why) => format!("reload refused: {why}"),
        });
        result
    }

    fn try_reload(&mut self) -> Result<String, String> {
        let path = self.config_path.display().to_string();
        let text = std::fs::read_to_string(&self.config_path).map_err(|e| {
            format!("{path}: cannot be read ({e}); the running gains (version {}) stay", self.version)
        })?;
        let config = Config::from_toml(&text, &path)
            .map_err(|e| format!("{e}; the running gains (version {}) stay", self.version))?;
        let changed = changed_keys(&self.config_text, &text);
        let restart_only: Vec<&String> = changed
            .iter()
            .filter(|k| !LIVE_SECTIONS.iter().any(|s| k.starts_with(&format!("{s}."))))
            .collect();
        if !restart_only.is_empty() {
            return Err(format!(
                "{path}: {} cannot change while the arm runs (they shape the running processes: arm, timing, camera, plant, nodes); restart vservod to apply them; nothing was applied",
                restart_only.iter().map(|k| k.as_str()).collect::<Vec<_>>().join(", ")
            ));
        }
        if changed.is_empty() {
            return Ok(format!("{path}: nothing changed; gains version {}", self.version));
        }
        let mut spec = config.gains_spec();
        // a target a client set stays unless the file's [desired] changed; it must be clear of the new margin
        if !changed.iter().any(|k| k.starts_with("desired.")) {
            spec.desired_features = self.spec.desired_features;
            spec.desired_depths = self.spec.desired_depths;
            inside_margin(&config.camera, &spec.desired_features, spec.options.border_margin_px).map_err(
                |e| {
                    format!(
                        "{path}: the target in force: {e}; the running gains (version {}) stay",
                        self.version
                    )
                },
            )?;
        }
        self.adopt(spec)
            .map_err(|e| format!("{path}: {e}; the running gains (version {}) stay", self.version))?;
        self.config = config;
        self.config_text = text;
        Ok(format!("{path}: {} changed; gains version {}", changed.join(", "), self.version))
    }

    fn handle(&mut self, command: &CommandMsg, heard: &LoopState) -> Result<String, String> {
        match command.kind {
            command_kind::TARGET_FEATURES => {
                let features = FeatureVector::from(command.features_px);
                self.check_target_features(&features)?;
                // the camera pose that sees the board so: it gives the depths, and must be reachable
                let camera = &self.config.camera;
                let camera_from_board =
                    camera.board_pose_from_features(&self.config.board, &features).ok_or(
                        "target: no camera pose images the board's marks there (three of them in a line?)",
                    )?;
                let (seen, depths) = camera
                    .project_marks_with_depths(&self.config.board, &camera_from_board)
                    .map_err(|e| format!("target: {e}"))?;
                let off_px = (seen - features).amax();
                if off_px > TARGET_POSE_FIT_PX {
                    return Err(format!(
                        "target: these features are no image of the board: the camera pose fitted to them (plane homography) reprojects the marks up to {off_px:.1} px away (at most {TARGET_POSE_FIT_PX} px)"
                    ));
                }
                self.check_reachable(&camera_from_board, heard)?;
                self.retarget(features, depths)
            }
            command_kind::TARGET_POSE => {
                let values = command.translation_m.iter().chain(&command.rotation_rpy_rad);
                if !values.into_iter().all(|v| v.is_finite()) {
                    return Err("target pose: a number is not finite".into());
                }
                let camera_from_board = vservo_config::pose_from_rpy(
                    Vector3::from(command.translation_m),
                    Vector3::from(command.rotation_rpy_rad),
                );
                let (features, depths) = self
                    .config
                    .camera
                    .project_marks_with_depths(&self.config.board, &camera_from_board)
                    .map_err(|e| format!("target pose: {e}"))?;
                self.check_target_features(&features)?;
                self.check_reachable(&camera_from_board, heard)?;
                self.retarget(features, depths)
            }
            command_kind::TARGET_TEACH => {
                let features = heard
                    .features
                    .filter(|f| f.valid_mask == 0b1111)
                    .map(|f| FeatureVector::from(f.features_px))
                    .ok_or("teach: the camera does not see all four marks now")?;
                let camera_from_board = self.camera_from_board_seen(&features)?;
                let (_, depths) = self
                    .config
                    .camera
                    .project_marks_with_depths(&self.config.board, &camera_from_board)
                    .map_err(|e| format!("teach: {e}"))?;
                self.check_target_features(&features)?;
                self.retarget(features, depths)
            }
            command_kind::OBJECT_HOLD | command_kind::OBJECT_STEP | command_kind::OBJECT_CIRCLE => {
                self.object(command)
            }
            other => Err(format!("unknown command kind {other}")),
        }
    }

    fn retarget(
        &mut self,
        features: FeatureVector,
        depths: vservo_scene::MarkDepths,
    ) -> Result<String, String> {
        let mut spec = self.spec;
        spec.desired_features = features;
        spec.desired_depths = depths;
        self.adopt(spec).map_err(|e| format!("target: {e}"))?;
        Ok(format!("new target; gains version {}", self.version))
    }

    /// Finite, inside the image with a margin, marks apart, in the layout's orientation.
    fn check_target_features(&self, features: &FeatureVector) -> Result<(), String> {
        if !features.iter().all(|v| v.is_finite()) {
            return Err("target: a feature is not finite".into());
        }
        inside_margin(&self.config.camera, features, self.spec.options.border_margin_px)
            .map_err(|e| format!("target: {e}"))?;
        for a in 0..MARKS {
            for b in a + 1..MARKS {
                let d = ((features[2 * a] - features[2 * b]).powi(2)
                    + (features[2 * a + 1] - features[2 * b + 1]).powi(2))
                .sqrt();
                if d < TARGET_MIN_SEPARATION_PX {
                    return Err(format!(
                        "target: marks {} and {} are {d:.1} px apart (at least {TARGET_MIN_SEPARATION_PX} px)",
                        a + 1,
                        b + 1
                    ));
                }
            }
        }
        if quad_area(features).signum() != quad_area(&self.config.desired.features).signum() {
            return Err(
                "target: the marks are in mirrored order (the board would have to be seen from behind)"
                    .into(),
            );
        }
        Ok(())
    }

    /// The board as the camera sees it in `features` (all four marks): the pose the board-plane
    /// homography gives, as a real cell has it (no simulated world is consulted).
    fn camera_from_board_seen(&self, features: &FeatureVector) -> Result<IsometryMatrix3<f64>, String> {
        self.config
            .camera
            .board_pose_from_features(&self.config.board, features)
            .ok_or_else(|| "the board's pose cannot be found from the features seen now".to_string())
    }

    /// Where the board is, in the base frame, and the joints now: from the latest joint state and the
    /// latest features with all four marks (the camera's pose from forward kinematics times the board's
    /// pose the features give). Before both are heard, the configuration's desired arrangement.
    fn board_and_joints_now(&self, heard: &LoopState) -> (IsometryMatrix3<f64>, JointVector) {
        let seen = heard
            .features
            .filter(|f| f.valid_mask == 0b1111)
            .and_then(|f| self.camera_from_board_seen(&FeatureVector::from(f.features_px)).ok());
        match (heard.joint_state, seen) {
            (Some(state), Some(camera_from_board)) => {
                let q = JointVector::from(state.q_rad);
                (self.arm.base_from_tool(&q) * self.config.tool_from_camera * camera_from_board, q)
            }
            (Some(state), None) => (self.config.base_from_board(&self.arm), JointVector::from(state.q_rad)),
            _ => (self.config.base_from_board(&self.arm), self.config.desired.joints),
        }
    }

    /// The arm can put the camera at `camera_from_board` with the board where it is now.
    fn check_reachable(
        &self,
        camera_from_board: &IsometryMatrix3<f64>,
        heard: &LoopState,
    ) -> Result<(), String> {
        let (base_from_board, q_now) = self.board_and_joints_now(heard);
        let base_from_tool =
            base_from_board * camera_from_board.inverse() * self.config.tool_from_camera.inverse();
        self.arm.reach(&base_from_tool, &q_now).map(|_| ()).ok_or_else(|| {
            "target pose: out of the arm's reach, or no arm configuration inside the joint limits reaches it"
                .to_string()
        })
    }

    fn object(&mut self, command: &CommandMsg) -> Result<String, String> {
        if self.config.robot.driver != vservo_config::RobotDriver::Simulated {
            return Err("object: the board is the simulation's; with robot.driver = \"external\" there is none to move".into());
        }
        let values = command.translation_m.iter().chain([&command.radius_m, &command.rev_per_min]);
        if !values.into_iter().all(|v| v.is_finite()) {
            return Err("object: a number is not finite".into());
        }
        let what = match command.kind {
            command_kind::OBJECT_STEP => {
                let jump = Vector3::from(command.translation_m).norm();
                if jump > 0.2 {
                    return Err(format!(
                        "object step: {jump:.3} m is more than the 0.2 m the simulated cell allows"
                    ));
                }
                format!("the board jumps by {:?} m", command.translation_m)
            }
            command_kind::OBJECT_CIRCLE => {
                if !(0.0..=0.2).contains(&command.radius_m) || !(0.0..=60.0).contains(&command.rev_per_min) {
                    return Err(format!(
                        "object circle: radius {} m and speed {} rev/min must be within 0–0.2 m and 0–60 rev/min",
                        command.radius_m, command.rev_per_min
                    ));
                }
                format!("the board circles: {} m at {} rev/min", command.radius_m, command.rev_per_min)
            }
            _ => "the board holds still".to_string(),
        };
        let mut message = ObjectMsg {
            schema: SCHEMA_VERSION,
            kind: command.kind,
            sequence: self.object_sequence + 1,
            translation_m: command.translation_m,
            radius_m: command.radius_m,
            rev_per_min: command.rev_per_min,
            seal: 0,
        };
        message.seal = self.seal_key.seal_object(&message);
        let sample = self.object_publisher.loan_uninit().map_err(|e| format!("object: {e}"))?;
        sample.write_payload(message).send().map_err(|e| format!("object: {e}"))?;
        self.object_sequence += 1;
        Ok(what)
    }
}

/// Signed area of the quadrilateral of the four marks in feature order (shoelace; px²).
fn quad_area(features: &FeatureVector) -> f64 {
    let mut twice = 0.0;
    for a in 0..MARKS {
        let b = (a + 1) % MARKS;
        twice += features[2 * a] * features[2 * b + 1] - features[2 * b] * features[2 * a + 1];
    }
    twice / 2.0
}

/// Dotted paths of the keys whose values differ between two TOML texts (added and removed keys count).
pub fn changed_keys(old: &str, new: &str) -> Vec<String> {
    fn walk(prefix: &str, a: Option<&toml::Value>, b: Option<&toml::Value>, out: &mut Vec<String>) {
        match (a, b) {
            (Some(toml::Value::Table(a)), Some(toml::Value::Table(b))) => {
                let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
                keys.sort();
                keys.dedup();
                for key in keys {
                    let path = if prefix.is_empty() { key.clone() } else { format!("{prefix}.{key}") };
                    walk(&path, a.get(key), b.get(key), out);
                }
            }
            (a, b) if a != b => out.push(prefix.to_string()),
            _ => {}
        }
    }
    let parse = |text: &str| text.parse::<toml::Table>().ok().map(toml::Value::Table);
    let mut out = Vec::new();
    walk("", parse(old).as_ref(), parse(new).as_ref(), &mut out);
    out
}

/// Every mark of `features` inside the image, [`TARGET_BORDER_MARGIN_PX`] or the barrier's margin
/// (`controller.border_margin_px`, whichever is wider) from its border: the barrier would keep the servo from
/// a target inside its margin.
fn inside_margin(
    camera: &vservo_scene::CameraIntrinsics,
    features: &FeatureVector,
    barrier_margin_px: f64,
) -> Result<(), String> {
    let (w, h) = (f64::from(camera.width_px()), f64::from(camera.height_px()));
    let m = TARGET_BORDER_MARGIN_PX.max(barrier_margin_px);
    let whose =
        if barrier_margin_px > TARGET_BORDER_MARGIN_PX { " (controller.border_margin_px)" } else { "" };
    for mark in 0..MARKS {
        let (x, y) = (features[2 * mark], features[2 * mark + 1]);
        if !(m..=w - m).contains(&x) || !(m..=h - m).contains(&y) {
            return Err(format!(
                "mark {} at ({x:.1}, {y:.1}) px is outside the image or within {m} px{whose} of its border ({w}×{h} px)",
                mark + 1
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changed_keys_name_every_difference() {
        let old = "[controller]\nq = 300.0\nr = [1, 1, 1, 6, 6, 6]\n[plant]\nmode = \"dynamic\"\n";
        let new =
            "[controller]\nq = 300.0\nr = [2, 2, 2, 6, 6, 6]\n[plant]\nmode = \"kinematic\"\nextra = 1\n";
        assert_eq!(changed_keys(old, new), vec!["controller.r", "plant.extra", "plant.mode"]);
        assert!(changed_keys(old, old).is_empty());
    }

    #[test]
    fn the_area_sign_follows_the_order_of_the_marks() {
        let square = FeatureVector::from([0.0, 0.0, 10.0, 0.0, 10.0, 10.0, 0.0, 10.0]);
        let mirrored = FeatureVector::from([0.0, 0.0, 0.0, 10.0, 10.0, 10.0, 10.0, 0.0]);
        assert_eq!(quad_area(&square), 100.0);
        assert_eq!(quad_area(&mirrored), -100.0);
    }

    #[test]
    fn a_target_is_kept_clear_of_the_barriers_margin_when_it_is_wider_than_the_border_margin() {
        let camera = vservo_scene::CameraIntrinsics::paper();
        // mark 4 at 15 px from the top
        let target = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 15.0]);
        assert!(inside_margin(&camera, &target, 0.0).is_ok());
        let refused = inside_margin(&camera, &target, 20.0).expect_err("inside the barrier's margin");
        assert!(refused.contains("mark 4") && refused.contains("controller.border_margin_px"), "{refused}");
        let refused = inside_margin(&camera, &target.map(|v| v - 10.0), 0.0).expect_err("within 10 px");
        assert!(!refused.contains("controller.border_margin_px"), "{refused}");
    }
}
