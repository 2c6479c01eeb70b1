//! The clock every stamp of the protocol is on: CLOCK_MONOTONIC, in nanoseconds (daemon, nodes and drivers share
//! one host).

pub use vservo_time::monotonic_ns;
