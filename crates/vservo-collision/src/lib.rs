//! The cell's collision geometry and the distances between its parts.
//!
//! The arm's links come from its URDF (primitives, and STL, OBJ or COLLADA meshes kept as their convex hulls);
//! the camera and its mount ride on the tool as a box; the scene's obstacles stand in the base frame. A
//! [`CollisionModel`] places them at a joint vector and finds the nearest checked pair, with parry3d's queries.
//! Pure and deterministic: the files are read when the model is built, and placing and measuring allocate
//! nothing.

pub mod braking;
pub mod error;
pub mod guard;
pub mod mesh;
pub mod model;
pub mod shape;
pub mod urdf_bodies;

pub use braking::BrakingLimits;
pub use error::GeometryError;
pub use guard::{Assessment, Between, Guard, GuardSettings, Nearness, Workspace};
pub use model::{CollisionModel, PairDistance};
pub use shape::Solid;
pub use urdf_bodies::{BodyKind, BodySpec, arm_bodies};
