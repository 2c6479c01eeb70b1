//! What the daemon does once at its start: the configuration read and checked (the cell built, so that one that
//! cannot run is refused before any node starts), the instance claimed; and what it says when a driver it waits
//! for does not appear.

use std::path::Path;
use std::time::Duration;

use anyhow::Context;
use iceoryx2::prelude::{Node, ipc};
use vservo_config::Config;
use vservo_control::Gains;
use vservo_protocol::InstanceClaim;

use super::clearance::ClearanceWatch;

/// Says that an external driver (`what`) has not appeared after `waited`, and what to check; the drivers vservod
/// starts itself (`started`) say why in their own lines.
pub fn say_absent(instance: &str, what: &str, started: &str, waited: Duration) {
    tracing::warn!(
        waited_s = waited.as_secs_f64(),
        instance,
        schema = vservo_protocol::SCHEMA_VERSION,
        "no {what} has appeared: is it running, for this instance (and this user's runtime directory), on the same \
         schema (docs/PROTOCOL.md)? One vservod starts ({started}) says why above; a writer of another schema or a \
         stream taken is named above by its pid"
    );
}

/// Reads and checks the configuration: the text the nodes are handed is the text validated here; the gains
/// are designed and the arm placed now, so that a configuration that cannot run is refused before any node
/// starts.
pub fn load_config(config_path: &Path) -> anyhow::Result<(Config, String, Gains, ClearanceWatch)> {
    // the file with the bases it extends merged in: the nodes are handed that text
    let (config, config_text) = Config::load_with_text(config_path)?;
    let cell = vservo_cell::Cell::new(&config.cell).with_context(|| format!("{}", config_path.display()))?;
    if let vservo_config::VisionSource::Directory(directory) = &config.cell.vision.source {
        anyhow::bail!(
            "{}: camera.source = \"directory\" ({}): recorded images cannot close the loop; check them open-loop with `vservoctl vision extract`, or set camera.source = \"simulated\" or \"external\"",
            config_path.display(),
            directory.display()
        );
    }
    let clearance = ClearanceWatch::new(&cell);
    Ok((config, config_text, cell.gains().clone(), clearance))
}

/// The instance's runtime directory, lock and shared-memory prefix, out of other users' reach, and the
/// daemon's iceoryx2 node in it (the leftovers of an earlier run's dead nodes removed); the configuration
/// in force is written there for clients.
pub fn claim_instance(
    instance: &str,
    config_text: &str,
) -> anyhow::Result<(InstanceClaim, Node<ipc::Service>)> {
    let claim = InstanceClaim::claim(instance)?;
    if let Some(reason) = &claim.renewed_because {
        tracing::warn!(instance, reason, "the instance's shared-memory prefix was replaced by a new one");
    }
    // clients that find the instance by its name read its arm and camera from here
    claim.write_configuration(config_text)?;
    let node = vservo_protocol::create_node_in(claim.dir(), "daemon")?;
    let cleaned = vservo_protocol::cleanup_dead_nodes(&node);
    if cleaned > 0 {
        tracing::info!(instance, cleaned, "removed the leftovers of dead nodes of an earlier run");
    }
    Ok((claim, node))
}
