//! Matching blobs to marks by the board's layout: every labelling of four (or three) candidates scored by how
//! well a similarity transform carries the layout onto them.

use vservo_scene::{FeatureVector, MARKS};

use super::{Candidate, MAX_CANDIDATES, track};

/// Matches candidates to marks by the layout: every way of giving four (or, failing that, three) marks
/// distinct mark-like candidates, scored by how well a similarity transform (shift, turn, scale) carries
/// the layout onto them. Returns the assignment and where the layout puts each mark.
///
/// The paper's four marks are nearly point-symmetric (the diagonals' midpoints are 2.5 px apart), so the
/// labelling turned by 180° fits almost as well, and under perspective it can fit better. The score
/// therefore adds a small cost for turning the layout: the image is taken to be turned by less than 90°
/// from the layout, as it is for a hand camera servoing to a desired view.
pub(super) fn match_layout(
    candidates: &[Candidate],
    layout: &FeatureVector,
) -> ([Option<usize>; MARKS], FeatureVector) {
    let mut usable = [0_usize; MAX_CANDIDATES];
    let mut n_usable = 0;
    for (i, _) in candidates.iter().enumerate().filter(|(_, c)| c.mark_like) {
        usable[n_usable] = i;
        n_usable += 1;
    }
    let usable = &usable[..n_usable];
    let point = |i: usize| (candidates[i].blob.centroid.0, candidates[i].blob.centroid.1);
    let model = |m: usize| (layout[2 * m], layout[2 * m + 1]);
    let mut best: Option<(f64, [Option<usize>; MARKS], Similarity)> = None;
    for marks_used in [MARKS, MARKS - 1] {
        if usable.len() < marks_used {
            continue;
        }
        for skipped in 0..(if marks_used == MARKS { 1 } else { MARKS }) {
            let mut marks = [0_usize; MARKS];
            let mut n_marks = 0;
            for m in (0..MARKS).filter(|&m| marks_used == MARKS || m != skipped) {
                marks[n_marks] = m;
                n_marks += 1;
            }
            let marks = &marks[..n_marks];
            permutations(usable, n_marks, &mut |chosen: &[usize]| {
                let mut pairs = [((0.0, 0.0), (0.0, 0.0)); MARKS];
                for (pair, (&m, &c)) in pairs.iter_mut().zip(marks.iter().zip(chosen)) {
                    *pair = (model(m), point(c));
                }
                let (fit, misfit) = Similarity::fit(&pairs[..n_marks]);
                let turn = fit.b.atan2(fit.a) / std::f64::consts::PI;
                let score = misfit + 0.01 * turn * turn;
                if misfit < 0.02 && best.as_ref().is_none_or(|(s, _, _)| score < *s) {
                    let mut assignment = [None; MARKS];
                    for (&m, &c) in marks.iter().zip(chosen) {
                        assignment[m] = Some(c);
                    }
                    best = Some((score, assignment, fit));
                }
            });
        }
        if best.is_some() {
            break;
        }
    }
    match best {
        Some((_, assignment, fit)) => {
            let mut expected = FeatureVector::zeros();
            for m in 0..MARKS {
                let (x, y) = fit.apply(model(m));
                expected[2 * m] = x;
                expected[2 * m + 1] = y;
            }
            (assignment, expected)
        }
        // fewer than three mark-like blobs: take the nearest for each mark, as in tracking
        None => (track(candidates, layout, f64::INFINITY), *layout),
    }
}

/// Calls `visit` with every ordered choice of `k` (at most four) distinct items.
pub(super) fn permutations(items: &[usize], k: usize, visit: &mut impl FnMut(&[usize])) {
    pub(super) fn go(
        items: &[usize],
        k: usize,
        chosen: &mut [usize; MARKS],
        len: usize,
        visit: &mut impl FnMut(&[usize]),
    ) {
        if len == k {
            visit(&chosen[..k]);
            return;
        }
        for &item in items {
            if !chosen[..len].contains(&item) {
                chosen[len] = item;
                go(items, k, chosen, len + 1, visit);
            }
        }
    }
    go(items, k.min(MARKS), &mut [0; MARKS], 0, visit);
}

/// A layout point and the image point it is matched with.
pub(super) type PointPair = ((f64, f64), (f64, f64));

/// x ↦ s·R(θ)·x + t in the image plane.
#[derive(Debug, Clone, Copy)]
pub(super) struct Similarity {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) tx: f64,
    pub(super) ty: f64,
}

impl Similarity {
    pub(super) const IDENTITY: Similarity = Similarity { a: 1.0, b: 0.0, tx: 0.0, ty: 0.0 };

    /// The least-squares fit of `to ≈ S(from)` and its misfit relative to the spread of `to` (0 is exact).
    pub(super) fn fit(pairs: &[PointPair]) -> (Similarity, f64) {
        let n = pairs.len() as f64;
        let (mut fx, mut fy, mut tx, mut ty) = (0.0, 0.0, 0.0, 0.0);
        for &((x, y), (u, v)) in pairs {
            fx += x;
            fy += y;
            tx += u;
            ty += v;
        }
        let (fx, fy, tx, ty) = (fx / n, fy / n, tx / n, ty / n);
        let (mut dot, mut cross, mut from_sq, mut to_sq) = (0.0, 0.0, 0.0, 0.0);
        for &((x, y), (u, v)) in pairs {
            let (x, y, u, v) = (x - fx, y - fy, u - tx, v - ty);
            dot += x * u + y * v;
            cross += x * v - y * u;
            from_sq += x * x + y * y;
            to_sq += u * u + v * v;
        }
        if from_sq <= 0.0 || to_sq <= 0.0 {
            return (Similarity { a: 1.0, b: 0.0, tx, ty }, f64::INFINITY);
        }
        let (a, b) = (dot / from_sq, cross / from_sq);
        let residual = (to_sq - (dot * dot + cross * cross) / from_sq).max(0.0);
        (Similarity { a, b, tx: tx - (a * fx - b * fy), ty: ty - (b * fx + a * fy) }, residual / to_sq)
    }

    /// Whether this fit turns the layout by less than 15° more (or less) and scales it by less than 1.25
    /// times more (or less) than `other`: as plausible a view of the board. (With two marks seen any
    /// labelling fits exactly; these bounds keep the alternatives to those the board's shape makes alike,
    /// such as the two pairs of a nearly parallelogram layout.)
    pub(super) fn as_plausible_as(&self, other: &Similarity) -> bool {
        let (scale, other_scale) = (self.a.hypot(self.b), other.a.hypot(other.b));
        let turn = (self.b * other.a - self.a * other.b).atan2(self.a * other.a + self.b * other.b);
        scale > 0.0
            && other_scale > 0.0
            && (scale / other_scale).ln().abs() < 1.25_f64.ln()
            && turn.abs() < 15_f64.to_radians()
    }

    pub(super) fn apply(&self, (x, y): (f64, f64)) -> (f64, f64) {
        (self.a * x - self.b * y + self.tx, self.b * x + self.a * y + self.ty)
    }
}
