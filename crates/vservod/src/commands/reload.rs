//! A reload as a diff of validated configurations: which keys changed, whether each may change while the
//! arm runs (`[controller]` and `[desired]` may; every other key shapes the running processes), and the
//! gains specification the reload designs. The camera's lens and mount ([`NODE_RESTART_KEYS`], what
//! `vservoctl calibrate --apply` writes) are applied while the cell is held, by restarting the nodes that read
//! them. Pure: the commander reads the file and publishes the result.

use vservo_cell::target::{self, Target, TargetRefused};
use vservo_config::{CellConfig, Config, ConfigError};

/// Why a reload is refused; nothing is applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReloadRefused {
    /// The file cannot be read.
    #[error("{path}: cannot be read ({reason})")]
    Unreadable {
        /// The configuration file.
        path: String,
        /// The system's reason.
        reason: String,
    },
    /// The file does not validate.
    #[error(transparent)]
    Invalid(#[from] ConfigError),
    /// The camera changed while the cell is not held.
    #[error(
        "{path}: {} change the camera the servo, vision and rmrc nodes run: they are applied while the cell is held, by restarting those nodes (`vservoctl safe-stop`, then reload, then `vservoctl resume`); nothing was applied",
        keys.join(", ")
    )]
    NotHeld {
        /// The configuration file.
        path: String,
        /// The camera keys that changed.
        keys: Vec<&'static str>,
    },
    /// Keys changed that only a restart applies.
    #[error(
        "{path}: {} cannot change while the arm runs (they shape the running processes: arm, timing, camera, plant, nodes); restart vservod to apply them; nothing was applied",
        keys.join(", ")
    )]
    RestartOnly {
        /// The configuration file.
        path: String,
        /// The restart-only keys that changed.
        keys: Vec<&'static str>,
    },
    /// The target a client set is not one under the new `[controller]` (inside the barrier's new margin).
    #[error("{path}: the target in force: {why}")]
    TargetInForce {
        /// The configuration file.
        path: String,
        /// Why it is no target now.
        why: TargetRefused,
    },
    /// The gains cannot be designed or handed on.
    #[error("{path}: {why}")]
    Gains {
        /// The configuration file.
        path: String,
        /// Why.
        why: crate::commands::GainsRefused,
    },
}

/// The keys whose validated values differ, split by whether they may change while the arm runs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ConfigDiff {
    /// Changed keys of `[controller]` and `[desired]`.
    pub live: Vec<&'static str>,
    /// Changed keys of every other section.
    pub restart_only: Vec<&'static str>,
}

impl ConfigDiff {
    /// Whether `[desired]` changed.
    pub fn desired_changed(&self) -> bool {
        self.live.iter().any(|key| key.starts_with("desired"))
    }
}

/// `(key, changed)` for the fields of a section, each named `section.field`.
macro_rules! fields {
    ($section:literal, $old:expr, $new:expr; $($field:ident),+) => {
        [$((concat!($section, ".", stringify!($field)), $old.$field != $new.$field)),+]
    };
}

