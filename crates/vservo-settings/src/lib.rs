//! # vservo-settings — the stages' settings as plain values
//!
//! What the configuration file sets for the control law ([`control`], with the weights Q and R validated once
//! in [`weights`]), the simulation and the interpolator ([`simulation`]), the vision stages ([`vision`]) and the
//! collision guard's solids ([`collision`]):
//! enums and structs with their defaults and names, no math of the stages themselves.
//!
//! They live below both the stages (`vservo-control`, `vservo-sim`, `vservo-vision`, which re-export each at
//! the path where it is used) and the configuration (`vservo-config`), so that a driver that reads the
//! configuration does not build the cell's math: the drivers and bridges depend on the configuration, never on
//! the stages (tests/tests/architecture.rs).

pub mod collision;
pub mod control;
pub mod simulation;
pub mod vision;
pub mod weights;
