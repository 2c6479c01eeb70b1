//! What users do with a running instance (issue 7): retune by reloading, send targets, move the object —
//! against real processes over iceoryx2, driven through `vservoctl` as a user would. One test at a time.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use nix::sys::signal::Signal;
use serde_json::Value;
use vservo_system_tests::{
    Daemon, binary, config_with, exclusive, keep_pace, numbers, run, running, status, unique, wait_until,
};

fn up(instance: &str) -> bool {
    status(instance).is_some_and(|s| running(&s))
}

fn gains_version(instance: &str) -> Option<u64> {
    status(instance).and_then(|s| s["gains_version"].as_u64())
}

/// Starts `vservoctl echo TOPIC` for the instance; its lines are read when the returned child is finished.
fn echo(instance: &str, topic: &str, seconds: f64) -> Child {
    Command::new(binary("vservoctl"))
        .args(["echo", topic, "--instance", instance, "--duration-s", &seconds.to_string()])
        .stdout(Stdio::piped())
        .spawn()
        .expect("echo starts")
}

fn lines(child: Child) -> Vec<Value> {
    let stdout = child.stdout.expect("piped");
    BufReader::new(stdout).lines().map(|l| serde_json::from_str(&l.expect("line")).expect("JSON")).collect()
}

/// −K(ξ − ξ_d) for the paper's law of a configuration.
fn paper_twist(config: &vservo_config::Config, features: &[f64]) -> [f64; 6] {
    let gains = vservo_control::Gains::design(&config.cell.gains_spec()).expect("design");
    let error = vservo_scene::FeatureVector::from_column_slice(features) - gains.desired_features;
    let twist = -(gains.feature_gain * error);
    std::array::from_fn(|i| twist[i])
}

#[test]
fn reloads_swap_the_gain_and_the_law_options_at_a_frame_and_bad_files_change_nothing() {
    let _one = exclusive();
    let instance = unique("reload");
    let config = config_with("name = \"default\"", &format!("name = \"{instance}\""));
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || up(&instance)), "{}", daemon.log());
    let before = vservo_config::Config::load(&config.path).expect("config");
    let features = echo(&instance, "features", 3.0);
    let twists = echo(&instance, "camera_twist", 3.0);
    std::thread::sleep(Duration::from_millis(1200));
    let text = std::fs::read_to_string(&config.path).expect("read");
    std::fs::write(
        &config.path,
        text.replace("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", "r = [4.0, 4.0, 4.0, 24.0, 24.0, 24.0]"),
    )
    .expect("write");
    let after = vservo_config::Config::load(&config.path).expect("config");
    daemon.signal(Signal::SIGHUP);
    assert!(wait_until(Duration::from_secs(5), || gains_version(&instance) == Some(2)), "{}", daemon.log());
    let features: Vec<Value> = lines(features);
    let twists: Vec<Value> = lines(twists);
    // every twist is exactly −K(ξ − ξ_d) of the version it names, for the features of its frame: the swap
    // changes the gain between two frames and nothing else
    let (mut old, mut new) = (0, 0);
    for twist in &twists {
        let frame = twist["frame"].as_u64();
        let Some(seen) = features.iter().find(|f| f["frame"].as_u64() == frame) else { continue };
        let xi = numbers(&seen["features_px"]);
        let config = match twist["gains_version"].as_u64() {
            Some(1) => {
                old += 1;
                &before
            }
            Some(2) => {
                new += 1;
                &after
            }
            other => panic!("unexpected gains version {other:?}"),
        };
        let expected = paper_twist(config, &xi);
        let got = numbers(&twist["twist"]);
        for i in 0..6 {
            assert!(
                (got[i] - expected[i]).abs() <= 1e-12 + 1e-9 * expected[i].abs(),
                "{twist}\nexpected {expected:?}"
            );
        }
    }
    assert!(old >= 5 && new >= 5, "frames before ({old}) and after ({new}) the reload");
    assert!(daemon.log().contains("RELOADING") || daemon.log().contains("reloaded"), "{}", daemon.log());

    // a broken file is refused with its error; the gains stay and the loop runs on
    std::fs::write(&config.path, "[controller\nthis is not TOML").expect("write");
    let out = run("vservoctl", &["reload", "--instance", &instance]);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("refused") && stderr.contains("version 2) stay"), "{stderr}");
    // a restart-only key is refused by name
    std::fs::write(&config.path, text.replace("mode = \"dynamic\"", "mode = \"kinematic\"")).expect("write");
    let out = run("vservoctl", &["reload", "--instance", &instance]);
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("plant.mode") && stderr.contains("restart vservod"), "{stderr}");
    assert_eq!(gains_version(&instance), Some(2));
    assert!(up(&instance));

    // the law's options are live keys: a reload takes them to the servo sealed with the gains, and a bad one
    // is refused by name with the running gains kept
    let robust = text
        .replace("interaction = \"desired\"", "interaction = \"mean\"")
        .replace("border_margin_px = 0.0", "border_margin_px = 20.0")
        .replace("feedforward = false", "feedforward = true");
    assert_ne!(robust, text, "the default file names the options");
    std::fs::write(&config.path, robust.replace("border_margin_px = 20.0", "border_margin_px = -1.0"))
        .expect("write");
    let out = run("vservoctl", &["reload", "--instance", &instance]);
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("border_margin_px") && stderr.contains("version 2) stay"), "{stderr}");
    std::fs::write(&config.path, &robust).expect("write");
    let out = run("vservoctl", &["reload", "--instance", &instance]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("controller.interaction") && stdout.contains("gains version 3"), "{stdout}");
    let gains = lines(echo(&instance, "gains", 0.5));
    let latest = gains.last().expect("gains history");
    assert_eq!(latest["version"], 3, "{latest}");
    assert_eq!(latest["interaction"], vservo_protocol::Interaction::Mean.code(), "{latest}");
    assert_eq!(latest["border_margin_px"], 20.0, "{latest}");
    assert_eq!(latest["feedforward"], 1, "{latest}");
    // a target inside the barrier's margin (mark 4 at 15 px from the top) is refused by name
    let out = run(
        "vservoctl",
        &["target", "set", "--features", "151,168,318,178,339,75,172,15", "--instance", &instance],
    );
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("controller.border_margin_px"), "{stderr}");
    // the servo runs them: its twists name version 3, and the loop stays on ξ_d
    let twists = lines(echo(&instance, "camera_twist", 0.5));
    assert!(!twists.is_empty() && twists.iter().all(|t| t["gains_version"] == 3), "{twists:?}");
    assert!(
        wait_until(Duration::from_secs(5), || status(&instance)
            .is_some_and(|s| running(&s) && s["feature_error_px"].as_f64().is_some_and(|e| e < 1.0))),
        "{}",
        daemon.log()
    );
    daemon.stop();
}

