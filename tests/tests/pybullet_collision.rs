//! The collision guard in a physics engine (issue 47): the UR5e and the Panda of config/arms/, driven in PyBullet
//! (clients/python/pybullet_driver.py, the scene's obstacles and the camera's box as PyBullet bodies), servo towards
//! a target whose desired pose puts the camera 5 cm into a table. The arm slows and stops at least the stop distance
//! from the table (the UR5e's camera; the Panda's fingers, which reach past its camera, come first); PyBullet's own contact points stay empty all along, and its closest points
//! agree with vservo's distance within 2 mm; the status names the pair; after `resume` a move towards the table is
//! refused (stopped again) and a joint move away is taken.

use std::path::Path;
use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    Daemon, ScratchDir, TempConfig, clearance, exclusive, python_process, refused_towards_then_moved_away,
    repository_root, run, safe_stopped_by, status, unique, wait_until,
};

/// Agreement of PyBullet's closest points with vservo's distance, at rest (m).
const AGREEMENT_M: f64 = 0.002;

/// The collision log's lines (contacts, closest distance, link, obstacle), every 10 ms.
fn collision_log(path: &Path) -> Vec<Value> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines().filter_map(|line| serde_json::from_str(line).ok()).collect()
}

/// The arm file's cell driven in PyBullet, its camera starting 25 cm above the desired pose, and a 30 cm table
/// whose top is 5 cm above where the desired joints put the camera.
fn a_table_in_the_way(arm: &str, urdf: &Path, period_s: f64, nearest: &str) {
    let _one = exclusive();
    let instance = unique(&format!("pybullet-table-{arm}"));
    let root = repository_root();
    let file = root.join(format!("config/arms/{arm}.toml"));
    let base = vservo_config::Config::load(&file).expect("the arm file");
    let camera = base.cell.arm.base_from_tool(&base.cell.desired.joints) * base.cell.tool_from_camera;
    let [x, y, z] = [camera.translation.x, camera.translation.y, camera.translation.z];
    let stop_m = base.cell.collision.as_ref().expect("the arm file's guard").stop_distance_m;
    let config = TempConfig::written(&format!(
        "extends = \"{}\"\n[instance]\nname = \"{instance}\"\n[timing]\npipeline_delay_frames = 0\n[camera]\n\
         source = \"external\"\n[robot]\ndriver = \"external\"\ncommand = \"velocity\"\nperiod_s = {period_s}\n\
         start = \"servoing\"\nspeed_scale = 1.0\n[scenario]\ninitial_camera_translation_m = [0.0, 0.0, -0.25]\n\
         [[scene.obstacles]]\nname = \"table\"\nshape = \"box\"\nsize_m = [0.3, 0.3, 0.05]\n\
         translation_m = [{x}, {y}, {}]\n",
        file.display(),
        z + 0.05 - 0.025
    ));
    let dir = ScratchDir::new(&instance);
    let out = run("vservoctl", &["scene", "--config", &config.arg()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let scene = dir.write("scene.json", &String::from_utf8_lossy(&out.stdout));
    let log = dir.0.join("collision.jsonl");
    let daemon = Daemon::start(&config);
    let (scene_arg, urdf_arg, log_arg) =
        (scene.display().to_string(), urdf.display().to_string(), log.display().to_string());
    let _driver = python_process(
        "clients/python/pybullet_driver.py",
        &["--scene", &scene_arg, "--urdf", &urdf_arg, "--instance", &instance, "--collision-log", &log_arg],
        &dir.0.join("driver.log"),
    );
    assert!(
        wait_until(Duration::from_secs(60), || safe_stopped_by(&instance, "collision")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(800));
    let (stopped_m, between) = clearance(&instance).expect("the status's clearance");
    let lines = collision_log(&log);
    let last = lines.last().expect("PyBullet's collision log");
    let pybullet_m = last["closest_m"].as_f64().expect("a closest point");
    println!(
        "{arm}: stopped, vservo {between} {stopped_m:.4} m, PyBullet {}–{} {pybullet_m:.4} m",
        last["link"], last["obstacle"]
    );
    // what meets the table first: the UR5e's camera; the Panda's fingers, which reach past its camera
    assert_eq!(between, format!("{nearest} – table"), "{arm}");
    assert!(stopped_m >= stop_m, "{arm}: stopped {stopped_m} m from the table");
    let named =
        format!("{} – {}", last["link"].as_str().unwrap_or("?"), last["obstacle"].as_str().unwrap_or("?"));
    assert_eq!(named, between, "PyBullet's nearest pair is vservo's: {last}");
    assert!(
        (pybullet_m - stopped_m).abs() <= AGREEMENT_M,
        "{arm}: PyBullet {pybullet_m} m, vservo {stopped_m} m"
    );

    refused_towards_then_moved_away(&instance, &config, (&between, stopped_m), || daemon.log());
    let lines = collision_log(&log);
    let touching: Vec<&Value> = lines.iter().filter(|l| l["contacts"].as_u64() != Some(0)).collect();
    println!("{arm}: {} samples of PyBullet's contacts, {} with any", lines.len(), touching.len());
    assert!(lines.len() > 100, "{arm}: the log covers the run");
    assert!(touching.is_empty(), "{arm}: PyBullet saw contact: {:?}", touching.first());
    daemon.stop();
}

#[test]
fn pybullet_the_ur5e_stops_short_of_a_table_pybullet_never_touches() {
    a_table_in_the_way("ur5e", &repository_root().join("config/arms/ur5e.urdf"), 0.002, "camera");
}

#[test]
fn pybullet_the_panda_stops_short_of_a_table_pybullet_never_touches() {
    a_table_in_the_way(
        "panda",
        &repository_root().join("target/pybullet_data/franka_panda/panda.urdf"),
        0.001,
        "panda_rightfinger",
    );
}
