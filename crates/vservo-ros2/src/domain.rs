//! Joining the ROS 2 graph: the DDS participant in the configured domain, bound to one interface if asked, and a
//! node of it in the configured namespace.

use anyhow::Context as _;
use vservo_config::Ros2;

/// The DDS participant: in the configured domain; with `interface`, advertised and multicasting on that
/// interface only.
pub fn participant(settings: &Ros2) -> anyhow::Result<rustdds::DomainParticipant> {
    let mut builder = rustdds::DomainParticipantBuilder::new(settings.domain_id);
    if let Some(address) = settings.interface {
        check_local(address)?;
        builder = builder.with_only_networks([address]);
    }
    builder.build().with_context(|| format!("joining DDS domain {}", settings.domain_id))
}

/// `ros2.interface` must be one of this machine's addresses: DDS would otherwise be bound to nothing.
fn check_local(address: std::net::IpAddr) -> anyhow::Result<()> {
    let local = nix::ifaddrs::getifaddrs()
        .context("listing this machine's interfaces")?
        .filter_map(|interface| interface.address)
        .filter_map(|socket| {
            let v4 = socket.as_sockaddr_in().map(|s| std::net::IpAddr::V4(s.ip()));
            v4.or_else(|| socket.as_sockaddr_in6().map(|s| std::net::IpAddr::V6(s.ip())))
        })
        .any(|ip| ip == address);
    anyhow::ensure!(local, "ros2.interface = \"{address}\" is not an address of this machine's interfaces");
    Ok(())
}

/// A ROS 2 node named `name` in the configured namespace, on a participant of the configured domain ([`participant`]),
/// without rosout; the context is returned with it (the node's entities live as long as it does).
pub fn node(settings: &Ros2, name: &str) -> anyhow::Result<(ros2_client::Context, ros2_client::Node)> {
    let context = ros2_client::Context::from_domain_participant(participant(settings)?)
        .map_err(|e| anyhow::anyhow!("creating the ROS 2 context: {e:?}"))?;
    let namespace = if settings.namespace.is_empty() { "/" } else { settings.namespace.as_str() };
    let node_name = ros2_client::NodeName::new(namespace, name)
        .map_err(|e| anyhow::anyhow!("ros2.namespace {namespace:?}: {e:?}"))?;
    let node = context
        .new_node(node_name, ros2_client::NodeOptions::new().enable_rosout(false))
        .map_err(|e| anyhow::anyhow!("creating the ROS 2 node: {e:?}"))?;
    Ok((context, node))
}
