//! Where a recording lands (issue 37, the security review's planted files): `vservoctl record --out` into a
//! sticky folder open to all refuses another user's symbolic link or file open to all at the name, leaving it
//! and what it points to unchanged; one's own file is replaced only with `--force`, by a recording of its own,
//! mode 0600, never written into.

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::Path;

use vservo_system_tests::{binary, exclusive, nobody, running_daemon, unique};

/// `vservoctl record --out OUT` for a second (with `extra` arguments): its exit code and its stderr.
fn record(instance: &str, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    let recorded = std::process::Command::new(binary("vservoctl"))
        .args(["record", "--out", &out.display().to_string(), "--duration-s", "1", "--instance", instance])
        .args(extra)
        .output()
        .expect("vservoctl record runs");
    (recorded.status.code(), String::from_utf8_lossy(&recorded.stderr).to_string())
}

/// The recording at `out`: a file of its own (not a link), mode 0600, an MCAP file.
fn assert_a_recording_of_its_own(out: &Path) {
    let metadata = std::fs::symlink_metadata(out).expect("the recording");
    assert!(metadata.file_type().is_file(), "a regular file, not a link: {metadata:?}");
    assert_eq!(metadata.mode() & 0o777, 0o600);
    let bytes = std::fs::read(out).expect("readable");
    assert!(bytes.starts_with(b"\x89MCAP"), "an MCAP file");
}

#[test]
fn another_users_link_or_open_file_at_the_name_is_refused_and_ones_own_replaced_only_with_force() {
    let Some((uid, gid)) = nobody() else { return };
    let _one = exclusive();
    let instance = unique("record-files");
    let (_config, daemon) = running_daemon(&instance);
    let shared = std::env::temp_dir().join(format!("vservo-shared-{}", std::process::id()));
    std::fs::create_dir_all(&shared).expect("a shared folder");
    std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o1777)).expect("sticky, open to all");

    // nobody's link at the name, to a file of the recording user's
    let victim = shared.join("victim.txt");
    std::fs::write(&victim, b"precious").expect("the victim");
    let out = shared.join("linked.mcap");
    std::os::unix::fs::symlink(&victim, &out).expect("the planted link");
    std::os::unix::fs::lchown(&out, Some(uid), Some(gid)).expect("nobody's link");
    let (code, stderr) = record(&instance, &out, &["--force"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("is a symbolic link"), "{stderr}");
    assert_eq!(std::fs::read(&victim).expect("the victim"), b"precious", "nothing written through the link");
    assert!(std::fs::symlink_metadata(&out).expect("the link").file_type().is_symlink(), "the link stays");

    // nobody's file at the name, open to all
    let out = shared.join("open.mcap");
    std::fs::write(&out, b"planted").expect("the planted file");
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o666)).expect("open to all");
    std::os::unix::fs::chown(&out, Some(uid), Some(gid)).expect("nobody's file");
    let (code, stderr) = record(&instance, &out, &["--force"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("is user \"nobody\"'s file"), "{stderr}");
    assert_eq!(std::fs::read(&out).expect("the planted file"), b"planted", "not written into");

    // one's own file: refused without --force, replaced with it
    let own = shared.join("own.mcap");
    std::fs::write(&own, b"an older recording").expect("one's own file");
    let (code, stderr) = record(&instance, &own, &[]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("exists: --force replaces it"), "{stderr}");
    assert_eq!(std::fs::read(&own).expect("own"), b"an older recording");
    let (code, stderr) = record(&instance, &own, &["--force"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_a_recording_of_its_own(&own);

    // nothing left beside them
    let left: Vec<_> =
        std::fs::read_dir(&shared).expect("the folder").flatten().map(|e| e.file_name()).collect();
    assert_eq!(left.len(), 4, "{left:?}");
    let _ = std::fs::remove_dir_all(&shared);
    daemon.stop();
}
