//! The homography of a plane to an image, fitted to point pairs by the normalised direct linear transform
//! (Hartley & Zisserman, algorithm 4.2): each side's points moved to their centroid and scaled to a mean
//! distance of √2, the least-squares null vector of the stacked equations taken from their 9 × 9 normal
//! matrix, and the normalisations undone. Fixed-size throughout: no allocation, however many pairs.

use nalgebra::{Matrix3, Point2, SMatrix, SVector, Vector3};

/// The homography `image_from_plane` that best maps each pair's plane point to its image point, for at least
/// four pairs; `None` for fewer, a point not finite, or points that do not fix one (three of four in a line,
/// all on one line).
pub fn fit_homography(pairs: &[(Point2<f64>, Point2<f64>)]) -> Option<Matrix3<f64>> {
    if pairs.len() < 4
        || pairs.iter().any(|(a, b)| !(a.coords.iter().chain(b.coords.iter()).all(|v| v.is_finite())))
    {
        return None;
    }
    let plane_norm = normalisation(pairs.iter().map(|(plane, _)| plane))?;
    let image_norm = normalisation(pairs.iter().map(|(_, image)| image))?;
    let mut normal = SMatrix::<f64, 9, 9>::zeros();
    for (plane, image) in pairs {
        let p = plane_norm * Vector3::new(plane.x, plane.y, 1.0);
        let q = image_norm * Vector3::new(image.x, image.y, 1.0);
        let (x, y, u, v) = (p.x, p.y, q.x, q.y);
        let rows = [
            SVector::<f64, 9>::from([x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u]),
            SVector::<f64, 9>::from([0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v]),
        ];
        for row in rows {
            normal += row * row.transpose();
        }
    }
    let eigen = normal.symmetric_eigen();
    let mut order: [usize; 9] = std::array::from_fn(|i| i);
    order.sort_unstable_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
    let largest = eigen.eigenvalues[order[8]];
    // a second (near) zero eigenvalue: the points do not fix a homography
    if eigen.eigenvalues[order[1]].partial_cmp(&(1e-12 * largest)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let h = eigen.eigenvectors.column(order[0]);
    let normalised = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let homography = image_norm.try_inverse()? * normalised * plane_norm;
    let singular = homography.singular_values();
    (singular.min() > 1e-12 * singular.max()).then_some(homography)
}

/// Where `homography` maps the plane point `p`; `None` at (or beyond) the line at infinity.
pub fn apply_homography(homography: &Matrix3<f64>, p: &Point2<f64>) -> Option<Point2<f64>> {
    let h = homography * Vector3::new(p.x, p.y, 1.0);
    (h.z.abs() > 1e-300)
        .then(|| Point2::new(h.x / h.z, h.y / h.z))
        .filter(|q| q.x.is_finite() && q.y.is_finite())
}

/// The similarity that moves `points` to their centroid and scales them to a mean distance of √2; `None` when
/// they all coincide.
fn normalisation<'a>(points: impl Iterator<Item = &'a Point2<f64>> + Clone) -> Option<Matrix3<f64>> {
    let count = points.clone().count() as f64;
    let centroid = points.clone().fold(Vector3::zeros(), |sum, p| sum + Vector3::new(p.x, p.y, 0.0)) / count;
    let mean_distance =
        points.map(|p| ((p.x - centroid.x).powi(2) + (p.y - centroid.y).powi(2)).sqrt()).sum::<f64>() / count;
    if mean_distance.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean_distance;
    Some(Matrix3::new(s, 0.0, -s * centroid.x, 0.0, s, -s * centroid.y, 0.0, 0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn random_homography(a: [f64; 8]) -> Matrix3<f64> {
        // a camera 0.3–1 m from a plane, looking at it from an angle: a homography as the bundle meets
        Matrix3::new(600.0 + a[0], a[1], 320.0, a[2], 600.0 + a[3], 240.0, a[4], a[5], 1.0)
            * Matrix3::new(1.0, 0.0, a[6], 0.0, 1.0, a[7], 0.0, 0.0, 0.6)
    }

    proptest! {
        /// Exact pairs give back the homography (up to scale) that made them, from four pairs to thirty-two.
        #[test]
        fn exact_pairs_give_back_their_homography(
            a in proptest::array::uniform8(-0.2f64..0.2), n in 4usize..33, turn in 0.0f64..6.3,
        ) {
            let truth = random_homography(a);
            // points on a golden-angle spiral: no three in a line
            let pairs: Vec<_> = (0..n)
                .map(|i| {
                    let (r, angle) = (0.05 + 0.2 * i as f64 / n as f64, turn + 2.399_963 * i as f64);
                    Point2::new(r * angle.cos(), r * angle.sin())
                })
                .map(|p| (p, apply_homography(&truth, &p).expect("finite")))
                .collect();
            let found = fit_homography(&pairs).expect("a homography");
            for probe in [Point2::new(0.2, -0.1), Point2::new(-0.15, 0.25), Point2::new(0.0, 0.0)] {
                let want = apply_homography(&truth, &probe).expect("finite");
                let got = apply_homography(&found, &probe).expect("finite");
                prop_assert!((want - got).norm() < 1e-6, "{want} vs {got}");
            }
        }
    }

    #[test]
    fn points_that_fix_no_homography_are_refused() {
        let on_a_line: Vec<_> =
            (0..6).map(|i| (Point2::new(f64::from(i), 0.0), Point2::new(f64::from(i), 1.0))).collect();
        assert!(fit_homography(&on_a_line).is_none());
        let three = [(Point2::new(0.0, 0.0), Point2::new(0.0, 0.0)); 3];
        assert!(fit_homography(&three).is_none());
        let square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
            .map(|(x, y)| (Point2::new(x, y), Point2::new(x, y)));
        let mut not_finite = square;
        not_finite[2].1.x = f64::NAN;
        assert!(fit_homography(&not_finite).is_none());
        let identity = fit_homography(&square).expect("a square");
        let p = apply_homography(&identity, &Point2::new(0.3, 0.7)).expect("finite");
        assert!((p - Point2::new(0.3, 0.7)).norm() < 1e-12, "{p}");
    }
}
