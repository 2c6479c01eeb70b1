//! The cell's bodies placed at one joint vector, the pairs that are checked, and the smallest distance between
//! them.
//!
//! Pairs left out: two bodies that cannot move relative to each other (both on the base, or on one carrier), two
//! arm bodies on neighbouring carriers (the links a moving joint joins, as MoveIt's default), and the pairs the
//! configuration names (an SRDF's `disable_collisions`). Placing the bodies and measuring them allocates
//! nothing.

use nalgebra::Vector3;
use parry3d_f64::math::Pose3;
use parry3d_f64::query;
use parry3d_f64::shape::SharedShape;
use vservo_arm::Transform;

use crate::error::GeometryError;
use crate::shape::{pose_of, vector_of};
use crate::urdf_bodies::{BodyKind, BodySpec};

/// Beyond this a pair is not measured when no cutoff is asked for (m).
const FAR_M: f64 = 1.0e3;

/// One shape of a body, where it sits, and the ball that bounds it.
#[derive(Clone)]
struct PlacedShape {
    shape: SharedShape,
    body_from_shape: Transform,
    /// Where the bounding ball's centre is in the shape's frame, and its radius (infinite for a half-space).
    local_centre: Vector3<f64>,
    radius_m: f64,
    /// Set by [`CollisionModel::place`]: the shape in the base frame, and its ball's centre.
    world: Pose3,
    world_centre: Vector3<f64>,
}

/// A body of the cell.
#[derive(Clone)]
struct Body {
    name: String,
    kind: BodyKind,
    carrier: usize,
    carrier_from_body: Transform,
    shapes: Vec<PlacedShape>,
}

/// The distance between two bodies and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairDistance {
    /// The index of the pair ([`CollisionModel::pair_names`]).
    pub pair: usize,
    /// The distance between the two bodies (m); negative: how deep they overlap.
    pub distance_m: f64,
    /// The nearest point of the pair's first body, in the base frame.
    pub point_first: Vector3<f64>,
    /// The nearest point of its second body, in the base frame.
    pub point_second: Vector3<f64>,
    /// The unit direction, in the base frame, in which the first body's point moves away from the second.
    pub away_from_second: Vector3<f64>,
}

/// The cell's collision geometry: bodies, and the pairs that are checked between them.
#[derive(Clone)]
pub struct CollisionModel {
    bodies: Vec<Body>,
    pairs: Vec<(usize, usize)>,
}

impl std::fmt::Debug for CollisionModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CollisionModel")
            .field("bodies", &self.bodies.iter().map(|b| b.name.as_str()).collect::<Vec<_>>())
            .field("pairs", &self.pairs.len())
            .finish()
    }
}

impl CollisionModel {
    /// The model of these bodies, every pair checked except those the module's doc leaves out and those in
    /// `disabled` (by name, in either order). `Err` on a name given twice or a disabled pair naming a body
    /// that is not there.
    pub fn new(specs: Vec<BodySpec>, disabled: &[[String; 2]]) -> Result<Self, GeometryError> {
        let bodies = specs.into_iter().map(body_of).collect::<Vec<_>>();
        for (i, body) in bodies.iter().enumerate() {
            if bodies[..i].iter().any(|b| b.name == body.name) {
                return Err(GeometryError::DuplicateName { name: body.name.clone() });
            }
        }
        let index_of = |name: &str, pair: &[String; 2]| {
            bodies.iter().position(|b| b.name == name).ok_or_else(|| GeometryError::UnknownBody {
                first: pair[0].clone(),
                second: pair[1].clone(),
                unknown: name.to_string(),
                known: bodies.iter().map(|b| b.name.as_str()).collect::<Vec<_>>().join(", "),
            })
        };
        let mut disabled_indices = Vec::with_capacity(disabled.len());
        for pair in disabled {
            disabled_indices.push((index_of(&pair[0], pair)?, index_of(&pair[1], pair)?));
        }
        let mut pairs = Vec::new();
        for a in 0..bodies.len() {
            for b in a + 1..bodies.len() {
                let named = disabled_indices.iter().any(|&(x, y)| (x, y) == (a, b) || (y, x) == (a, b));
                if !named && may_meet(&bodies[a], &bodies[b]) {
                    pairs.push((a, b));
                }
            }
        }
        Ok(Self { bodies, pairs })
    }

    /// How many pairs are checked.
    pub fn pair_count(&self) -> usize {
        self.pairs.len()
    }

