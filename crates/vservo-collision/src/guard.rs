//! The guard: each tick, the checked pairs within the slowdown distance and the workspace's faces near the tool
//! and the camera, how fast the reference closes each, and what follows — the asked motion slowed, its direction
//! kept, so that it closes no distance faster than the tool's speed limit scaled linearly from the slowdown
//! distance to nothing at the stop distance (a motion away or along is left alone); and a stop where the reference
//! closes one faster than it can brake before the stop distance, or where the asked motion still closes one that
//! has slowed it to [`HALT_SHARE`].
//!
//! Allocates nothing: the model's queries are parry3d's distance queries on shapes built once.

use nalgebra::Vector3;
use vservo_arm::{JointVector, MAX_JOINTS, Placement};
pub use vservo_settings::collision::Workspace;

use crate::braking::{BrakingLimits, stop_angles};
use crate::model::{CollisionModel, PairDistance};

/// Where the slowdown has left this share of the asked speed or less, a motion that still closes the distance
/// stops the arm (as MoveIt Servo halts for a collision when its scale reaches zero): the servo is told why
/// instead of creeping towards the stop distance for ever.
pub const HALT_SHARE: f64 = 0.02;

/// The distances the guard acts at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuardSettings {
    /// Below this a motion that closes a distance is slowed, linearly to nothing at the stop distance (m).
    pub slowdown_distance_m: f64,
    /// The arm stops before any checked distance is below this (m).
    pub stop_distance_m: f64,
}

/// Which distance a [`Nearness`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Between {
    /// A checked pair of the model (its index).
    Pair(usize),
    /// A point of the tool or the camera ([`Guard::point_name`]) and a face of the workspace.
    Workspace {
        /// The point's index.
        point: usize,
    },
}

/// One distance the guard watches, as it stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearness {
    /// Which.
    pub between: Between,
    /// The distance (m); negative: an overlap, or a point outside the workspace.
    pub distance_m: f64,
    /// How fast the reference closes it now (m/s; negative: it opens).
    pub closing_m_s: f64,
    /// How much it may still close while the reference brakes now, at most (m).
    pub braking_m: f64,
}

/// What the guard made of one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Assessment {
    /// The share of the asked motion to follow: 1 unless it closes a distance below the slowdown distance.
    pub speed_share: f64,
    /// The nearest distance within the slowdown distance, if any.
    pub nearest: Option<Nearness>,
    /// A distance the reference closes and cannot brake for before the stop distance: stop now.
    pub stop: Option<Nearness>,
}

/// The cell's collision model, its workspace, and the distances they act at.
#[derive(Debug, Clone)]
pub struct Guard {
    model: CollisionModel,
    settings: GuardSettings,
    workspace: Option<Workspace>,
    /// The points that stay inside the workspace: a name and the point in the last carrier's frame.
    points: Vec<(String, Vector3<f64>)>,
}

impl Guard {
    /// A guard of `model`, with the tool and camera points `points` (name, point in the last link's frame) kept
    /// inside `workspace`.
    pub fn new(
        model: CollisionModel,
        settings: GuardSettings,
        workspace: Option<Workspace>,
        points: Vec<(String, Vector3<f64>)>,
    ) -> Self {
        Self { model, settings, workspace, points }
    }

    /// The collision model.
    pub fn model(&self) -> &CollisionModel {
        &self.model
    }

    /// The distances it acts at.
    pub fn settings(&self) -> GuardSettings {
        self.settings
    }

    /// The name of workspace point `point`.
    pub fn point_name(&self, point: usize) -> &str {
        &self.points[point].0
    }

    /// The two names a [`Between`] is between.
    pub fn names(&self, between: Between) -> (&str, &str) {
        match between {
            Between::Pair(pair) => self.model.pair_names(pair),
            Between::Workspace { point } => (self.point_name(point), "workspace"),
        }
    }

    /// The distance `between` stands at as last placed (m): a pair of the model or a workspace point's nearest
    /// face (`None`: a workspace point without a workspace).
    pub fn distance_of(&self, between: Between, placement: &Placement) -> Option<f64> {
        match between {
            Between::Pair(pair) => self.model.pair_distance(pair, f64::INFINITY).map(|d| d.distance_m),
            Between::Workspace { point } => {
                let workspace = self.workspace?;
                let last = &placement.carriers[placement.joint_count];
                let at = last.transform_point(&self.points.get(point)?.1.into()).coords;
                faces(&workspace, &at).iter().map(|(d, _)| *d).reduce(f64::min)
            }
        }
    }

