//! Finding a running instance: `--instance NAME`, or the instance of `--config FILE`, or by default the
//! default configuration's instance.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Args;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ZeroCopySend, ipc};
use vservo_protocol::Topic;

use crate::UsageError;

/// Which instance to talk to.
#[derive(Args, Debug, Clone)]
pub struct InstanceArg {
    /// The instance named in this configuration file [default: config/vservo.toml's].
    #[arg(long, value_name = "FILE", conflicts_with = "instance", global = true)]
    pub config: Option<PathBuf>,
    /// The instance name ([instance] name in its configuration).
    #[arg(long, value_name = "NAME", global = true)]
    pub instance: Option<String>,
}

impl InstanceArg {
    /// The instance name.
    pub fn name(&self) -> Result<String, UsageError> {
        if let Some(name) = &self.instance {
            return if vservo_config::is_instance_name(name) {
                Ok(name.clone())
            } else {
                Err(UsageError(format!("--instance {name:?}: {}", vservo_config::INSTANCE_NAME_RULE)))
            };
        }
        let path = self.config.clone().unwrap_or_else(|| PathBuf::from("config/vservo.toml"));
        // only the instance's name is needed: a file that no longer validates as a whole (edited since the
        // daemon started) still names its instance, so `reload` reaches the daemon, which refuses it and says why
        match vservo_config::Config::instance_of(&path) {
            Ok(name) => Ok(name),
            // without a file to read, the default instance
            Err(vservo_config::ConfigError::Read { .. }) if self.config.is_none() => {
                Ok("default".to_string())
            }
            Err(e) => Err(UsageError(e.to_string())),
        }
    }
}

impl InstanceArg {
    /// The configuration the instance `name` runs: the one its daemon wrote to the instance's directory,
    /// else `--config` (else config/vservo.toml), which must name that instance.
    pub fn configuration_in_force(&self, name: &str) -> anyhow::Result<vservo_config::Config> {
        let in_force = vservo_protocol::InstanceDir::locate(name).map(|dir| dir.configuration());
        let path = match in_force {
            Ok(path) if path.exists() => path,
            _ => self.config.clone().unwrap_or_else(|| PathBuf::from("config/vservo.toml")),
        };
        let config = vservo_config::Config::load(&path)?;
        if config.instance != name {
            anyhow::bail!("{} configures instance \"{}\", not \"{name}\"", path.display(), config.instance);
        }
        Ok(config)
    }
}

/// A connection to an instance's services.
pub struct Connection {
    /// The instance.
    pub instance: String,
    /// This process's iceoryx2 node.
    pub node: Node<ipc::Service>,
}

impl Connection {
    /// Opens a node in the instance's iceoryx2 domain.
    pub fn open(arg: &InstanceArg) -> anyhow::Result<Self> {
        let instance = arg.name()?;
        let node = vservo_protocol::create_node(&instance, &format!("vservoctl-{}", std::process::id()))?;
        Ok(Self { instance, node })
    }

    /// [`Connection::open`], waiting while no daemon has made the instance's directory yet (one still
    /// starting) until `give_up()` says so; any other refusal is at once.
    pub fn open_when_there(arg: &InstanceArg, mut give_up: impl FnMut() -> bool) -> anyhow::Result<Self> {
        loop {
            match Self::open(arg) {
                Err(error)
                    if matches!(
                        error.downcast_ref::<vservo_protocol::ProtocolError>(),
                        Some(vservo_protocol::ProtocolError::Instance(
                            vservo_protocol::InstanceDirError::NotRunning { .. }
                        ))
                    ) && !give_up() =>
                {
                    std::thread::sleep(Duration::from_millis(50));
                }
                result => return result,
            }
        }
    }

    /// A subscriber on a topic.
    pub fn subscriber<T: std::fmt::Debug + ZeroCopySend + 'static>(
        &self,
        topic: Topic,
    ) -> anyhow::Result<Subscriber<ipc::Service, T, ()>> {
        Ok(vservo_protocol::client_subscriber::<T>(&self.node, &self.instance, topic)?)
    }
}

/// How long a client without a deadline of its own waits for a service (a daemon still starting).
pub const WAIT_FOR_SERVICE: Duration = Duration::from_secs(2);

/// Opens a service, waiting for it while a daemon may still be starting: until `until`, or
/// [`WAIT_FOR_SERVICE`] without one. A client only opens, never creates: with no daemon this fails.
pub fn when_there<S>(
    until: Option<Instant>,
    mut open: impl FnMut() -> anyhow::Result<S>,
) -> anyhow::Result<S> {
    let give_up = until.unwrap_or_else(|| Instant::now() + WAIT_FOR_SERVICE);
    loop {
        match open() {
            Ok(opened) => return Ok(opened),
            Err(error) if Instant::now() >= give_up => return Err(error),
            Err(_) => std::thread::sleep(Duration::from_millis(20)),
        }
    }
}

/// Polls `receive` every millisecond until it yields or `timeout` passes.
pub fn wait_for<T>(timeout: Duration, mut receive: impl FnMut() -> Option<T>) -> Option<T> {
    let until = Instant::now() + timeout;
    loop {
        if let Some(value) = receive() {
            return Some(value);
        }
        if Instant::now() >= until {
            return None;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}