    /// The carriers of pair `pair`'s two bodies (0: the base).
    pub fn pair_carriers(&self, pair: usize) -> (usize, usize) {
        let (a, b) = self.pairs[pair];
        (self.bodies[a].carrier, self.bodies[b].carrier)
    }

    /// How far pair `pair`'s first body (`second`: its second) reaches along `direction`, as placed: the
    /// largest `x · direction` over its points (m per unit of `direction`); `None` for a body with a shape that
    /// has no end in some direction (a half-space).
    pub fn reach_along(&self, pair: usize, second: bool, direction: &Vector3<f64>) -> Option<f64> {
        let (a, b) = self.pairs[pair];
        let body = &self.bodies[if second { b } else { a }];
        let towards = parry3d_f64::math::Vec3::new(direction.x, direction.y, direction.z);
        body.shapes.iter().try_fold(f64::NEG_INFINITY, |reach, shape| {
            let support = shape.shape.as_support_map()?.support_point(&shape.world, towards);
            Some(reach.max(vector_of(support).dot(direction)))
        })
    }

    /// The names of pair `pair`'s two bodies.
    pub fn pair_names(&self, pair: usize) -> (&str, &str) {
        let (a, b) = self.pairs[pair];
        (&self.bodies[a].name, &self.bodies[b].name)
    }

    /// Places every body: `base_from_carrier[k]` is carrier `k`'s frame in the base frame (element 0 the base
    /// itself). A body whose carrier is past the slice's end stays where it was.
    pub fn place(&mut self, base_from_carrier: &[Transform]) {
        for body in &mut self.bodies {
            let Some(base_from_carrier) = base_from_carrier.get(body.carrier) else { continue };
            let base_from_body = base_from_carrier * body.carrier_from_body;
            for shape in &mut body.shapes {
                let base_from_shape = base_from_body * shape.body_from_shape;
                shape.world = pose_of(&base_from_shape);
                shape.world_centre = base_from_shape.transform_point(&shape.local_centre.into()).coords;
            }
        }
    }

    /// The distance of pair `pair` as placed, or `None` when it is beyond `cutoff_m`.
    pub fn pair_distance(&self, pair: usize, cutoff_m: f64) -> Option<PairDistance> {
        let (a, b) = self.pairs[pair];
        let mut nearest: Option<PairDistance> = None;
        for first in &self.bodies[a].shapes {
            for second in &self.bodies[b].shapes {
                let reach_m = nearest.map_or(cutoff_m, |n| n.distance_m.min(cutoff_m));
                if let Some(found) = shape_distance(first, second, reach_m) {
                    nearest = Some(PairDistance { pair, ..found });
                }
            }
        }
        nearest
    }

    /// The nearest pair as placed and its distance, or `None` when every pair is beyond `cutoff_m` (at most
    /// 1 km is measured).
    pub fn nearest(&self, cutoff_m: f64) -> Option<PairDistance> {
        let mut nearest: Option<PairDistance> = None;
        for pair in 0..self.pairs.len() {
            let reach_m = nearest.map_or(cutoff_m.min(FAR_M), |n| n.distance_m);
            if let Some(found) = self.pair_distance(pair, reach_m)
                && nearest.is_none_or(|n| found.distance_m < n.distance_m)
            {
                nearest = Some(found);
            }
        }
        nearest
    }
}

/// A body with its shapes' bounding balls.
fn body_of(spec: BodySpec) -> Body {
    let shapes = spec
        .shapes
        .into_iter()
        .map(|(shape, body_from_shape)| {
            let ball = shape.compute_local_bounding_sphere();
            let infinite = shape.as_halfspace().is_some();
            PlacedShape {
                local_centre: vector_of(ball.center),
                radius_m: if infinite { f64::INFINITY } else { ball.radius },
                shape,
                body_from_shape,
                world: Pose3::IDENTITY,
                world_centre: Vector3::zeros(),
            }
        })
        .collect();
    Body {
        name: spec.name,
        kind: spec.kind,
        carrier: spec.carrier,
        carrier_from_body: spec.carrier_from_body,
        shapes,
    }
}

/// Whether two bodies can come nearer or further: not both still, not rigidly joined, not an arm's neighbours.
fn may_meet(a: &Body, b: &Body) -> bool {
    let still = |body: &Body| body.carrier == 0;
    if a.shapes.is_empty() || b.shapes.is_empty() || (still(a) && still(b)) || a.carrier == b.carrier {
        return false;
    }
    let neighbours = a.kind == BodyKind::Arm && b.kind == BodyKind::Arm && a.carrier.abs_diff(b.carrier) == 1;
    !neighbours
}

