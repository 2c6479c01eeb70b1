//! Where a recording lands: `vservoctl record --out` into a folder others may write (the security review's
//! planted files) writes a file of its own and moves it to the name, so that a symbolic link planted at the name
//! is replaced, never written through, and a file planted there open to all is replaced by the recording's own,
//! mode 0600.

use std::os::unix::fs::{MetadataExt, PermissionsExt};

use vservo_system_tests::{binary, exclusive, running_daemon, unique};

/// `vservoctl record --out OUT` for a second.
fn record(instance: &str, out: &std::path::Path) {
    let recorded = std::process::Command::new(binary("vservoctl"))
        .args(["record", "--out", &out.display().to_string(), "--duration-s", "1", "--instance", instance])
        .output()
        .expect("vservoctl record runs");
    assert!(recorded.status.success(), "{}", String::from_utf8_lossy(&recorded.stderr));
}

/// The recording at `out`: a file of its own (not a link), mode 0600, an MCAP file.
fn assert_a_recording_of_its_own(out: &std::path::Path) {
    let metadata = std::fs::symlink_metadata(out).expect("the recording");
    assert!(metadata.file_type().is_file(), "a regular file, not a link: {metadata:?}");
    assert_eq!(metadata.mode() & 0o777, 0o600);
    let bytes = std::fs::read(out).expect("readable");
    assert!(bytes.starts_with(b"\x89MCAP"), "an MCAP file");
}

#[test]
fn a_planted_link_or_open_file_at_the_name_is_replaced_never_written_through() {
    let _one = exclusive();
    let instance = unique("record-files");
    let (_config, daemon) = running_daemon(&instance);
    let shared = std::env::temp_dir().join(format!("vservo-shared-{}", std::process::id()));
    std::fs::create_dir_all(&shared).expect("a shared folder");
    std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o1777)).expect("sticky, open to all");

    // a link at the name, to a file of the recording user's
    let victim = shared.join("victim.txt");
    std::fs::write(&victim, b"precious").expect("the victim");
    let out = shared.join("linked.mcap");
    std::os::unix::fs::symlink(&victim, &out).expect("the planted link");
    record(&instance, &out);
    assert_eq!(std::fs::read(&victim).expect("the victim"), b"precious", "nothing written through the link");
    assert_a_recording_of_its_own(&out);

    // a file at the name, open to all
    let out = shared.join("open.mcap");
    std::fs::write(&out, b"planted").expect("the planted file");
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o666)).expect("open to all");
    record(&instance, &out);
    assert_a_recording_of_its_own(&out);
    // nothing left beside it
    let left: Vec<_> =
        std::fs::read_dir(&shared).expect("the folder").flatten().map(|e| e.file_name()).collect();
    assert_eq!(left.len(), 3, "{left:?}");
    let _ = std::fs::remove_dir_all(&shared);
    daemon.stop();
}