    /// Places the cell at `placement` and finds the nearest checked distance within `cutoff_m`: the model's
    /// pairs and, with a workspace, the tool's and the camera's points from its faces. For a status or a check,
    /// not for a tick (every pair is measured).
    pub fn nearest(&mut self, placement: &Placement, cutoff_m: f64) -> Option<(Between, f64)> {
        let joints = placement.joint_count;
        self.model.place(&placement.carriers[..=joints]);
        let pair = self.model.nearest(cutoff_m).map(|found| (Between::Pair(found.pair), found.distance_m));
        let point = (0..self.points.len())
            .filter_map(|point| {
                let between = Between::Workspace { point };
                self.distance_of(between, placement).map(|d| (between, d))
            })
            .filter(|(_, d)| *d <= cutoff_m)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        [pair, point].into_iter().flatten().min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// Places the cell at `placement` (the reference's joints) and judges the motion: `qd`, `qdd` the
    /// reference's speeds and accelerations now, `asked` the joint speeds the next tick asks for, `limits` what
    /// the reference brakes within.
    pub fn assess(
        &mut self,
        placement: &Placement,
        (qd, qdd): (&JointVector, &JointVector),
        asked: &JointVector,
        limits: &BrakingLimits,
    ) -> Assessment {
        let joints = placement.joint_count;
        self.model.place(&placement.carriers[..=joints]);
        let mut turn = [0.0; MAX_JOINTS];
        stop_angles(&qd.as_slice()[..joints], &qdd.as_slice()[..joints], limits, &mut turn);
        let motion = Motion { placement, model: &self.model, qd, asked, turn: &turn };
        let mut judged = Judged::new(self.settings, limits.tool_speed_m_s);
        let slowdown_m = self.settings.slowdown_distance_m;
        for pair in 0..self.model.pair_count() {
            if let Some(found) = self.model.pair_distance(pair, slowdown_m) {
                let carriers = self.model.pair_carriers(pair);
                judged.take(motion.of_pair(&found, carriers), Between::Pair(pair));
            }
        }
        if let Some(workspace) = self.workspace {
            let last = &placement.carriers[joints];
            for (point, (_, in_last)) in self.points.iter().enumerate() {
                let at = last.transform_point(&(*in_last).into()).coords;
                for (distance_m, away) in faces(&workspace, &at) {
                    if distance_m <= slowdown_m {
                        let nearness = motion.of_point(at, joints, distance_m, away);
                        judged.take(nearness, Between::Workspace { point });
                    }
                }
            }
        }
        judged.assessment
    }
}

/// The reference's motion, for the speeds and braking of points.
struct Motion<'a> {
    placement: &'a Placement,
    model: &'a CollisionModel,
    qd: &'a JointVector,
    asked: &'a JointVector,
    /// Each joint's braking angle, signed as it turns (rad).
    turn: &'a [f64; MAX_JOINTS],
}

