//! The folders vservoctl writes into, and the files it writes there (issue 46, the planted links): `plot --out DIR`
//! and `calibrate`'s views folder refuse another user's folder, a link to a folder, and a link at a file's name,
//! naming it, and write nothing through them; `calibrate --apply` refuses a read-only configuration before any work.
//! The attacker's files are `nobody`'s, planted in a sticky folder open to all (the tests run as root to plant
//! them; as another user they are skipped, saying so).

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use vservo_system_tests::{binary, exclusive, nobody, repository_root, running_daemon, unique};

/// A sticky folder open to all, as /tmp is.
fn shared_folder(name: &str) -> PathBuf {
    let shared = std::env::temp_dir().join(format!("vservo-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&shared);
    std::fs::create_dir_all(&shared).expect("a shared folder");
    std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o1777)).expect("sticky, open to all");
    shared
}

/// The caller's private folder (0700) holding `victim.txt`, which must never change.
fn private_victim(shared: &Path) -> (PathBuf, PathBuf) {
    let private = shared.join("private");
    std::fs::create_dir(&private).expect("the caller's folder");
    std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o700)).expect("private");
    let victim = private.join("victim.txt");
    std::fs::write(&victim, b"precious").expect("the victim");
    (private, victim)
}

/// Runs vservoctl with `args`: its exit code and stderr.
fn vservoctl(args: &[&str]) -> (Option<i32>, String) {
    let out = std::process::Command::new(binary("vservoctl")).args(args).output().expect("vservoctl runs");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).to_string())
}

/// A link at `at` to `to`, `nobody`'s.
fn planted_link(to: &Path, at: &Path, (uid, gid): (u32, u32)) {
    std::os::unix::fs::symlink(to, at).expect("the planted link");
    std::os::unix::fs::lchown(at, Some(uid), Some(gid)).expect("nobody's link");
}

fn text(path: &Path) -> String {
    path.display().to_string()
}

#[test]
fn plot_refuses_another_users_folder_a_folder_link_and_a_link_at_a_figures_name() {
    let Some(nobody) = nobody() else { return };
    let _one = exclusive();
    let shared = shared_folder("plot-out");
    let (private, victim) = private_victim(&shared);
    let instance = unique("plot-out");
    let (config, daemon) = running_daemon(&instance);
    let recording = private.join("run.mcap");
    let (code, stderr) =
        vservoctl(&["record", "--out", &text(&recording), "--duration-s", "1", "--instance", &instance]);
    assert_eq!(code, Some(0), "{stderr}");
    daemon.stop();
    let plot =
        |out: &Path| vservoctl(&["plot", &text(&recording), "--out", &text(out), "--config", &config.arg()]);

    // nobody's folder open to all, with nobody's links at the four names plot writes, to the caller's files
    let theirs = shared.join("theirs");
    std::fs::create_dir(&theirs).expect("their folder");
    std::fs::set_permissions(&theirs, std::fs::Permissions::from_mode(0o777)).expect("open to all");
    std::os::unix::fs::chown(&theirs, Some(nobody.0), Some(nobody.1)).expect("nobody's folder");
    for name in ["trajectory.svg", "error.svg", "camera_position.svg", "frames.svg"] {
        planted_link(&victim, &theirs.join(name), nobody);
    }
    let (code, stderr) = plot(&theirs);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("is user \"nobody\"'s folder"), "{stderr}");

    // a link to the caller's private folder
    let linked = shared.join("linked-folder");
    planted_link(&private, &linked, nobody);
    let (code, stderr) = plot(&linked);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("linked-folder is a symbolic link"), "{stderr}");

    // the caller's own folder, with a link at one figure's name
    let own = private.join("plots");
    std::fs::create_dir(&own).expect("the caller's folder");
    planted_link(&victim, &own.join("error.svg"), nobody);
    let (code, stderr) = plot(&own);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("error.svg is a symbolic link"), "{stderr}");

    assert_eq!(std::fs::read(&victim).expect("the victim"), b"precious", "nothing written through a link");
    let in_private: Vec<_> =
        std::fs::read_dir(&private).expect("read").flatten().map(|e| e.file_name()).collect();
    assert_eq!(in_private.len(), 3, "victim, recording and the plots folder only: {in_private:?}");
    // and the premise: into a folder of its own, plot writes
    let fresh = private.join("fresh");
    let (code, stderr) = plot(&fresh);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(fresh.join("trajectory.svg").is_file());
    let _ = std::fs::remove_dir_all(&shared);
}

#[test]
fn calibrate_refuses_a_planted_views_folder_and_apply_a_read_only_configuration_before_any_work() {
    let Some(nobody) = nobody() else { return };
    let shared = shared_folder("calibrate-out");
    let (private, victim) = private_victim(&shared);
    let demo = text(&repository_root().join("config/calibration-demo.toml"));
    let calibrate = |extra: &[&str]| {
        let mut args = vec!["calibrate", "--config", &demo, "--lockstep", "--json"];
        args.extend_from_slice(extra);
        vservoctl(&args)
    };

    // the default views folder beside the output, a link nobody planted to the caller's private folder
    let out = shared.join("calibration.toml");
    planted_link(&private, &shared.join("calibration-views"), nobody);
    let (code, stderr) = calibrate(&["--out", &text(&out)]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("calibration-views is a symbolic link"), "{stderr}");
    // --views naming nobody's folder
    let theirs = shared.join("their-views");
    std::fs::create_dir(&theirs).expect("their folder");
    std::os::unix::fs::chown(&theirs, Some(nobody.0), Some(nobody.1)).expect("nobody's folder");
    let (code, stderr) = calibrate(&["--out", &text(&out), "--views", &text(&theirs)]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("is user \"nobody\"'s folder"), "{stderr}");
    assert!(!out.exists(), "nothing calibrated");
    let in_private: Vec<_> =
        std::fs::read_dir(&private).expect("read").flatten().map(|e| e.file_name()).collect();
    assert_eq!(in_private.len(), 1, "no view or dataset written through the link: {in_private:?}");
    assert_eq!(std::fs::read(&victim).expect("the victim"), b"precious");

    // --apply on a configuration kept read-only (0444): refused before any work, even as root
    let config = private.join("cell.toml");
    let base = text(&repository_root().join("config/calibration-demo.toml"));
    std::fs::write(&config, format!("extends = {base:?}\n")).expect("a configuration");
    std::fs::set_permissions(&config, std::fs::Permissions::from_mode(0o444)).expect("read-only");
    let out = private.join("calibration.toml");
    let views = private.join("views");
    let (code, stderr) = vservoctl(&[
        "calibrate",
        "--config",
        &text(&config),
        "--lockstep",
        "--apply",
        "--out",
        &text(&out),
        "--views",
        &text(&views),
    ]);
    assert_eq!(code, Some(2), "a refusal: {stderr}");
    assert!(stderr.contains("is read-only (mode 0444)") && stderr.contains("nothing was moved"), "{stderr}");
    assert!(!out.exists() && !views.exists(), "refused before any work");
    assert_eq!(std::fs::read_to_string(&config).expect("read"), format!("extends = {base:?}\n"));
    let _ = std::fs::remove_dir_all(&shared);
}
