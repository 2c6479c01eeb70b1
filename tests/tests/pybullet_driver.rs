//! The driver contract (docs/DRIVERS.md) proved a second time, with another simulator and an arm vservo models
//! from a URDF: PyBullet's physics and TinyRenderer behind clients/python/pybullet_driver.py, pybullet_data's
//! xArm6 (six joints) and Panda (seven), vservod on config/arms/xarm6.toml and panda.toml (robot.driver =
//! "external", camera.source = "external").

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use vservo_system_tests::{exclusive, repository_root, run_script_to_convergence, wait_until};

/// pybullet_data's directory (the URDFs and meshes that come with PyBullet), as the venv's Python says.
fn pybullet_data() -> PathBuf {
    let python = repository_root().join("target/python-venv/bin/python");
    assert!(python.exists(), "{}: scripts/setup.sh makes it", python.display());
    let out = Command::new(&python)
        .args(["-c", "import pybullet_data; print(pybullet_data.getDataPath())"])
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "pybullet_data (scripts/setup.sh installs pybullet): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
}

/// The pids of the driver's camera processes (named `pybullet-camera`) on this machine.
fn camera_processes() -> Vec<u32> {
    let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
    entries
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            std::fs::read_to_string(format!("/proc/{pid}/comm")).is_ok_and(|c| c.trim() == "pybullet-camera")
        })
        .collect()
}

/// `scripts/run-pybullet.sh --json` on the xArm6, the Panda, the iiwa and a UR5e, the README's way to try it; nothing of
/// the driver outlives the run (its camera process ends with it).
#[test]
fn run_pybullet_with_the_xarm6_the_panda_the_iiwa_and_a_ur5e_converges_below_one_pixel() {
    let _one = exclusive();
    let urdf = pybullet_data().join("xarm/xarm6_robot.urdf");
    assert!(urdf.exists(), "{}", urdf.display());
    let urdf = urdf.display().to_string();
    // each arm at its own rate, as its configuration gives it (timing.control_period_s): the xArm at 250 Hz
    run_script_to_convergence("run-pybullet.sh", &["--urdf", &urdf, "--config", "config/arms/xarm6.toml"]);
    let overlay = std::fs::read_to_string(repository_root().join("target/pybullet-run/pybullet.toml"))
        .expect("the run's overlay");
    assert!(overlay.contains("period_s = 0.004"), "{overlay}");
    // seven joints: the Panda at its own rate, 1 kHz
    let panda = pybullet_data().join("franka_panda/panda.urdf").display().to_string();
    run_script_to_convergence("run-pybullet.sh", &["--urdf", &panda, "--config", "config/arms/panda.toml"]);
    // a second seven-joint arm with a configuration file only: the KUKA LBR iiwa of pybullet_data
    let iiwa = pybullet_data().join("kuka_iiwa/model.urdf").display().to_string();
    run_script_to_convergence("run-pybullet.sh", &["--urdf", &iiwa, "--config", "config/arms/iiwa.toml"]);
    // another arm with nothing but its files: a UR5e (its URDF written from its DH parameters) at 500 Hz
    run_script_to_convergence(
        "run-pybullet.sh",
        &["--urdf", "config/arms/ur5e.urdf", "--config", "config/arms/ur5e.toml"],
    );
    assert!(
        wait_until(Duration::from_secs(3), || camera_processes().is_empty()),
        "camera processes left behind: {:?}",
        camera_processes()
    );
}
