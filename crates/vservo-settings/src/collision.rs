//! The collision guard's solids and workspace as plain values: what the configuration gives and the guard
//! (`vservo-collision`) builds its shapes from, and the obstacles as the primitives viewers draw them with
//! ([`Obstacle::primitives`], [`Primitive::edges`]).

use nalgebra::{IsometryMatrix3, Point3};

/// A solid as a configuration or a robot description gives it, centred on its own frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// A box of these full edge lengths along its frame's x, y and z.
    Box {
        /// The edge lengths (m).
        size_m: [f64; 3],
    },
    /// A cylinder along its frame's z (a URDF `<cylinder>`).
    Cylinder {
        /// Its radius (m).
        radius_m: f64,
        /// Its length, end to end (m).
        length_m: f64,
    },
    /// A capsule along its frame's z: a cylinder of this length with a half-ball on each end.
    Capsule {
        /// Its radius (m).
        radius_m: f64,
        /// The length of its cylinder (m).
        length_m: f64,
    },
    /// A ball.
    Sphere {
        /// Its radius (m).
        radius_m: f64,
    },
    /// Everything below its frame's xy plane (z ≤ 0): a floor or a wall with no end.
    HalfSpace,
}

/// A box the tool and the camera stay inside, in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// Its lowest corner (m).
    pub min_m: [f64; 3],
    /// Its highest corner (m).
    pub max_m: [f64; 3],
}

/// One obstacle of the scene (`[[scene.obstacles]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    /// Its name (messages, the status, markers).
    pub name: String,
    /// Its shape, centred on its frame (a plane: everything below its frame's xy plane).
    pub solid: Solid,
    /// Its frame in the base frame.
    pub base_from_obstacle: IsometryMatrix3<f64>,
}

/// A plane is drawn as a square of this edge (m) around its frame's origin: it has no end, a picture has.
pub const PLANE_DRAWN_EDGE_M: f64 = 3.0;
/// A plane is drawn this thick (m), its top face on the plane.
pub const PLANE_DRAWN_THICKNESS_M: f64 = 0.002;

/// A solid as viewers draw it (Foxglove's scene primitives, ROS 2's markers, a wireframe on a picture), placed in
/// the base frame: a box, or a cylinder or a ball, each centred on `base_from_centre` (a cylinder along its z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primitive {
    /// Which primitive.
    pub kind: PrimitiveKind,
    /// Its centre and orientation in the base frame.
    pub base_from_centre: IsometryMatrix3<f64>,
    /// Its full extent along its own x, y and z (m): a cylinder's diameter twice and its length, a ball's
    /// diameter three times.
    pub size_m: [f64; 3],
}

/// The primitives viewers have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimitiveKind {
    /// A box.
    Cube,
    /// A cylinder along its z.
    Cylinder,
    /// A ball.
    Sphere,
}

impl Obstacle {
    /// The obstacle as viewers' primitives: a box, a cylinder and a ball as themselves, a capsule as its cylinder
    /// and a ball on each end, a plane as a thin square ([`PLANE_DRAWN_EDGE_M`]) whose top face is the plane.
    pub fn primitives(&self) -> Vec<Primitive> {
        let at = |offset_z: f64| self.base_from_obstacle * IsometryMatrix3::translation(0.0, 0.0, offset_z);
        let primitive = |kind, offset_z, size_m| Primitive { kind, base_from_centre: at(offset_z), size_m };
        match self.solid {
            Solid::Box { size_m } => vec![primitive(PrimitiveKind::Cube, 0.0, size_m)],
            Solid::Cylinder { radius_m, length_m } => {
                vec![primitive(PrimitiveKind::Cylinder, 0.0, [2.0 * radius_m, 2.0 * radius_m, length_m])]
            }
            Solid::Sphere { radius_m } => vec![primitive(PrimitiveKind::Sphere, 0.0, [2.0 * radius_m; 3])],
            Solid::Capsule { radius_m, length_m } => vec![
                primitive(PrimitiveKind::Cylinder, 0.0, [2.0 * radius_m, 2.0 * radius_m, length_m]),
                primitive(PrimitiveKind::Sphere, -0.5 * length_m, [2.0 * radius_m; 3]),
                primitive(PrimitiveKind::Sphere, 0.5 * length_m, [2.0 * radius_m; 3]),
            ],
            Solid::HalfSpace => vec![primitive(
                PrimitiveKind::Cube,
                -0.5 * PLANE_DRAWN_THICKNESS_M,
                [PLANE_DRAWN_EDGE_M, PLANE_DRAWN_EDGE_M, PLANE_DRAWN_THICKNESS_M],
            )],
        }
    }
}

