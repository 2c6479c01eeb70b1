//! The instance's objects in /dev/shm: finding them by prefix, refusing one another user owns or could open,
//! making iceoryx2's node counter owner-only before iceoryx2 would, and removing ours of a prefix given up.

use super::*;

/// Where POSIX shared memory lives on Linux.
pub(super) const SHM_DIR: &str = "/dev/shm";
/// The suffix iceoryx2 gives its node counter segment.
pub(super) const NODE_COUNTER_SUFFIX: &str = ".global_mgmt";

/// Removes what is ours of a prefix given up: iceoryx2's registrations of its dead nodes, and our own
/// shared-memory objects under it (another user's stay where they are, unused).
pub(super) fn forget_prefix(dir: &InstanceDir) {
    if let Ok(config) = dir.iceoryx2_config()
        && let Ok(node) = NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
    {
        let _ = node.try_cleanup_dead_nodes();
    }
    let own = effective_uid();
    for name in shm_names(&dir.prefix) {
        let path = Path::new(SHM_DIR).join(name);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.uid() == own) {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// The first shared-memory object under `prefix` that another user owns or could open, described.
pub(super) fn foreign_or_exposed(prefix: &str) -> Option<String> {
    let own = effective_uid();
    let entries = std::fs::read_dir(SHM_DIR).ok()?;
    entries.flatten().find_map(|entry| {
        let name = entry.file_name().to_string_lossy().to_string();
        if !name.starts_with(prefix) {
            return None;
        }
        let metadata = entry.metadata().ok()?;
        if metadata.uid() != own {
            Some(format!("{SHM_DIR}/{name} belongs to user {}", user_name(metadata.uid())))
        } else if metadata.mode() & 0o077 != 0 {
            Some(format!("{SHM_DIR}/{name} has mode {:o}: other users can open it", metadata.mode() & 0o7777))
        } else {
            None
        }
    })
}

/// Who made iceoryx2's node counter of an instance's prefix.
pub(super) enum CounterMade {
    /// The daemon, owner-only (or it was there, ours and private, from the last run).
    Owner,
    /// Another process, since the daemon looked (its name in /dev/shm).
    ByAnother(String),
}

/// iceoryx2 creates its node counter segment for every user to write (mode 0666). The daemon makes it
/// first, owner-only: the name is learnt from a throwaway node under a second random prefix (whose
/// segment is removed at once), the content is iceoryx2's version word and a zero counter. A client that
/// read the last run's prefix may make it first, between the daemon's look and its making:
/// [`CounterMade::ByAnother`].
pub(super) fn prepare_node_counter(dir: &InstanceDir) -> Result<CounterMade, InstanceDirError> {
    let refused = |reason: String| InstanceDirError::Iceoryx2 { instance: dir.instance.clone(), reason };
    let existing = shm_names(&dir.prefix).into_iter().find(|n| n.ends_with(NODE_COUNTER_SUFFIX));
    if existing.is_some() {
        return Ok(CounterMade::Owner); // ours and private: foreign_or_exposed said so
    }
    let scratch = InstanceDir { prefix: new_prefix()?, ..dir.clone() };
    let node = NodeBuilder::new()
        .config(&scratch.iceoryx2_config()?)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| refused(format!("a throwaway node to learn the node counter's name: {e:?}")));
    drop(node);
    let made = shm_names(&scratch.prefix);
    for name in &made {
        let _ = std::fs::remove_file(Path::new(SHM_DIR).join(name));
    }
    let [counter] = made.as_slice() else {
        return Err(refused(format!(
            "a new node made {} shared-memory objects ({made:?}), where iceoryx2 0.10 makes one node counter",
            made.len()
        )));
    };
    let Some(rest) = counter.strip_prefix(&scratch.prefix).filter(|r| r.ends_with(NODE_COUNTER_SUFFIX))
    else {
        return Err(refused(format!("{counter:?} is not iceoryx2 0.10's node counter")));
    };
    let path = Path::new(SHM_DIR).join(format!("{}{rest}", dir.prefix));
    // iceoryx2's dynamic storage: a u64 version word, then the data (a u32 counter), padded to 16 bytes
    let mut content = [0u8; 16];
    let version = iceoryx2_bb_elementary::package_version::PackageVersion::get().to_u64();
    content[..8].copy_from_slice(&version.to_ne_bytes());
    let opened = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .custom_flags(nix::libc::O_NOFOLLOW)
        .open(&path);
    let mut file = match opened {
        Ok(file) => file,
        Err(e) if e.kind() == ErrorKind::AlreadyExists => {
            return Ok(CounterMade::ByAnother(format!("{}{rest}", dir.prefix)));
        }
        Err(e) => return Err(io(&path, "creating iceoryx2's node counter owner-only")(e)),
    };
    file.write_all(&content).map_err(io(&path, "writing iceoryx2's node counter"))?;
    Ok(CounterMade::Owner)
}

/// The names in /dev/shm that start with `prefix`.
pub(super) fn shm_names(prefix: &str) -> Vec<String> {
    std::fs::read_dir(SHM_DIR)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| e.file_name().to_string_lossy().to_string())
                .filter(|n| n.starts_with(prefix))
                .collect()
        })
        .unwrap_or_default()
}
