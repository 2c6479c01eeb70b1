//! The object's motion: where the board is at each instant of simulated time (the setting, with its
//! formula, is `vservo_settings::simulation::ObjectMotion`).

pub use vservo_settings::simulation::ObjectMotion;