impl Workspace {
    /// The box as a primitive in the base frame.
    pub fn primitive(&self) -> Primitive {
        let centre = std::array::from_fn::<f64, 3, _>(|i| 0.5 * (self.min_m[i] + self.max_m[i]));
        Primitive {
            kind: PrimitiveKind::Cube,
            base_from_centre: IsometryMatrix3::translation(centre[0], centre[1], centre[2]),
            size_m: std::array::from_fn(|i| self.max_m[i] - self.min_m[i]),
        }
    }
}

/// Segments a circle is drawn with in a wireframe.
const CIRCLE_SEGMENTS: usize = 24;

impl Primitive {
    /// The primitive as a wireframe of segments in the base frame: a box's 12 edges; a cylinder's two end
    /// circles and four lines along it; a ball's three great circles.
    pub fn edges(&self) -> Vec<[Point3<f64>; 2]> {
        let half = self.size_m.map(|s| 0.5 * s);
        let local: Vec<[Point3<f64>; 2]> = match self.kind {
            PrimitiveKind::Cube => box_edges(half),
            PrimitiveKind::Cylinder => {
                let mut edges = circle(half[0], half[1], -half[2], [0, 1, 2]);
                edges.extend(circle(half[0], half[1], half[2], [0, 1, 2]));
                edges.extend((0..4).map(|k| {
                    let angle = std::f64::consts::FRAC_PI_2 * k as f64;
                    let (x, y) = (half[0] * angle.cos(), half[1] * angle.sin());
                    [Point3::new(x, y, -half[2]), Point3::new(x, y, half[2])]
                }));
                edges
            }
            PrimitiveKind::Sphere => {
                let mut edges = circle(half[0], half[1], 0.0, [0, 1, 2]);
                edges.extend(circle(half[1], half[2], 0.0, [1, 2, 0]));
                edges.extend(circle(half[2], half[0], 0.0, [2, 0, 1]));
                edges
            }
        };
        local.into_iter().map(|[a, b]| [self.base_from_centre * a, self.base_from_centre * b]).collect()
    }
}

/// A box's 12 edges, centred on the origin with these half extents.
fn box_edges(half: [f64; 3]) -> Vec<[Point3<f64>; 2]> {
    let corner = |k: usize| {
        Point3::from(std::array::from_fn::<f64, 3, _>(|i| if k & (1 << i) != 0 { half[i] } else { -half[i] }))
    };
    // an edge joins two corners that differ along one axis
    (0..8)
        .flat_map(|k| {
            (0..3).filter(move |i| k & (1 << i) == 0).map(move |i| [corner(k), corner(k | (1 << i))])
        })
        .collect()
}