#[test]
fn targets_move_the_servo_target_and_bad_ones_are_refused_while_the_loop_runs() {
    let _one = exclusive();
    let instance = unique("target");
    let config = config_with("name = \"default\"", &format!("name = \"{instance}\""));
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || up(&instance)), "{}", daemon.log());
    let target = [161.0, 168.0, 328.0, 178.0, 349.0, 75.0, 182.0, 70.0];
    let list = target.map(|v| v.to_string()).join(",");
    let out = run("vservoctl", &["target", "set", "--features", &list, "--instance", &instance]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("gains version 2"));
    // the servo runs the new target: its gains carry it, and the features settle on it
    let gains = lines(echo(&instance, "gains", 0.5));
    assert_eq!(numbers(&gains.last().expect("gains history")["desired_features_px"]), target.to_vec());
    assert!(
        wait_until(Duration::from_secs(25), || status(&instance).is_some_and(
            |s| s["gains_version"] == 2 && s["feature_error_px"].as_f64().is_some_and(|e| e < 1.0)
        )),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    for (features, why) in [
        ("nan,168,318,178,339,75,172,70", "not finite"),
        ("151,168,318,178,339,75,172,600", "outside the image"),
        ("151,168,318,178,339,75,210,70", "no image of the board"),
    ] {
        let out = run("vservoctl", &["target", "set", "--features", features, "--instance", &instance]);
        assert_eq!(out.status.code(), Some(3), "{features}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(why),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let out = run("vservoctl", &["target", "pose", "--translation-m", "0,0,3", "--instance", &instance]);
    assert_eq!(out.status.code(), Some(3), "a board 3 m away: marks too close together");
    let after = status(&instance).expect("status");
    assert_eq!(after["gains_version"], 2, "refused targets change nothing");
    if let Err(last) = keep_pace(&[&instance], Duration::from_secs(10)) {
        panic!("the loop lost its pace after refused targets: {last:?}\n{}", daemon.log());
    }
    // teach takes what the camera sees; an object step moves the board and the loop follows
    let out = run("vservoctl", &["target", "teach", "--instance", &instance]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = run("vservoctl", &["object", "step", "--by-m", "0,0.02,0", "--instance", &instance]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = run("vservoctl", &["object", "step", "--by-m", "0,1,0", "--instance", &instance]);
    assert_eq!(out.status.code(), Some(3));
    daemon.stop();
}

#[test]
fn a_recording_holds_every_service_in_order_and_plots() {
    let _one = exclusive();
    let instance = unique("record");
    // with a table in the scene (the built-in PUMA has no collision shapes: the guard never acts)
    let config = vservo_system_tests::config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            (
                "[ros2]\n",
                "[collision]\n\n[[scene.obstacles]]\nname = \"table\"\nshape = \"box\"\nsize_m = [0.6, 0.6, 0.04]\n\
                 translation_m = [0.8, 0.0, 0.2]\n\n[ros2]\n",
            ),
        ],
    );
    let file = config.path.with_extension("mcap");
    // the recorder starts first, so it hears everything from the first message on (and reads the cell, the
    // arm and its scene, from the file the daemon will run)
    let recorder = Command::new(binary("vservoctl"))
        .args([
            "record",
            "--out",
            &file.display().to_string(),
            "--duration-s",
            "6",
            "--config",
            &config.arg(),
        ])
        .stderr(Stdio::piped())
        .spawn()
        .expect("vservoctl record starts");
    std::thread::sleep(Duration::from_millis(300));
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || up(&instance)), "{}", daemon.log());
    let out = run("vservoctl", &["object", "step", "--by-m", "0,0.01,0", "--instance", &instance]);
    assert!(out.status.success());
    // the simulated camera publishes what the extractor saw on camera_image: frames in order, the paper's
    // camera size, a board-and-marks image (neither black nor white)
    let images = lines(echo(&instance, "camera_image", 0.5));
    assert!(images.len() >= 3, "{images:?}");
    for pair in images.windows(2) {
        assert_eq!(pair[1]["frame"].as_u64(), pair[0]["frame"].as_u64().map(|f| f + 1), "{images:?}");
    }
    for image in &images {
        assert_eq!((image["width"].as_u64(), image["height"].as_u64()), (Some(512), Some(512)), "{image}");
        assert_eq!(image["bytes"], 512 * 512);
        assert_eq!(image["schema"], vservo_protocol::SCHEMA_VERSION);
        let mean = image["mean_gray"].as_f64().expect("a mean");
        assert!((60.0..230.0).contains(&mean), "{image}");
    }
    let recorded = recorder.wait_with_output().expect("the recorder ends");
    assert!(recorded.status.success(), "{}", String::from_utf8_lossy(&recorded.stderr));
    daemon.stop();

    let bytes = std::fs::read(&file).expect("the recording");
    // created for the daemon's user only
    let mode = std::os::unix::fs::PermissionsExt::mode(
        &std::fs::metadata(&file).expect("the recording").permissions(),
    );
    assert_eq!(mode & 0o777, 0o600, "the recording's mode is {:o}", mode & 0o777);
    let mut per_topic: std::collections::BTreeMap<String, Vec<(u32, Value)>> = Default::default();
    for message in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let message = message.expect("a message");
        // Foxglove's views (protobuf) are checked below, with Python's mcap package
        if message.channel.message_encoding != "json" {
            continue;
        }
        let data: Value = serde_json::from_slice(&message.data).expect("JSON");
        per_topic.entry(message.channel.topic.clone()).or_default().push((message.sequence, data));
    }
    for topic in [
        "joint_state",
        "joint_command",
        "sim_world",
        "features",
        "camera_twist",
        "telemetry",
        "status",
        "gains",
        "object",
    ] {
        let name = format!("vservo/{instance}/{topic}");
        let messages = per_topic.get(&name).unwrap_or_else(|| panic!("no {name} in {:?}", per_topic.keys()));
        assert!(messages.windows(2).all(|w| w[1].0 == w[0].0 + 1), "{topic}: sequence numbers in order");
    }
    let ticks: Vec<u64> = per_topic[&format!("vservo/{instance}/joint_state")]
        .iter()
        .filter_map(|(_, m)| m["tick"].as_u64())
        .collect();
    assert!(ticks.windows(2).all(|w| w[1] > w[0]), "joint states in tick order");
    let missing = (ticks[ticks.len() - 1] - ticks[0] + 1) as usize - ticks.len();
    eprintln!("joint states recorded: {} of {} ticks", ticks.len(), ticks.len() + missing);
    assert!(missing * 100 <= ticks.len(), "{missing} of {} joint states missing", ticks.len());
    let frames: Vec<u64> = per_topic[&format!("vservo/{instance}/features")]
        .iter()
        .filter_map(|(_, m)| m["frame"].as_u64())
        .collect();
    assert!(frames.windows(2).all(|w| w[1] == w[0] + 1), "every frame, in order: {frames:?}");

    // as pictures: read back with the `mcap` package from PyPI, compressed, with images, annotations
    // exactly at the servo's features and the arm's, camera's and board's frames under Foxglove's schemas
    let python = vservo_system_tests::repository_root().join("target/python-venv/bin/python");
    let checked = Command::new(&python)
        .arg(vservo_system_tests::repository_root().join("tests/python/check_recording.py"))
        .arg(&file)
        .arg(&instance)
        .output()
        .expect("python runs");
    assert!(checked.status.success(), "{}", String::from_utf8_lossy(&checked.stderr));
    let figures: Value = serde_json::from_slice(&checked.stdout).expect("JSON figures");
    eprintln!("recording: {} bytes over 6 s; {figures}", bytes.len());
    assert!(figures["images"].as_u64() >= Some(40), "{figures}");
    assert!(figures["annotated_frames"].as_u64() >= Some(40), "{figures}");
    assert!(figures["images_with_annotations"].as_u64() >= Some(40), "{figures}");
    // the table under Foxglove's scene schema, as configured, named, in the base frame
    let table = &figures["obstacles"]["obstacle/table"];
    assert_eq!(table["frame_id"], "base", "{figures}");
    assert_eq!(table["cube_sizes"], serde_json::json!([[0.6, 0.6, 0.04]]), "{figures}");
    assert_eq!(table["cube_centres"], serde_json::json!([[0.8, 0.0, 0.2]]), "{figures}");
    assert_eq!(table["texts"], serde_json::json!(["table"]), "{figures}");

    let out_dir = config.path.with_extension("plots");
    let out = run(
        "vservoctl",
        &[
            "plot",
            &file.display().to_string(),
            "--out",
            &out_dir.display().to_string(),
            "--config",
            &config.arg(),
            "--frames",
            "6",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for figure in ["trajectory.svg", "error.svg"] {
        let svg = std::fs::read_to_string(out_dir.join(figure)).expect("a figure");
        assert!(svg.contains("<svg") && svg.contains("polyline"), "{figure}");
    }
    // the contact sheet: six recorded images, each with the marks crossed where the recording's features put
    // them (scaled to the sheet)
    let recorded_features: std::collections::BTreeMap<u64, Vec<f64>> = per_topic
        [&format!("vservo/{instance}/features")]
        .iter()
        .filter_map(|(_, m)| Some((m["frame"].as_u64()?, vservo_system_tests::numbers(&m["features_px"]))))
        .collect();
    let sheet = std::fs::read_to_string(out_dir.join("frames.svg")).expect("frames.svg");
    let pictures: Vec<&str> = sheet
        .split("href=\"data:image/png;base64,")
        .skip(1)
        .filter_map(|rest| rest.split('"').next())
        .collect();
    let drawn: Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("frames.json")).expect("frames.json"))
            .expect("JSON");
    let cells = drawn["frames"].as_array().expect("frames");
    assert_eq!((pictures.len(), cells.len()), (6, 6), "{drawn}");
    for (picture, cell) in pictures.iter().zip(cells) {
        use base64::Engine as _;
        let png = base64::engine::general_purpose::STANDARD.decode(picture).expect("base64");
        let picture = image::load_from_memory(&png).expect("a PNG").to_rgb8();
        let frame = cell["frame"].as_u64().expect("a frame");
        let scale = cell["scale"].as_f64().expect("a scale");
        assert!(sheet.contains(&format!(">frame {frame} ·")), "the caption names frame {frame}");
        let xi = &recorded_features[&frame];
        for mark in 0..4 {
            let (u, v) = ((xi[2 * mark] * scale).floor() as u32, (xi[2 * mark + 1] * scale).floor() as u32);
            assert_eq!(
                picture.get_pixel(u, v).0,
                [0, 220, 0],
                "frame {frame}, mark {mark}: no cross at ({u}, {v})"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&out_dir);
    let _ = std::fs::remove_file(&file);
}

/// A port of this test run's own for the live view (tests of several checkouts may run at once).
fn view_port(offset: u32) -> u16 {
    (20_000 + (std::process::id() * 3 + offset) % 20_000) as u16
}

/// A daemon of `instance` with the live view on `port`, once its viewer has started.
fn daemon_with_viewer(instance: &str, port: u16) -> (vservo_system_tests::TempConfig, Daemon) {
    let config = vservo_system_tests::config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("enabled = false\nmax_clients", "enabled = true\nmax_clients"),
            ("port = 8765", &format!("port = {port}")),
        ],
    );
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || up(instance)), "{}", daemon.log());
    assert!(
        wait_until(Duration::from_secs(10), || daemon.log().contains("the Foxglove viewer started")),
        "{}",
        daemon.log()
    );
    (config, daemon)
}

