//! A robot description's mesh (STL, OBJ or COLLADA), read with `mesh-loader` and kept as its convex hull: what
//! the distance queries take, and what collision checkers (MoveIt's FCL, coal, PyBullet) do with a mesh too.

use std::path::{Path, PathBuf};

use parry3d_f64::math::Vec3;
use parry3d_f64::shape::SharedShape;

use crate::error::{GeometryError, MAX_MESH_VERTICES};

/// Where a URDF's mesh `filename` is on disk: relative to the URDF's folder, `file://` absolute, or
/// `package://NAME/REST` looked for as `REST` and `NAME/REST` in the URDF's folder and each folder above it (as
/// PyBullet looks for it). `Err` with the paths tried.
pub fn locate(urdf_dir: &Path, filename: &str, link: &str) -> Result<PathBuf, GeometryError> {
    let candidates: Vec<PathBuf> = if let Some(absolute) = filename.strip_prefix("file://") {
        vec![PathBuf::from(absolute)]
    } else if let Some(packaged) = filename.strip_prefix("package://") {
        let rest = packaged.split_once('/').map_or(packaged, |(_, rest)| rest);
        urdf_dir.ancestors().flat_map(|dir| [dir.join(rest), dir.join(packaged)]).collect()
    } else {
        vec![urdf_dir.join(filename)]
    };
    candidates.iter().find(|path| path.is_file()).cloned().ok_or_else(|| GeometryError::MeshNotFound {
        link: link.to_string(),
        filename: filename.to_string(),
        tried: candidates.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "),
    })
}

/// The convex hull of the mesh at `path`, every vertex scaled by `scale` (the URDF's `<mesh scale>`).
pub fn convex_hull(path: &Path, scale: [f64; 3], link: &str) -> Result<SharedShape, GeometryError> {
    let unreadable = |message: String| GeometryError::MeshUnreadable {
        link: link.to_string(),
        path: path.display().to_string(),
        message,
    };
    let scene = mesh_loader::Loader::default().load(path).map_err(|e| unreadable(e.to_string()))?;
    let vertices: usize = scene.meshes.iter().map(|mesh| mesh.vertices.len()).sum();
    if vertices > MAX_MESH_VERTICES {
        return Err(GeometryError::MeshTooLarge {
            link: link.to_string(),
            path: path.display().to_string(),
            vertices,
        });
    }
    let points: Vec<Vec3> = scene
        .meshes
        .iter()
        .flat_map(|mesh| mesh.vertices.iter())
        .map(|v| {
            Vec3::new(f64::from(v[0]) * scale[0], f64::from(v[1]) * scale[1], f64::from(v[2]) * scale[2])
        })
        .collect();
    if !points.iter().all(|p| p.is_finite()) {
        return Err(unreadable("a vertex is not finite".to_string()));
    }
    SharedShape::convex_hull(&points)
        .ok_or_else(|| unreadable(format!("its {} vertices enclose no volume", points.len())))
}