/// An ellipse of half axes `a` and `b` in the plane of two axes (`axes[0]`, `axes[1]`) at `height` along the
/// third, as segments.
fn circle(a: f64, b: f64, height: f64, axes: [usize; 3]) -> Vec<[Point3<f64>; 2]> {
    let point = |k: usize| {
        let angle = std::f64::consts::TAU * k as f64 / CIRCLE_SEGMENTS as f64;
        let mut p = Point3::origin();
        p[axes[0]] = a * angle.cos();
        p[axes[1]] = b * angle.sin();
        p[axes[2]] = height;
        p
    };
    (0..CIRCLE_SEGMENTS).map(|k| [point(k), point(k + 1)]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    fn obstacle(solid: Solid) -> Obstacle {
        let rotation = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        Obstacle {
            name: "thing".into(),
            solid,
            base_from_obstacle: IsometryMatrix3::from_parts(
                Translation3::new(1.0, 2.0, 3.0),
                rotation.to_rotation_matrix(),
            ),
        }
    }

    #[test]
    fn a_box_is_drawn_as_its_twelve_edges_of_its_sizes_where_it_stands() {
        let drawn = obstacle(Solid::Box { size_m: [0.4, 0.2, 0.1] }).primitives();
        assert_eq!(drawn.len(), 1);
        let edges = drawn[0].edges();
        assert_eq!(edges.len(), 12);
        let mut lengths: Vec<f64> = edges.iter().map(|[a, b]| (b - a).norm()).collect();
        lengths.sort_by(f64::total_cmp);
        for (group, expected) in lengths.chunks(4).zip([0.1, 0.2, 0.4]) {
            assert!(group.iter().all(|l| (l - expected).abs() < 1e-12), "{lengths:?}");
        }
        // turned a quarter about z: the box's x edges (0.4 m) lie along the base's y
        let along_y = edges.iter().filter(|[a, b]| ((b - a).y.abs() - 0.4).abs() < 1e-12).count();
        assert_eq!(along_y, 4);
        let centre: Vector3<f64> =
            edges.iter().map(|[a, b]| (a.coords + b.coords) * 0.5).sum::<Vector3<f64>>() / 12.0;
        assert!((centre - Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-12);
    }

    #[test]
    fn a_capsule_is_a_cylinder_with_a_ball_on_each_end_and_a_plane_a_thin_square_under_it() {
        let capsule = obstacle(Solid::Capsule { radius_m: 0.05, length_m: 0.3 }).primitives();
        let kinds: Vec<PrimitiveKind> = capsule.iter().map(|p| p.kind).collect();
        assert_eq!(kinds, [PrimitiveKind::Cylinder, PrimitiveKind::Sphere, PrimitiveKind::Sphere]);
        assert_eq!(capsule[0].size_m, [0.1, 0.1, 0.3]);
        let ends: Vec<f64> = capsule[1..].iter().map(|p| p.base_from_centre.translation.z).collect();
        assert_eq!(ends, [2.85, 3.15]);
        let plane = obstacle(Solid::HalfSpace).primitives();
        let top = plane[0].edges().iter().flat_map(|e| e.iter().map(|p| p.z)).fold(f64::MIN, f64::max);
        assert!((top - 3.0).abs() < 1e-12, "the square's top face is the plane: {top}");
        // every point of a ball's wireframe is on the ball
        let ball = obstacle(Solid::Sphere { radius_m: 0.2 }).primitives()[0];
        let centre = Point3::new(1.0, 2.0, 3.0);
        assert!(ball.edges().iter().flatten().all(|p| ((p - centre).norm() - 0.2).abs() < 1e-12));
    }

    #[test]
    fn a_workspace_is_a_box_from_its_lowest_to_its_highest_corner() {
        let workspace = Workspace { min_m: [-0.5, -0.4, 0.0], max_m: [0.5, 0.6, 0.8] };
        let drawn = workspace.primitive();
        assert_eq!(drawn.size_m, [1.0, 1.0, 0.8]);
        let corners: Vec<Point3<f64>> = drawn.edges().into_iter().flatten().collect();
        let lowest = corners.iter().fold([f64::MAX; 3], |m, p| std::array::from_fn(|i| m[i].min(p[i])));
        assert_eq!(lowest, [-0.5, -0.4, 0.0]);
    }
}