/// `vservoctl view --url` of the instance, once its viewer has written it.
fn view_url(instance: &str) -> String {
    let mut url = String::new();
    let written = wait_until(Duration::from_secs(10), || {
        let out = run("vservoctl", &["view", "--url", "--instance", instance]);
        url = String::from_utf8_lossy(&out.stdout).trim().to_string();
        out.status.success()
    });
    assert!(written, "no URL: {url}");
    url
}

/// What tests/python/view_probe.py (standard library only, fed on stdin) gets from the live view on `port`
/// at `path`, run as `user` (None: this process's user); `how` is `SECONDS` or `--connections N`.
fn view_probe(user: Option<&str>, port: u16, path: &str, how: &[&str]) -> Value {
    let script = vservo_system_tests::repository_root().join("tests/python/view_probe.py");
    let mut command = match user {
        Some(user) => {
            let mut command = Command::new("runuser");
            command.args(["-u", user, "--", "python3"]);
            command
        }
        None => Command::new("python3"),
    };
    let out = command
        .args(["-", "127.0.0.1", &port.to_string(), path])
        .args(how)
        .stdin(std::fs::File::open(script).expect("the probe"))
        .current_dir("/")
        .output()
        .expect("python3 runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON figures")
}

/// Nothing of the view came: no upgrade, no serverInfo, no channel, no data byte.
fn nothing_of_the_view(figures: &Value) -> bool {
    figures["status"] != 101
        && figures["server_info"] == false
        && figures["channels"] == 0
        && figures["data_bytes"] == 0
}

