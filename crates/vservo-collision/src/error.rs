//! Why a cell's collision geometry cannot be built.

/// A refusal to build the cell's collision geometry, naming what and where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// A mesh file a URDF names could not be found.
    #[error("link {link:?}: mesh {filename:?} not found (looked at {tried})")]
    MeshNotFound {
        /// The link whose collision element names it.
        link: String,
        /// The filename as the URDF writes it.
        filename: String,
        /// The paths tried, for the message.
        tried: String,
    },
    /// A mesh file could not be read or parsed.
    #[error("link {link:?}: mesh {path}: {message}")]
    MeshUnreadable {
        /// The link.
        link: String,
        /// The file.
        path: String,
        /// The loader's message.
        message: String,
    },
    /// A mesh is larger than a collision mesh is read up to.
    #[error(
        "link {link:?}: mesh {path} has {vertices} vertices; a collision mesh is read up to {MAX_MESH_VERTICES}"
    )]
    MeshTooLarge {
        /// The link.
        link: String,
        /// The file.
        path: String,
        /// How many vertices it has.
        vertices: usize,
    },
    /// A shape has no volume, or a number that is not finite or not positive.
    #[error("{body:?}: {why}")]
    BadShape {
        /// The link, obstacle or `"camera"`.
        body: String,
        /// What is wrong.
        why: String,
    },
    /// A pair to leave unchecked names a body the cell does not have.
    #[error(
        "disabled pair [{first:?}, {second:?}]: no link, obstacle or camera named {unknown:?} (known: {known})"
    )]
    UnknownBody {
        /// The pair's first name.
        first: String,
        /// Its second.
        second: String,
        /// The name not found.
        unknown: String,
        /// The names the cell has.
        known: String,
    },
    /// Two obstacles, or an obstacle and a link, have one name.
    #[error("two bodies are named {name:?}")]
    DuplicateName {
        /// The name.
        name: String,
    },
    /// The URDF could not be read.
    #[error(transparent)]
    Urdf(#[from] vservo_arm::urdf::UrdfError),
}

/// The most vertices a collision mesh is read with (its convex hull is what is kept).
pub const MAX_MESH_VERTICES: usize = 500_000;