/// The distance between two placed shapes when it is within `reach_m` (their balls first).
fn shape_distance(first: &PlacedShape, second: &PlacedShape, reach_m: f64) -> Option<PairDistance> {
    if first.radius_m.is_finite() && second.radius_m.is_finite() {
        let gap_m = (first.world_centre - second.world_centre).norm() - first.radius_m - second.radius_m;
        if gap_m > reach_m {
            return None;
        }
    }
    // parry3d 0.31 measures a half-space wrongly when it is the second shape (a ball 0.4 m above the plane
    // z = 0 comes out 0.6 m inside it; first, it is right): the half-space is always asked first
    if second.shape.as_halfspace().is_some() && first.shape.as_halfspace().is_none() {
        let contact =
            query::contact(&second.world, second.shape.as_ref(), &first.world, first.shape.as_ref(), reach_m)
                .ok()??;
        return (contact.dist <= reach_m).then(|| PairDistance {
            pair: 0,
            distance_m: contact.dist,
            point_first: vector_of(contact.point2),
            point_second: vector_of(contact.point1),
            away_from_second: vector_of(contact.normal1),
        });
    }
    let contact =
        query::contact(&first.world, first.shape.as_ref(), &second.world, second.shape.as_ref(), reach_m)
            .ok()??;
    (contact.dist <= reach_m).then(|| PairDistance {
        pair: 0,
        distance_m: contact.dist,
        point_first: vector_of(contact.point1),
        point_second: vector_of(contact.point2),
        away_from_second: -vector_of(contact.normal1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Solid;
    use nalgebra::{Rotation3, Translation3};

    fn solid_body(name: &str, kind: BodyKind, carrier: usize, at: [f64; 3], solid: Solid) -> BodySpec {
        let (shape, solid_from_shape) = crate::shape::shape_of(&solid).expect("a solid");
        let place = Transform::from_parts(Translation3::new(at[0], at[1], at[2]), Rotation3::identity());
        BodySpec {
            name: name.to_string(),
            kind,
            carrier,
            carrier_from_body: place,
            shapes: vec![(shape, solid_from_shape)],
        }
    }

    /// A ball above a floor and beside a box, either one named first: the distances, points and directions
    /// worked out by hand.
    #[test]
    fn a_ball_above_a_floor_and_beside_a_box_is_where_it_is_whichever_comes_first() {
        for floor_first in [false, true] {
            let ball = solid_body("ball", BodyKind::Arm, 1, [0.3, 0.2, 0.5], Solid::Sphere { radius_m: 0.1 });
            let floor = solid_body("floor", BodyKind::Obstacle, 0, [0.0; 3], Solid::HalfSpace);
            let wall = solid_body(
                "wall",
                BodyKind::Obstacle,
                0,
                [1.0, 0.2, 0.5],
                Solid::Box { size_m: [0.2, 1.0, 1.0] },
            );
            let bodies = if floor_first { vec![floor, wall, ball] } else { vec![ball, floor, wall] };
            let mut model = CollisionModel::new(bodies, &[]).expect("a model");
            model.place(&[Transform::identity(), Transform::identity()]);
            assert_eq!(model.pair_count(), 2, "the two obstacles are not a pair");
            for pair in 0..2 {
                let found = model.pair_distance(pair, 10.0).expect("measured");
                let (first, second) = model.pair_names(pair);
                let (ball_point, other_point, away_from_other) = if first == "ball" {
                    (found.point_first, found.point_second, found.away_from_second)
                } else {
                    (found.point_second, found.point_first, -found.away_from_second)
                };
                let (distance, direction) = if first == "floor" || second == "floor" {
                    (0.4, Vector3::z())
                } else {
                    (0.5, -Vector3::x())
                };
                assert!((found.distance_m - distance).abs() < 1e-9, "{first}–{second}: {}", found.distance_m);
                assert!((away_from_other - direction).norm() < 1e-9, "{first}–{second}: {away_from_other}");
                assert!(((ball_point - other_point).norm() - distance).abs() < 1e-9, "{first}–{second}");
            }
            assert!((model.nearest(10.0).expect("a pair").distance_m - 0.4).abs() < 1e-9);
            assert!(model.nearest(0.3).is_none(), "beyond the cutoff");
        }
    }
}