/// `[viewer] enabled = true`: vservod serves the cell to Foxglove; a client of the public WebSocket protocol
/// (Python, `websockets` from PyPI), given the URL with the view's token by `vservoctl view --url`, sees the
/// channels with Foxglove's schema names, images, annotations whose marks are exactly the features the servo
/// used in that frame, joint states and the daemon's status.
#[test]
fn the_live_view_serves_foxglove_the_image_and_the_marks_the_servo_used() {
    let _one = exclusive();
    let instance = unique("view");
    let port = view_port(0);
    let (_config, daemon) = daemon_with_viewer(&instance, port);
    let url = view_url(&instance);
    assert!(url.starts_with(&format!("ws://127.0.0.1:{port}/?token=")), "{url}");
    assert!(
        !daemon.log().contains(&url[url.find("token=").expect("a token") + 6..]),
        "the token is not logged"
    );
    let python = vservo_system_tests::repository_root().join("target/python-venv/bin/python");
    let client = vservo_system_tests::repository_root().join("tests/python/foxglove_client.py");
    // the client waits up to 10 s for the server to listen
    let out = Command::new(&python).arg(&client).args([&url, &instance, "4"]).output().expect("python runs");
    assert!(out.status.success(), "{}\n{}", String::from_utf8_lossy(&out.stderr), daemon.log());
    let figures: Value = serde_json::from_slice(&out.stdout).expect("JSON figures");
    eprintln!("live view, 4 s: {figures}");
    assert!(figures["images"].as_u64() >= Some(20), "{figures}");
    assert!(figures["annotated_frames_checked"].as_u64() >= Some(20), "{figures}");
    assert!(figures["images_with_annotations"].as_u64() >= Some(20), "{figures}");
    assert!(figures["joint_states"].as_u64() >= Some(100), "{figures}");
    assert!(figures["statuses"].as_u64() >= Some(1), "{figures}");
    assert!(up(&instance), "the cell still runs");
    daemon.stop();
}

