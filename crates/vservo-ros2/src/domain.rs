//! Joining the ROS 2 graph: the DDS participant in the configured domain, bound to one interface if asked.

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