impl Motion<'_> {
    /// The speed of `point` on carrier `carrier` at joint speeds `rates`.
    fn velocity(&self, point: &Vector3<f64>, carrier: usize, rates: &JointVector) -> Vector3<f64> {
        (0..carrier.min(self.placement.joint_count)).fold(Vector3::zeros(), |v, j| {
            let (axis, on_axis) = self.placement.joint_axes[j];
            v + axis.cross(&(point - on_axis)) * rates[j]
        })
    }

    /// How much a distance closes while the reference brakes now (m): between `first` and `second` (each a
    /// nearest point and its carrier; 0 does not move), `away` the direction in which the first's point opens it;
    /// `turning(w)` how much the first body's turn against the second brings its other points closer, for
    /// `w = φ × away` ([`Motion::turned_closer`]).
    ///
    /// The nearest points' motion over the joints' stop angles, to second order (each joint's stop is the
    /// generator's own, so the angles are what the joints turn, not bounds), and the bodies' turn against each
    /// other over the same angles, to first order.
    fn braking_m(
        &self,
        first: (&Vector3<f64>, usize),
        second: (&Vector3<f64>, usize),
        away: &Vector3<f64>,
        turning: impl Fn(&Vector3<f64>) -> f64,
    ) -> f64 {
        let joints = self.placement.joint_count;
        let axes = &self.placement.joint_axes;
        let moved = |(point, carrier): (&Vector3<f64>, usize), j: usize| {
            if j < carrier { axes[j].0.cross(&(point - axes[j].1)) } else { Vector3::zeros() }
        };
        let (mut closing_m, mut relative_turn) = (0.0, Vector3::zeros());
        for (j, (axis, _)) in axes.iter().enumerate().take(joints) {
            closing_m -= (moved(first, j) - moved(second, j)).dot(away) * self.turn[j];
            match (j < first.1, j < second.1) {
                (true, false) => relative_turn += axis * self.turn[j],
                (false, true) => relative_turn -= axis * self.turn[j],
                _ => {}
            }
        }
        let turned_m =
            if relative_turn.norm() > 0.0 { turning(&relative_turn.cross(away)).max(0.0) } else { 0.0 };
        let quadratic = |(point, carrier): (&Vector3<f64>, usize)| {
            let mut sum = Vector3::zeros();
            for i in 0..carrier.min(joints) {
                for k in i..carrier.min(joints) {
                    let weight = if i == k { 0.5 } else { 1.0 };
                    let term = axes[i].0.cross(&axes[k].0.cross(&(point - axes[k].1)));
                    sum += term * (weight * self.turn[i] * self.turn[k]);
                }
            }
            sum
        };
        let second_order_m = -(quadratic(first) - quadratic(second)).dot(away);
        (closing_m + turned_m + second_order_m).max(0.0)
    }

    /// How much the bodies' turn `φ` against each other brings points other than the nearest closer, to first
    /// order: seen from either body, the other turns about its nearest point, and its points `x` come closer by
    /// `(x − p)·w`, `w = φ × away`, at most; each side is a bound (the separating plane at the fixed body's
    /// nearest point), and the smaller is kept. A half-space has no end to turn: the other side is read.
    fn turned_closer(&self, found: &PairDistance, towards: &Vector3<f64>) -> f64 {
        let model = self.model;
        let first =
            model.reach_along(found.pair, false, towards).map(|reach| reach - found.point_first.dot(towards));
        let second =
            model.reach_along(found.pair, true, towards).map(|reach| reach - found.point_second.dot(towards));
        match (first, second) {
            (Some(a), Some(b)) => a.min(b),
            (Some(one), None) | (None, Some(one)) => one,
            (None, None) => f64::INFINITY,
        }
    }

    /// A pair's distance as the reference moves: closing speeds now and as asked, and its braking bound.
    fn of_pair(&self, found: &PairDistance, (first, second): (usize, usize)) -> (Nearness, f64) {
        let closing = |rates: &JointVector| {
            let relative = self.velocity(&found.point_first, first, rates)
                - self.velocity(&found.point_second, second, rates);
            -relative.dot(&found.away_from_second)
        };
        let braking_m = self.braking_m(
            (&found.point_first, first),
            (&found.point_second, second),
            &found.away_from_second,
            |towards| self.turned_closer(found, towards),
        );
        let nearness = Nearness {
            between: Between::Pair(0),
            distance_m: found.distance_m,
            closing_m_s: closing(self.qd),
            braking_m,
        };
        (nearness, closing(self.asked))
    }

    /// A point on the last carrier at `distance_m` from a workspace face, `away` the direction into the box.
    fn of_point(
        &self,
        point: Vector3<f64>,
        carrier: usize,
        distance_m: f64,
        away: Vector3<f64>,
    ) -> (Nearness, f64) {
        let closing = |rates: &JointVector| -self.velocity(&point, carrier, rates).dot(&away);
        let braking_m = self.braking_m((&point, carrier), (&point, 0), &away, |_| 0.0);
        let nearness = Nearness {
            between: Between::Workspace { point: 0 },
            distance_m,
            closing_m_s: closing(self.qd),
            braking_m,
        };
        (nearness, closing(self.asked))
    }
}

/// The assessment as the distances come in.
struct Judged {
    settings: GuardSettings,
    tool_speed_m_s: f64,
    assessment: Assessment,
}

impl Judged {
    fn new(settings: GuardSettings, tool_speed_m_s: f64) -> Self {
        Self {
            settings,
            tool_speed_m_s,
            assessment: Assessment { speed_share: 1.0, nearest: None, stop: None },
        }
    }

    /// Takes one distance, with how fast the asked motion closes it.
    fn take(&mut self, (nearness, asked_closing_m_s): (Nearness, f64), between: Between) {
        let nearness = Nearness { between, ..nearness };
        let GuardSettings { slowdown_distance_m, stop_distance_m } = self.settings;
        let a = &mut self.assessment;
        if a.nearest.is_none_or(|n| nearness.distance_m < n.distance_m) {
            a.nearest = Some(nearness);
        }
        let mut halted = false;
        if asked_closing_m_s > 0.0 {
            let ramp = ((nearness.distance_m - stop_distance_m) / (slowdown_distance_m - stop_distance_m))
                .clamp(0.0, 1.0);
            let share = (self.tool_speed_m_s * ramp / asked_closing_m_s).min(1.0);
            a.speed_share = a.speed_share.min(share);
            halted = share <= HALT_SHARE;
        }
        let cannot_brake =
            nearness.closing_m_s > 0.0 && nearness.distance_m - nearness.braking_m <= stop_distance_m;
        if (halted || cannot_brake) && a.stop.is_none_or(|s| nearness.distance_m < s.distance_m) {
            a.stop = Some(nearness);
        }
    }
}

/// Each face of the workspace: the point's distance inside it, and the direction away from it.
fn faces(workspace: &Workspace, at: &Vector3<f64>) -> [(f64, Vector3<f64>); 6] {
    let axis = |i: usize| Vector3::from_fn(|r, _| if r == i { 1.0 } else { 0.0 });
    std::array::from_fn(|face| {
        let i = face / 2;
        if face % 2 == 0 {
            (at[i] - workspace.min_m[i], axis(i))
        } else {
            (workspace.max_m[i] - at[i], -axis(i))
        }
    })
}