/// The live view serves the daemon's user with the token only: without it, or with a wrong one, an HTTP
/// error and nothing else (counted in bytes); with it, data. One viewer more than `[viewer] max_clients`
/// (4) is refused. The URL file is the daemon's user's only, and goes with the viewer.
#[test]
fn the_live_view_gives_nothing_without_its_token_and_serves_at_most_max_clients() {
    use std::os::unix::fs::PermissionsExt;
    let _one = exclusive();
    let instance = unique("view-token");
    let port = view_port(1);
    let (_config, daemon) = daemon_with_viewer(&instance, port);
    let url = view_url(&instance);
    let path = &url[url.find("/?").expect("a query")..];
    let url_file =
        vservo_protocol::InstanceDir::locate(&instance).expect("the instance").path.join("viewer-url");
    let mode = std::fs::metadata(&url_file).expect("the URL file").permissions().mode() & 0o777;
    assert_eq!(mode, 0o600, "mode {mode:o}");

    let no_token = view_probe(None, port, "/", &["2"]);
    let guessed = view_probe(None, port, &format!("/?token={}", "0".repeat(32)), &["2"]);
    let with_token = view_probe(None, port, path, &["2"]);
    eprintln!("the daemon's user: no token {no_token}; a guessed token {guessed}; the token {with_token}");
    assert!(nothing_of_the_view(&no_token) && no_token["status"] == 401, "{no_token}");
    assert!(nothing_of_the_view(&guessed) && guessed["status"] == 403, "{guessed}");
    assert_eq!(with_token["status"], 101, "{with_token}");
    assert!(with_token["server_info"] == true && with_token["channels"].as_u64() >= Some(10), "{with_token}");
    assert!(with_token["data_bytes"].as_u64() >= Some(100_000), "{with_token}");

    let held = view_probe(None, port, path, &["--connections", "5"]);
    eprintln!("5 viewers at once, at most 4: {held}");
    assert_eq!(held["statuses"], serde_json::json!([101, 101, 101, 101, 503]), "{held}");

    daemon.stop();
    assert!(!url_file.exists(), "the URL file goes with the viewer");
}

