//! `[robot.arm] preset = "urdf"`: an arm read from its URDF, and the URDFs vservo cannot honour refused with
//! the key, the file and the joint.

use std::path::{Path, PathBuf};

use vservo_config::{Config, ConfigError};

const DEFAULT: &str = include_str!("../../../config/vservo.toml");
const LIMIT: &str = r#"<limit lower="-2.5" upper="2.5" velocity="3" effort="10"/>"#;
/// A six-joint arm's own accelerations (an arm from a URDF must give them).
const ACCELERATIONS: &str = "acceleration_limits_rad_s2 = [10.0, 10.0, 10.0, 10.0, 10.0, 10.0]";

/// A directory of this test's own, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Self {
        let path = std::env::temp_dir().join(format!("vservo-urdf-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&path).expect("a scratch directory");
        Self(path)
    }

    /// Writes `urdf` and a configuration whose `[robot.arm]` reads it, with [`ACCELERATIONS`] and `arm_keys`
    /// added; loads it.
    fn load(&self, urdf: &str, arm_keys: &str, plant_mode: &str) -> Result<Config, ConfigError> {
        self.load_arm(urdf, &format!("{ACCELERATIONS}\n{arm_keys}"), plant_mode)
    }

    /// Writes `urdf` and a configuration whose `[robot.arm]` reads it, with `arm_keys` added; loads it.
    fn load_arm(&self, urdf: &str, arm_keys: &str, plant_mode: &str) -> Result<Config, ConfigError> {
        std::fs::write(self.0.join("arm.urdf"), urdf).expect("written");
        let text = DEFAULT
            .replacen(
                "preset = \"puma560\"",
                &format!("preset = \"urdf\"\nurdf = \"arm.urdf\"\n{arm_keys}"),
                1,
            )
            .replacen("mode = \"dynamic\"", &format!("mode = \"{plant_mode}\""), 1)
            .replacen(
                "joints_rad = [0.0, 0.7853981633974483, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
                "joints_rad = [0.3, 0.5, -0.4, 0.6, 0.7, 0.2]",
                1,
            );
        let path = self.0.join("cell.toml");
        std::fs::write(&path, text).expect("written");
        Config::load(&path)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// An arm of `joints` revolute joints (joint `special` of kind `kind` with `limit`), a fixed flange, and two
/// fingers branching off it.
fn urdf(joints: usize, special: usize, kind: &str, limit: &str) -> String {
    let mut text = String::from(
        r#"<robot name="test"><link name="l0"/><link name="flange"/><link name="f1"/><link name="f2"/>"#,
    );
    for j in 1..=joints {
        let (kind, limit) = if j == special { (kind, limit) } else { ("revolute", LIMIT) };
        let rx = if j % 2 == 0 { "1.5707963267948966" } else { "0" };
        text += &format!(
            r#"<link name="l{j}"/><joint name="j{j}" type="{kind}"><parent link="l{p}"/><child link="l{j}"/>
               <origin xyz="0.05 0 0.1" rpy="{rx} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>"#,
            p = j - 1
        );
    }
    text += &format!(
        r#"<joint name="flange_joint" type="fixed"><parent link="l{joints}"/><child link="flange"/><origin xyz="0 0 0.05"/></joint>
           <joint name="finger1" type="prismatic"><parent link="flange"/><child link="f1"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="1" effort="1"/></joint>
           <joint name="finger2" type="prismatic"><parent link="flange"/><child link="f2"/><axis xyz="0 -1 0"/><limit lower="0" upper="0.04" velocity="1" effort="1"/></joint>
           </robot>"#
    );
    text
}

fn refusal(result: Result<Config, ConfigError>) -> (String, String) {
    let error = result.expect_err("refused");
    (error.key().unwrap_or("").to_string(), error.to_string())
}

#[test]
fn a_six_joint_urdf_gives_the_arm_with_the_files_limits_unless_the_configuration_gives_them() {
    let scratch = Scratch::new("good");
    let config = scratch.load(&urdf(6, 0, "", ""), "tip_link = \"flange\"", "kinematic").expect("an arm");
    let vservo_arm::Geometry::Chain(chain) = &config.cell.arm.geometry else { panic!("a chain") };
    assert_eq!(
        chain.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>(),
        ["j1", "j2", "j3", "j4", "j5", "j6"]
    );
    assert_eq!((chain.base_link.as_str(), chain.tip_link.as_str()), ("l0", "flange"));
    assert_eq!(config.cell.arm.links[2].limits.position_max, 2.5);
    assert_eq!(config.cell.arm.links[2].limits.velocity_max, 3.0);
    assert!(config.arm_urdf_file.as_deref().is_some_and(|f| Path::new(f).is_absolute()));
    let keys = "tip_link = \"flange\"\njoint_limits_rad = [[-1, 1], [-1, 1], [-1, 1], [-1, 1], [-1, 1], [-1.5, 1]]\n\
                velocity_limits_rad_s = [1, 1, 1, 1, 1, 0.5]";
    let config = scratch.load(&urdf(6, 0, "", ""), keys, "kinematic").expect("an arm");
    assert_eq!(config.cell.arm.links[5].limits.position_min, -1.5);
    assert_eq!(config.cell.arm.links[5].limits.velocity_max, 0.5);
}

#[test]
fn what_vservo_cannot_honour_is_refused_naming_the_joint_and_why() {
    let scratch = Scratch::new("refused");
    let tip = "tip_link = \"flange\"";
    let far = urdf(6, 0, "", "").replacen(r#"<origin xyz="0.05 0 0.1""#, r#"<origin xyz="0.05 0 1e300""#, 1);
    let cases: [(String, &str, &str, &str, &[&str]); 10] = [
        (far, tip, "kinematic", "robot.arm.urdf", &["\"j1\": an origin more than 10 m away"]),
        (urdf(6, 4, "prismatic", LIMIT), tip, "kinematic", "robot.arm.urdf", &["\"j4\" is prismatic"]),
        (
            urdf(6, 0, "", ""),
            "tip_link = \"f1\"",
            "kinematic",
            "robot.arm.urdf",
            &["\"finger1\" is prismatic"],
        ),
        (urdf(6, 0, "", ""), "", "kinematic", "robot.arm.urdf", &["branches at link \"flange\"", "tip_link"]),
        (urdf(5, 0, "", ""), tip, "kinematic", "robot.arm.urdf", &["5 moving joints", "6 or 7"]),
        (urdf(8, 0, "", ""), tip, "kinematic", "robot.arm.urdf", &["8 moving joints"]),
        // a seven-joint arm under the six angles of a six-joint arm's desired pose
        (urdf(7, 0, "", ""), tip, "kinematic", "desired.joints_rad", &["must list the 7 joints"]),
        (
            urdf(6, 3, "continuous", ""),
            tip,
            "kinematic",
            "robot.arm.joint_limits_rad",
            &["\"j3\"", "continuous"],
        ),
        (urdf(6, 2, "revolute", ""), tip, "kinematic", "robot.arm.joint_limits_rad", &["\"j2\""]),
        (urdf(6, 0, "", ""), tip, "dynamic", "plant.mode", &["kinematic"]),
    ];
    for (text, keys, mode, key, words) in &cases {
        let (found_key, message) = refusal(scratch.load(text, keys, mode));
        assert_eq!(&found_key, key, "{message}");
        for word in *words {
            assert!(message.contains(word), "{message:?} should say {word:?}");
        }
        if *key == "robot.arm.urdf" {
            assert!(message.contains("arm.urdf"), "{message:?} should name the file");
        }
    }
    // a continuous joint bounded by the configuration is taken
    let keys =
        "tip_link = \"flange\"\njoint_limits_rad = [[-2, 2], [-2, 2], [-2, 2], [-2, 2], [-2, 2], [-2, 2]]";
    scratch
        .load(&urdf(6, 3, "continuous", r#"<limit velocity="2" effort="1"/>"#), keys, "kinematic")
        .expect("bounded");
}

/// A seven-joint arm takes a value per joint where the keys are per joint: the desired pose, the acceleration
/// limits, the null-space posture; six values are refused naming the key.
#[test]
fn a_seven_joint_arm_takes_seven_values_per_joint_key() {
    let scratch = Scratch::new("seven");
    let seven = |text: &str| {
        text.replacen(
            "joints_rad = [0.3, 0.5, -0.4, 0.6, 0.7, 0.2]",
            "joints_rad = [0.3, 0.5, -0.4, 0.6, 0.7, 0.2, 0.1]",
            1,
        )
    };
    let tip = "tip_link = \"flange\"";
    std::fs::write(scratch.0.join("arm.urdf"), urdf(7, 0, "", "")).expect("written");
    let write_and_load = |text: String| {
        let path = scratch.0.join("seven.toml");
        std::fs::write(&path, text).expect("written");
        Config::load(&path)
    };
    let text = seven(
        &DEFAULT
            .replacen("preset = \"puma560\"", &format!("preset = \"urdf\"\nurdf = \"arm.urdf\"\n{tip}"), 1)
            .replacen("mode = \"dynamic\"", "mode = \"kinematic\"", 1)
            .replacen(
                "joints_rad = [0.0, 0.7853981633974483, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
                "joints_rad = [0.3, 0.5, -0.4, 0.6, 0.7, 0.2]",
                1,
            ),
    );
    let six = text.replacen(tip, &format!("{tip}\n{ACCELERATIONS}"), 1);
    let (key, message) = refusal(write_and_load(six));
    assert_eq!(key, "robot.arm.acceleration_limits_rad_s2", "{message}");
    assert!(message.contains("must list the 7 joints"), "{message}");
    let accelerations = "acceleration_limits_rad_s2 = [10.0, 10.0, 10.0, 10.0, 10.0, 10.0, 20.0]";
    let text = text.replacen(tip, &format!("{tip}\n{accelerations}"), 1);
    let config = write_and_load(text.clone()).expect("seven values each");
    assert_eq!(config.cell.arm.joint_count(), 7);
    assert_eq!(config.cell.desired.joints[6], 0.1);
    assert_eq!(config.cell.interpolator.acceleration_limit[6], 20.0);
    assert_eq!(config.cell.interpolator.null_space.posture, None);
    let posture = |values: &str| {
        text.replacen("posture_gain = 0.5", &format!("posture_gain = 0.5\nposture_rad = {values}"), 1)
    };
    let (key, message) = refusal(write_and_load(posture("[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]")));
    assert_eq!(key, "interpolator.null_space.posture_rad", "{message}");
    let config = write_and_load(posture("[0.0, 0.1, 0.0, -0.5, 0.0, 0.7, 0.0]")).expect("a posture of seven");
    assert_eq!(config.cell.interpolator.null_space.posture.map(|p| p[5]), Some(0.7));
}

/// Limits belong to the arm: an arm from a URDF without accelerations of its own is refused naming the keys to
/// write (it never takes the PUMA 560's); its jerk and tool speed limits are taken; the interpolator may narrow
/// them, never widen them; an external driver's tool is capped by default, and the cell starts held.
#[test]
fn an_arm_without_limits_of_its_own_is_refused_and_the_interpolator_only_narrows_them() {
    let scratch = Scratch::new("limits");
    let tip = "tip_link = \"flange\"";
    let (key, message) = refusal(scratch.load_arm(&urdf(6, 0, "", ""), tip, "kinematic"));
    assert_eq!(key, "robot.arm.acceleration_limits_rad_s2", "{message}");
    for word in ["no acceleration limits of its own", "robot.arm.jerk_limits_rad_s3", "config/arms/fr3.toml"]
    {
        assert!(message.contains(word), "{message:?} should say {word:?}");
    }
    let keys = format!(
        "{tip}\n{ACCELERATIONS}\njerk_limits_rad_s3 = [500.0, 500.0, 500.0, 500.0, 500.0, 250.0]\n\
         tool_speed_limit_m_s = 1.0\ntool_rotation_limit_rad_s = 2.0"
    );
    let config = scratch.load_arm(&urdf(6, 0, "", ""), &keys, "kinematic").expect("limits of its own");
    assert_eq!(config.cell.interpolator.acceleration_limit[0], 10.0);
    assert_eq!(config.cell.interpolator.jerk_limit.map(|j| j[5]), Some(250.0));
    assert_eq!(config.cell.interpolator.tool_speed_limit_m_s, 1.0);
    assert_eq!(config.cell.interpolator.tool_rotation_limit_rad_s, 2.0);
    assert!(!config.cell.robot.start_held, "the simulated driver servos at once");
    let path = scratch.0.join("cell.toml");
    let written = std::fs::read_to_string(&path).expect("the configuration");
    let with = |from: &str, to: &str| {
        let camera = if to.contains("external") { "source = \"external\"" } else { "source = \"simulated\"" };
        let text = written.replacen(from, to, 1).replacen("source = \"simulated\"", camera, 1);
        std::fs::write(&path, text).expect("written");
        Config::load(&path)
    };
    let narrow = "[interpolator]\nacceleration_limit_rad_s2 = [5.0, 5.0, 5.0, 5.0, 5.0, 5.0]";
    let config = with("[interpolator]", narrow).expect("narrowed");
    assert_eq!(config.cell.interpolator.acceleration_limit[3], 5.0);
    let wide = "[interpolator]\nacceleration_limit_rad_s2 = [5.0, 5.0, 50.0, 5.0, 5.0, 5.0]";
    let (key, message) = refusal(with("[interpolator]", wide));
    assert_eq!(key, "interpolator.acceleration_limit_rad_s2", "{message}");
    assert!(message.contains("joint 3 asks for 50 rad/s², above the arm's 10 rad/s²"), "{message}");
    let external = "driver = \"external\"\ncommand = \"velocity\"\nperiod_s = 0.001";
    let config = with("driver = \"simulated\"", external).expect("an external arm");
    assert!(config.cell.robot.start_held, "an external arm's cell starts held");
    assert_eq!(
        config.cell.interpolator.tool_speed_limit_m_s, 0.25,
        "the first motion's cap, below the arm's 1 m/s"
    );
    assert_eq!(config.cell.interpolator.tool_rotation_limit_rad_s, 0.75);
    let config =
        with("driver = \"simulated\"", &format!("{external}\nstart = \"servoing\"")).expect("servoing");
    assert!(!config.cell.robot.start_held);
    // the PUMA 560 has its own accelerations and no jerk limit
    let puma =
        Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml")).expect("the default");
    assert_eq!(puma.cell.interpolator.acceleration_limit[2], 45.0);
    assert_eq!(puma.cell.interpolator.jerk_limit, None);
    assert_eq!(puma.cell.interpolator.tool_speed_limit_m_s, f64::INFINITY);
}

/// A configuration written before the null-space keys (an installed one kept over an upgrade) loads, with
/// the defaults config/vservo.toml documents.
#[test]
fn a_configuration_without_the_null_space_section_loads_with_its_defaults() {
    let start = DEFAULT.find("[interpolator.null_space]").expect("the section");
    let end = start + DEFAULT[start..].find("\n[").expect("a section after it") + 1;
    let text = format!("{}{}", &DEFAULT[..start], &DEFAULT[end..]);
    assert!(!text.contains("limit_zone_rad"));
    let config = Config::from_toml(&text, "old.toml").expect("loads");
    assert_eq!(config.cell.interpolator.null_space, vservo_settings::simulation::NullSpaceTask::default());
    let full = Config::from_toml(DEFAULT, "vservo.toml").expect("loads");
    assert_eq!(full.cell.interpolator.null_space, config.cell.interpolator.null_space);
}

#[test]
fn a_missing_or_broken_file_and_keys_of_another_preset_are_refused() {
    let scratch = Scratch::new("broken");
    let (key, message) = refusal(scratch.load("<robot name=\"x\"><link", "", "kinematic"));
    assert_eq!(key, "robot.arm.urdf", "{message}");
    std::fs::remove_file(scratch.0.join("arm.urdf")).ok();
    let text = DEFAULT.replacen("preset = \"puma560\"", "preset = \"urdf\"\nurdf = \"nowhere.urdf\"", 1);
    let (key, message) = refusal(Config::from_toml(&text, "test.toml"));
    assert_eq!(key, "robot.arm.urdf");
    assert!(message.contains("cannot read"), "{message}");
    let text = DEFAULT.replacen("preset = \"puma560\"", "preset = \"puma560\"\ntip_link = \"flange\"", 1);
    let (key, message) = refusal(Config::from_toml(&text, "test.toml"));
    assert_eq!(key, "robot.arm.tip_link");
    assert!(message.contains("preset = \"urdf\""), "{message}");
}

/// `[robot] driver = "franka"`: the FR3 of config/arms/fr3.toml over its FCI; what the Franka driver cannot honour
/// is refused naming the key: a section without the driver, an address that is not one, another command, another
/// period, the simulated camera with a real robot, a port that is not one.
#[test]
fn a_franka_arm_is_taken_and_what_its_driver_cannot_honour_is_refused() {
    let scratch = Scratch::new("franka");
    let fr3 = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/arms/fr3.toml");
    let load = |extra: &str| {
        let path = scratch.0.join("franka.toml");
        std::fs::write(&path, format!("extends = {fr3:?}\n{extra}")).expect("written");
        Config::load(&path)
    };
    let robot = "[camera]\nsource = \"external\"\n[robot]\ndriver = \"franka\"\n";
    let config = load(&format!("{robot}[franka]\naddress = \"10.0.0.2\"\n")).expect("an FR3 over its FCI");
    let franka = config.franka.expect("the Franka driver's settings");
    assert_eq!(franka.address.to_string(), "10.0.0.2:1337");
    assert!(franka.limit_rate && !franka.simulator);
    assert_eq!(config.cell.robot.period_s, 0.001, "the FCI's period");
    assert!(config.cell.robot.start_held, "a real arm's cell starts held");
    let cases: [(String, &str); 6] = [
        ("[franka]\naddress = \"127.0.0.1\"\n".to_string(), "franka"),
        (format!("{robot}[franka]\naddress = \"robot.local\"\n"), "franka.address"),
        (format!("{robot}command = \"position\"\n"), "robot.command"),
        (format!("{robot}period_s = 0.002\n"), "robot.period_s"),
        (
            format!("{robot}[franka]\nsimulator = false\n")
                .replace("source = \"external\"", "source = \"simulated\""),
            "camera.source",
        ),
        (format!("{robot}[franka]\nport = 70000\n"), "franka.port"),
    ];
    for (extra, key) in &cases {
        let (found, message) = refusal(load(extra));
        assert_eq!(&found, key, "{extra}: {message}");
    }
    // franka-sim: the simulated camera may render the arm it reports
    load(
        &format!("{robot}[franka]\nsimulator = true\n")
            .replace("source = \"external\"", "source = \"simulated\""),
    )
    .expect("franka-sim with vservo's simulated camera");
}

/// A tool (or base) link the URDF does not have is the fault of the key that named it, in the file that wrote it
/// (an overlay of config/arms/ur5e.toml here, not the base that named the URDF), with the link nearest it.
#[test]
fn a_link_the_urdf_lacks_is_blamed_on_the_key_and_file_that_named_it() {
    let scratch = Scratch::new("tip-link");
    let ur5e = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/arms/ur5e.toml");
    let overlay = scratch.0.join("my-ur5e.toml");
    std::fs::write(
        &overlay,
        format!("extends = {:?}\n\n[robot.arm]\ntip_link = \"flang\"\n", ur5e.display()),
    )
    .expect("written");
    let error = Config::load(&overlay).expect_err("no link flang");
    assert_eq!(
        (error.file(), error.key()),
        (overlay.display().to_string().as_str(), Some("robot.arm.tip_link"))
    );
    let message = error.to_string();
    assert!(message.contains("\"flang\"") && message.contains("did you mean \"flange\"?"), "{message}");
    assert!(message.contains("ur5e.urdf has no such link"), "{message}");
}
