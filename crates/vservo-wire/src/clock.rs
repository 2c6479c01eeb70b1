//! The clock every stamp of the protocol is on: CLOCK_MONOTONIC, in nanoseconds (daemon, nodes and drivers share
//! one host).

/// CLOCK_MONOTONIC now (ns).
pub fn monotonic_ns() -> u64 {
    // clock_gettime(CLOCK_MONOTONIC) cannot fail on Linux with a valid clock id
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .map(|t| t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64)
        .unwrap_or(0)
}