/// The changed keys of one section: the fields named that changed, or the section itself when it changed
/// in a field not named.
fn section(out: &mut Vec<&'static str>, name: &'static str, changed: bool, fields: &[(&'static str, bool)]) {
    if !changed {
        return;
    }
    let named = fields.iter().filter(|(_, changed)| *changed).map(|(key, _)| *key);
    let before = out.len();
    out.extend(named);
    if out.len() == before {
        out.push(name);
    }
}

/// A fixed camera's keys that differ: its kind of mount, its pose, and where its board sits on the tool
/// ([desired] read with the camera fixed: the board is where it is, so a new desired pose is a new cell).
fn fixed_camera_keys(
    old: &Option<vservo_config::FixedCamera>,
    new: &Option<vservo_config::FixedCamera>,
) -> [(&'static str, bool); 3] {
    let both = old.zip(*new);
    [
        ("camera.mount", old.is_some() != new.is_some()),
        ("camera.base_from_camera", both.is_some_and(|(o, n)| o.base_from_camera != n.base_from_camera)),
        (
            "desired (the board on the tool)",
            both.is_some_and(|(o, n)| o.tool_from_board != n.tool_from_board),
        ),
    ]
}

/// The keys that differ between the configuration in force and a new one.
pub fn diff(old: &Config, new: &Config) -> ConfigDiff {
    // every section is named here or in `cell_sections`: a new one does not compile until it is sorted into live
    // or restart-only
    let Config {
        origin: _,
        instance,
        // the cell's sections
        cell: _,
        runtime,
        arm_urdf_file,
        faults,
        viewer,
        ros2,
        franka,
        // read by the GStreamer camera driver at its start, not by the daemon
        gstreamer: _,
        // read by `vservoctl calibrate`; a board printed on the simulated object is in `board`
        calibration: _,
    } = old;
    let mut restart = Vec::new();
    let r = &mut restart;
    section(r, "instance.name", instance != &new.instance, &[]);
    let live = cell_sections(&old.cell, &new.cell, r);
    section(r, "runtime", runtime != &new.runtime, &runtime_keys(runtime, &new.runtime));
    let arm_changed = old.cell.arm != new.cell.arm || arm_urdf_file != &new.arm_urdf_file;
    section(r, "robot.arm", arm_changed, &[]);
    // the times are durations in Config, named by their keys in the file
    let fault_keys = [
        ("faults.target_lost_s", faults.target_lost != new.faults.target_lost),
        ("faults.saturation_s", faults.saturation != new.faults.saturation),
        ("faults.resume", faults.resume != new.faults.resume),
        ("faults.resume_after_s", faults.resume_after != new.faults.resume_after),
    ];
    section(r, "faults", faults != &new.faults, &fault_keys);
    section(
        r,
        "viewer",
        viewer != &new.viewer,
        &fields!("viewer", viewer, new.viewer; enabled, address, port, max_clients),
    );
    let ros2_keys = fields!("ros2", ros2, new.ros2; enabled, domain_id, namespace, interface, publish,
        image_every, allow_motion);
    section(r, "ros2", ros2 != &new.ros2, &ros2_keys);
    section(r, "franka", franka != &new.franka, &[]);
    ConfigDiff { live, restart_only: restart }
}

/// The cell's sections that differ: the live ones returned, the restart-only ones added to `restart`.
fn cell_sections(old: &CellConfig, new: &CellConfig, restart: &mut Vec<&'static str>) -> Vec<&'static str> {
    let CellConfig {
        timing,
        camera,
        tool_from_camera,
        fixed_camera,
        camera_truth,
        board,
        desired,
        controller,
        vision,
        plant,
        interpolator,
        joint_servo,
        scenario,
        robot,
        // with the URDF file it came from, in `diff`
        arm: _,
        reacquire,
        collision,
    } = old;
    let mut live = Vec::new();
    let (o, n) = (&controller.options, &new.controller.options);
    let controller_keys = fields!("controller", controller, new.controller; law, q, r);
    let option_keys = fields!(
        "controller", o, n;
        interaction, border_margin_px, feedforward, pose_gain_per_s, pose_max_speed_m_s, pose_max_rotation_rad_s
    );
    let changed_keys = [&controller_keys[..], &option_keys[..]].concat();
    section(&mut live, "controller", controller != &new.controller, &changed_keys);
    let desired_keys = [("desired.joints_rad", desired.joints != new.desired.joints)];
    section(&mut live, "desired", desired != &new.desired, &desired_keys);
    let r = restart;
    let timing_keys =
        fields!("timing", timing, new.timing; vision_period_s, pipeline_delay_frames, control_period_s);
    section(r, "timing", timing != &new.timing, &timing_keys);
    section(r, "camera", camera != &new.camera, &[]);
    section(r, "camera.tool_from_camera", tool_from_camera != &new.tool_from_camera, &[]);
    let fixed_keys = fixed_camera_keys(fixed_camera, &new.fixed_camera);
    section(r, "camera.mount", fixed_camera != &new.fixed_camera, &fixed_keys);
    section(r, "camera.truth", camera_truth != &new.camera_truth, &[]);
    section(r, "object", board != &new.board, &[]);
    let source_keys = [("camera.source", vision.source != new.vision.source)];
    section(r, "vision", vision != &new.vision, &source_keys);
    section(r, "plant", plant != &new.plant, &fields!("plant", plant, new.plant; mode, rk4_substeps));
    section(r, "interpolator", interpolator != &new.interpolator, &[]);
    let servo_keys = fields!("joint_servo", joint_servo, new.joint_servo; law, kp, kv);
    section(r, "joint_servo", joint_servo != &new.joint_servo, &servo_keys);
    section(r, "scenario", scenario != &new.scenario, &[]);
    let robot_keys = fields!("robot", robot, new.robot; driver, command, period_s, state_timeout_periods);
    section(r, "robot", robot != &new.robot, &robot_keys);
    section(r, "reacquire", reacquire != &new.reacquire, &[]);
    section(r, "collision", collision != &new.collision, &[]);
    live
}

/// The `[runtime]` keys, each compared.
fn runtime_keys(old: &vservo_config::Runtime, new: &vservo_config::Runtime) -> [(&'static str, bool); 12] {
    let [lock_memory, timer_slack_ns, hold_after_missed_ticks, plant, rmrc, servo, vision] = fields!("runtime",
        old, new; lock_memory, timer_slack_ns, hold_after_missed_ticks, plant, rmrc, servo, vision);
    // the times are durations in Config, named by their keys in the file
    [
        lock_memory,
        timer_slack_ns,
        ("runtime.telemetry_period_s", old.telemetry_period != new.telemetry_period),
        ("runtime.restart_backoff_initial_s", old.restart_backoff_initial != new.restart_backoff_initial),
        ("runtime.restart_backoff_max_s", old.restart_backoff_max != new.restart_backoff_max),
        hold_after_missed_ticks,
        ("runtime.stop_timeout_s", old.stop_timeout != new.stop_timeout),
        ("runtime.hang_timeout_s", old.hang_timeout != new.hang_timeout),
        plant,
        rmrc,
        servo,
        vision,
    ]
}

/// The restart-only keys a reload applies, while the cell is held, by restarting the servo, vision and rmrc
/// nodes (they read them at their start): the camera's lens and its mount on the tool.
pub const NODE_RESTART_KEYS: [&str; 2] = ["camera", "camera.tool_from_camera"];

/// What a reload does, decided before anything is applied.
#[derive(Debug, Clone, PartialEq)]
pub enum ReloadPlan {
    /// Nothing changed that the daemon runs.
    Nothing,
    /// Design gains for the new configuration and `target`; the live keys that changed.
    Design {
        /// The target a client set that stays (none: the file's `[desired]`).
        target: Option<Target>,
        /// The changed keys.
        changed: Vec<&'static str>,
        /// Whether the nodes that read the camera restart with the new configuration.
        restart_nodes: bool,
    },
}

/// Decides a reload from the configuration in force (`old`, with the target a client set, if one did) to
/// `new`: refused if a restart-only key changed; a client's target stays unless `[desired]` changed, and
/// must then still be a target under the new `[controller]` (clear of a wider barrier margin).
pub fn plan(
    path: &str,
    (old, held): (&Config, bool),
    client_target: Option<&Target>,
    new: &Config,
) -> Result<ReloadPlan, ReloadRefused> {
    let diff = diff(old, new);
    let (by_node_restart, by_daemon_restart): (Vec<&'static str>, Vec<&'static str>) =
        diff.restart_only.iter().partition(|key| NODE_RESTART_KEYS.contains(key));
    if !by_daemon_restart.is_empty() {
        return Err(ReloadRefused::RestartOnly { path: path.to_string(), keys: diff.restart_only });
    }
    if !by_node_restart.is_empty() && !held {
        return Err(ReloadRefused::NotHeld { path: path.to_string(), keys: by_node_restart });
    }
    if diff.live.is_empty() && by_node_restart.is_empty() {
        return Ok(ReloadPlan::Nothing);
    }
    let target = client_target.filter(|_| !diff.desired_changed()).copied();
    if let Some(target) = &target {
        target::check_features(&new.cell, new.cell.controller.options.border_margin_px, &target.features)
            .map_err(|why| ReloadRefused::TargetInForce { path: path.to_string(), why })?;
    }
    let restart_nodes = !by_node_restart.is_empty();
    Ok(ReloadPlan::Design { target, changed: [diff.live, by_node_restart].concat(), restart_nodes })
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEFAULT: &str = include_str!("../../../../config/vservo.toml");

    fn with(old: &str, new: &str) -> Config {
        let text = DEFAULT.replace(old, new);
        assert_ne!(text, DEFAULT, "{old} is in the default file");
        Config::from_toml(&text, "edited.toml").expect("valid")
    }

    fn default() -> Config {
        Config::from_toml(DEFAULT, "vservo.toml").expect("valid")
    }

    #[test]
    fn the_same_values_are_no_change_whatever_the_text() {
        let old = default();
        let commented = Config::from_toml(&format!("# a comment\n{DEFAULT}"), "other.toml").expect("valid");
        assert_eq!(diff(&old, &commented), ConfigDiff::default(), "comments and the origin are no change");
        assert_eq!(plan("f", (&old, false), None, &commented), Ok(ReloadPlan::Nothing));
    }

    #[test]
    fn a_restart_only_key_is_refused_by_name_with_nothing_applied() {
        let old = default();
        let new = with("mode = \"dynamic\"", "mode = \"kinematic\"");
        // the simulated driver's command interface follows from the plant's mode: both are named
        assert_eq!(diff(&old, &new).restart_only, ["plant.mode", "robot.command"]);
        let refused = plan("f.toml", (&old, false), None, &new).expect_err("restart only");
        let keys = vec!["plant.mode", "robot.command"];
        assert_eq!(refused, ReloadRefused::RestartOnly { path: "f.toml".into(), keys });
        assert!(
            refused.to_string().contains("plant.mode") && refused.to_string().contains("restart vservod")
        );
        let runtime = with("hang_timeout_s = 1.0", "hang_timeout_s = 2.0");
        assert_eq!(diff(&old, &runtime).restart_only, ["runtime.hang_timeout_s"]);
        let instance = with("name = \"default\"", "name = \"other\"");
        assert_eq!(diff(&old, &instance).restart_only, ["instance.name"]);
        // a live key changed alongside refuses the whole file
        let both = Config::from_toml(
            &DEFAULT.replace("mode = \"dynamic\"", "mode = \"kinematic\"").replace("q = 300.0", "q = 200.0"),
            "f.toml",
        )
        .expect("valid");
        assert!(matches!(plan("f", (&old, false), None, &both), Err(ReloadRefused::RestartOnly { .. })));
    }

    #[test]
    fn live_keys_are_designed_and_named() {
        let old = default();
        let new = with("interaction = \"desired\"", "interaction = \"mean\"");
        assert_eq!(
            plan("f", (&old, false), None, &new),
            Ok(ReloadPlan::Design {
                target: None,
                changed: vec!["controller.interaction"],
                restart_nodes: false
            })
        );
        let weights = with("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", "r = [4.0, 4.0, 4.0, 24.0, 24.0, 24.0]");
        assert_eq!(diff(&old, &weights).live, ["controller.r"]);
    }

    #[test]
    fn a_clients_target_stays_unless_desired_changed_and_must_clear_a_wider_margin() {
        let old = default();
        // a client's target with mark 4 at 15 px from the top
        let features =
            vservo_scene::FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 15.0]);
        let client = Target { features, depths: old.cell.desired.depths };
        let feedforward = with("feedforward = false", "feedforward = true");
        assert_eq!(
            plan("f", (&old, false), Some(&client), &feedforward),
            Ok(ReloadPlan::Design {
                target: Some(client),
                changed: vec!["controller.feedforward"],
                restart_nodes: false
            })
        );
        // a pose-based law and its λ are retuned live like the others
        let text = DEFAULT
            .replace("law = \"paper\"", "law = \"pbvs\"")
            .replace("# pose_gain_per_s = 6.0", "pose_gain_per_s = 4.0");
        let pose = Config::from_toml(&text, "edited.toml").expect("valid");
        assert_eq!(
            plan("f", (&old, false), Some(&client), &pose),
            Ok(ReloadPlan::Design {
                target: Some(client),
                changed: vec!["controller.law", "controller.pose_gain_per_s"],
                restart_nodes: false
            })
        );
        let margin = with("border_margin_px = 0.0", "border_margin_px = 20.0");
        assert!(matches!(
            plan("f", (&old, false), Some(&client), &margin),
            Err(ReloadRefused::TargetInForce { why: TargetRefused::OutsideImage { mark: 3, .. }, .. })
        ));
        // [desired] changed: the file's target replaces the client's
        let desired = with(
            "joints_rad = [0.0, 0.7853981633974483, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
            "joints_rad = [0.0, 0.78, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
        );
        assert_eq!(
            plan("f", (&old, false), Some(&client), &desired),
            Ok(ReloadPlan::Design {
                target: None,
                changed: vec!["desired.joints_rad"],
                restart_nodes: false
            })
        );
    }

    #[test]
    fn each_section_outside_controller_and_desired_is_restart_only_and_named() {
        let old = default();
        let cases = [
            ("pipeline_delay_frames = 1", "pipeline_delay_frames = 2", "timing.pipeline_delay_frames"),
            ("focal_px = 500.0", "focal_px = 520.0", "camera"),
            (
                "translation_m = [0.0, 0.0, 0.08]",
                "translation_m = [0.0, 0.0, 0.09]",
                "camera.tool_from_camera",
            ),
            ("mark_diameter_m = 0.015", "mark_diameter_m = 0.016", "object"),
            (
                "[camera.tool_from_camera]",
                "[camera.truth]\nfx_px = 505.0\n[camera.tool_from_camera]",
                "camera.truth",
            ),
            ("gate_px = 40.0", "gate_px = 30.0", "vision"),
            ("rk4_substeps = 1", "rk4_substeps = 2", "plant.rk4_substeps"),
            ("max_damping = 0.05", "max_damping = 0.04", "interpolator"),
            (
                "kp = [3600.0, 3600.0, 3600.0, 3600.0, 3600.0, 3600.0]",
                "kp = [3000.0, 3600.0, 3600.0, 3600.0, 3600.0, 3600.0]",
                "joint_servo.kp",
            ),
            ("duration_s = 30.0", "duration_s = 20.0", "scenario"),
            ("state_timeout_periods = 50", "state_timeout_periods = 60", "robot.state_timeout_periods"),
            ("gain_per_s = 1.5", "gain_per_s = 1.0", "reacquire"),
            ("target_lost_s = 1.0", "target_lost_s = 2.0", "faults.target_lost_s"),
            ("fifo_priority = 80", "fifo_priority = 70", "runtime.plant"),
            ("port = 8765", "port = 8766", "viewer.port"),
            ("max_clients = 4", "max_clients = 3", "viewer.max_clients"),
        ];
        for (from, to, key) in cases {
            let new = with(from, to);
            // a value derived from it elsewhere (the camera's ξ_d in [desired]) may change too; the refusal
            // names what the file changed
            assert_eq!(diff(&old, &new).restart_only, [key], "{from} → {to}");
            let refused = plan("f", (&old, false), None, &new);
            if NODE_RESTART_KEYS.contains(&key) {
                assert!(
                    matches!(refused, Err(ReloadRefused::NotHeld { keys, .. }) if keys == [key]),
                    "{key}"
                );
            } else {
                assert!(
                    matches!(refused, Err(ReloadRefused::RestartOnly { keys, .. }) if keys == [key]),
                    "{key}"
                );
            }
        }
    }

    /// The camera's lens and mount (a calibration) are applied while the cell is held, by restarting the nodes
    /// that read them; with a key only a restart of vservod applies, the whole file is refused still.
    #[test]
    fn the_camera_is_applied_while_held_by_restarting_its_nodes() {
        let old = default();
        let lens = with("focal_px = 500.0", "focal_px = 520.0");
        let refused = plan("f", (&old, false), None, &lens).expect_err("not held");
        assert!(refused.to_string().contains("vservoctl safe-stop"), "{refused}");
        let Ok(ReloadPlan::Design { target: None, changed, restart_nodes: true }) =
            plan("f", (&old, true), None, &lens)
        else {
            panic!("held: designed, the nodes restarted");
        };
        // ξ_d follows the lens: [desired] is named with the camera
        assert_eq!(changed, ["desired", "camera"]);
        let mount = with("translation_m = [0.0, 0.0, 0.08]", "translation_m = [0.0, 0.0, 0.09]");
        assert!(matches!(
            plan("f", (&old, true), None, &mount),
            Ok(ReloadPlan::Design { restart_nodes: true, .. })
        ));
        let both = Config::from_toml(
            &DEFAULT
                .replace("focal_px = 500.0", "focal_px = 520.0")
                .replace("rk4_substeps = 1", "rk4_substeps = 2"),
            "f.toml",
        )
        .expect("valid");
        assert!(matches!(
            plan("f", (&old, true), None, &both),
            Err(ReloadRefused::RestartOnly { keys, .. }) if keys == ["camera", "plant.rk4_substeps"]
        ));
    }
}
