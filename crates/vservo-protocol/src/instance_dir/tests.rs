//! Unit tests of `instance_dir`.

use super::shared_memory::{NODE_COUNTER_SUFFIX, shm_names};
use super::*;

fn scratch_base(name: &str) -> PathBuf {
    // short: iceoryx2's sockets go below it
    let base = std::env::temp_dir().join(format!("vsv-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    base
}

fn remove_shm(prefix: &str) {
    for name in shm_names(prefix) {
        let _ = std::fs::remove_file(Path::new(SHM_DIR).join(name));
    }
}

#[test]
fn a_claim_makes_private_directories_a_secret_prefix_and_an_owner_only_node_counter() {
    let base = scratch_base("claim");
    let instance = format!("unit-claim-{}", std::process::id());
    let claim = InstanceClaim::claim_in(&base, &instance).expect("claimed");
    let dir = claim.dir().clone();
    assert!(dir.prefix.starts_with("vservo_"), "{}", dir.prefix);
    let mode = |p: &Path| std::fs::symlink_metadata(p).expect("exists").mode() & 0o777;
    assert_eq!(mode(&base), 0o700);
    assert_eq!(mode(&dir.path), 0o750);
    assert_eq!(mode(&dir.iceoryx2_root()), 0o750);
    // a node of the instance uses the counter made owner-only, and makes nothing reachable by others
    let node = NodeBuilder::new()
        .config(&dir.iceoryx2_config().expect("config"))
        .create::<ipc::Service>()
        .expect("a node");
    let names = shm_names(&dir.prefix);
    assert_eq!(names.iter().filter(|n| n.ends_with(NODE_COUNTER_SUFFIX)).count(), 1, "{names:?}");
    for name in &names {
        assert_eq!(mode(&Path::new(SHM_DIR).join(name)) & 0o077, 0, "{name}");
    }
    claim.check_private().expect("private");
    // a second daemon is refused while the first holds the lock
    let second = InstanceClaim::claim_in(&base, &instance).expect_err("locked");
    assert!(matches!(second, InstanceDirError::AlreadyRunning { .. }), "{second}");
    drop(node);
    drop(claim);
    // the next run keeps the prefix (drivers still running find the instance again)
    let again = InstanceClaim::claim_in(&base, &instance).expect("claimed again");
    assert_eq!(again.dir().prefix, dir.prefix);
    assert!(again.renewed_because.is_none());
    remove_shm(&dir.prefix);
    let _ = std::fs::remove_dir_all(&base);
}

/// The daemon says which schema it speaks; a client of another finds out in one sentence naming both.
#[test]
fn an_instance_of_another_schema_is_refused_naming_both() {
    let base = scratch_base("schema");
    let instance = format!("unit-schema-{}", std::process::id());
    let claim = InstanceClaim::claim_in(&base, &instance).expect("claimed");
    let path = claim.dir().path.clone();
    let written = std::fs::read_to_string(path.join(SCHEMA_FILE)).expect("the schema file");
    assert_eq!(written.trim(), crate::SCHEMA_VERSION.to_string());
    InstanceDir::open_ours(&instance, &path).expect("the same schema is found");
    write_file_atomically(&path.join(SCHEMA_FILE), format!("{}\n", crate::SCHEMA_VERSION - 1).as_bytes())
        .expect("rewritten");
    let refused = InstanceDir::open_ours(&instance, &path).expect_err("another schema");
    let text = refused.to_string();
    assert!(
        text.contains(&format!("speaks protocol schema {}", crate::SCHEMA_VERSION - 1))
            && text.contains(&format!("this program schema {}", crate::SCHEMA_VERSION))
            && text.contains("Changelog"),
        "{text}"
    );
    let prefix = claim.dir().prefix.clone();
    drop(claim);
    remove_shm(&prefix);
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn a_prefix_under_which_a_file_is_exposed_is_replaced() {
    let base = scratch_base("exposed");
    let instance = format!("unit-exposed-{}", std::process::id());
    let first = InstanceClaim::claim_in(&base, &instance).expect("claimed").dir().clone();
    // as another user would: a name of the instance's prefix, open to all
    let planted = Path::new(SHM_DIR).join(format!("{}planted.dynamic", first.prefix));
    std::fs::write(&planted, b"garbage").expect("planted");
    std::fs::set_permissions(&planted, std::fs::Permissions::from_mode(0o666)).expect("mode");
    let second = InstanceClaim::claim_in(&base, &instance).expect("claimed with a new prefix");
    assert_ne!(second.dir().prefix, first.prefix);
    let reason = second.renewed_because.clone().expect("a reason");
    assert!(reason.contains("planted.dynamic") && reason.contains("666"), "{reason}");
    remove_shm(&first.prefix);
    remove_shm(&second.dir().prefix);
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn a_base_too_long_for_unix_sockets_is_refused() {
    let base = std::env::temp_dir().join("v".repeat(60));
    let refused = InstanceClaim::claim_in(&base, "long").expect_err("refused");
    assert!(refused.to_string().contains("too long"), "{refused}");
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn a_client_takes_its_own_users_instance_wherever_it_is() {
    let system_closed = Sighting::Closed { base: PathBuf::from(SYSTEM_RUNTIME_DIR), base_owner: Some(0) };
    let own = Sighting::Ours(PathBuf::from("/tmp/vservo-65534/x"));
    // the system's /run/vservo exists (root's, closed to this user) and the user's daemon runs in /tmp
    assert_eq!(Sighting::decide(&[system_closed.clone(), own.clone()]), Some(&own));
    // the user's own instance under /run/vservo (the system service's user) comes first
    let own_system = Sighting::Ours(PathBuf::from("/run/vservo/x"));
    assert_eq!(Sighting::decide(&[own_system.clone(), own.clone()]), Some(&own_system));
    assert_eq!(Sighting::decide(&[Sighting::Absent, own.clone()]), Some(&own));
}

#[test]
fn another_user_is_named_only_when_the_instance_is_none_of_ours() {
    let system_closed = Sighting::Closed { base: PathBuf::from(SYSTEM_RUNTIME_DIR), base_owner: Some(0) };
    assert_eq!(Sighting::decide(&[system_closed.clone(), Sighting::Absent]), Some(&system_closed));
    let others = Sighting::OtherUsers { owner_uid: 999, path: PathBuf::from("/run/vservo/x") };
    assert_eq!(Sighting::decide(&[others.clone(), Sighting::Absent]), Some(&others));
    // an instance seen to be another user's tells more than a closed base that may hold one
    assert_eq!(Sighting::decide(&[system_closed.clone(), others.clone()]), Some(&others));
    assert_eq!(Sighting::decide(&[Sighting::Absent, Sighting::Absent]), None);
    assert_eq!(Sighting::decide(&[]), None);
}

#[test]
fn a_closed_base_names_no_owner_for_the_instance() {
    let closed = |base_owner: Option<&str>| InstanceDirError::Closed {
        instance: "x".to_string(),
        base: PathBuf::from(SYSTEM_RUNTIME_DIR),
        base_owner: base_owner.map(str::to_string),
        looked_in: vec![PathBuf::from("/run/vservo/x"), PathBuf::from("/tmp/vservo-1000/x")],
    };
    for text in [closed(Some("root")).to_string(), closed(None).to_string()] {
        assert!(!text.contains("is run by user"), "{text}");
        assert!(text.contains("/run/vservo is closed to this user") && text.contains("/tmp/vservo-1000/x"));
    }
    assert!(closed(Some("root")).to_string().contains("the directory is user \"root\"'s"));
    assert!(closed(None).to_string().contains("whose it is cannot be told"));
}

#[test]
fn a_prefix_file_naming_other_files_is_refused() {
    let path = Path::new("/x/prefix");
    assert!(valid_prefix("vservo_0123456789abcdef_", path).is_ok());
    for bad in
        ["vservo_0123456789abcdeg_", "vservo_../../etc/passwd_", "", "vservo__", "iox2_0123456789abcdef_"]
    {
        assert!(valid_prefix(bad, path).is_err(), "{bad}");
    }
}