/// As another local user (`nobody`), the live view gives nothing, with or without a guessed token, and
/// `vservoctl view --url` does not give that user the token.
#[test]
fn another_user_gets_nothing_of_the_live_view() {
    use std::os::unix::fs::MetadataExt;
    if std::fs::metadata("/proc/self").map(|m| m.uid()).ok() != Some(0) {
        println!("skipped: needs root to run a client as nobody");
        return;
    }
    let _one = exclusive();
    let instance = unique("view-other");
    let port = view_port(2);
    let (_config, daemon) = daemon_with_viewer(&instance, port);
    let url = view_url(&instance);
    let path = &url[url.find("/?").expect("a query")..];

    let no_token = view_probe(Some("nobody"), port, "/", &["2"]);
    let guessed = view_probe(Some("nobody"), port, &format!("/?token={}", "f".repeat(32)), &["2"]);
    eprintln!("nobody: no token {no_token}; a guessed token {guessed}");
    assert!(nothing_of_the_view(&no_token) && no_token["status"] == 401, "{no_token}");
    assert!(nothing_of_the_view(&guessed) && guessed["status"] == 403, "{guessed}");
    let out = Command::new("runuser")
        .args(["-u", "nobody", "--"])
        .arg(binary("vservoctl"))
        .args(["view", "--url", "--instance", &instance])
        .current_dir("/")
        .output()
        .expect("runuser runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("vservoctl view --url as nobody: {}", String::from_utf8_lossy(&out.stderr).trim());
    assert!(!out.status.success() && !stdout.contains("token="), "{stdout}");
    // the same probe, as the daemon's user with the token, does get the view (the probe can see data)
    let with_token = view_probe(None, port, path, &["2"]);
    eprintln!("the daemon's user with the token: {with_token}");
    assert!(with_token["data_bytes"].as_u64() >= Some(100_000), "{with_token}");
    daemon.stop();
}
