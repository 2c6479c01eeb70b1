//! A bundle: several tag36h11 tags printed on one flat board, seen as one target (apriltag_ros's "tag
//! bundles"). Its four features are the corners of the box that holds every tag's black square
//! ([`TagBundle::outer_corners_in_board`]); vision finds them through the homography of every tag it sees,
//! so a tag hidden or out of view costs accuracy, not the target.

use nalgebra::{Point2, Point3};

use crate::board::{AprilTag, MARKS};
use crate::tag36h11;

/// The most tags a bundle holds.
pub const MAX_BUNDLE_TAGS: usize = 8;

/// Up to [`MAX_BUNDLE_TAGS`] tags on the board plane, each with its own id, size and centre, their rows along
/// the board's +y and their columns along +x (as [`AprilTag`]), none within another's white border.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagBundle {
    /// The tags; those past `len` repeat the first and are never looked at.
    tags: [AprilTag; MAX_BUNDLE_TAGS],
    len: u8,
}

/// Why tags cannot make a bundle.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BundleError {
    /// None, or more than [`MAX_BUNDLE_TAGS`].
    #[error("a bundle has 1 to {MAX_BUNDLE_TAGS} tags; {0} is not that")]
    Count(usize),
    /// Two tags with one id: which would be which?
    #[error("tags {first} and {second} (counted from 1) both have id {id}")]
    RepeatedId {
        /// The id.
        id: u32,
        /// The first tag with it.
        first: usize,
        /// The second.
        second: usize,
    },
    /// Two tags' black squares nearer than the white border either needs (one cell of the larger).
    #[error("tags {first} and {second} (counted from 1) overlap or touch each other's white border")]
    Overlap {
        /// The first tag.
        first: usize,
        /// The second.
        second: usize,
    },
}

impl TagBundle {
    /// The bundle of `tags`, in the order given (tag k is what a scenario's occlusion of "mark" k covers).
    pub fn new(tags: &[AprilTag]) -> Result<Self, BundleError> {
        let Some(&first) = tags.first().filter(|_| tags.len() <= MAX_BUNDLE_TAGS) else {
            return Err(BundleError::Count(tags.len()));
        };
        for (i, a) in tags.iter().enumerate() {
            for (j, b) in tags.iter().enumerate().skip(i + 1) {
                if a.id() == b.id() {
                    return Err(BundleError::RepeatedId { id: a.id(), first: i + 1, second: j + 1 });
                }
                if too_near(a, b) {
                    return Err(BundleError::Overlap { first: i + 1, second: j + 1 });
                }
            }
        }
        let mut all = [first; MAX_BUNDLE_TAGS];
        all[..tags.len()].copy_from_slice(tags);
        Ok(Self { tags: all, len: tags.len() as u8 })
    }

    /// The tags, in the bundle's order.
    pub fn tags(&self) -> &[AprilTag] {
        &self.tags[..usize::from(self.len)]
    }

    /// The tag with id `id` and its index in the bundle, if the bundle has it.
    pub fn tag_with_id(&self, id: u32) -> Option<(usize, &AprilTag)> {
        self.tags().iter().enumerate().find(|(_, tag)| tag.id() == id)
    }

    /// The lowest and highest (x, y) of every tag's black square (board frame, m).
    pub fn black_extent_in_board(&self) -> [Point2<f64>; 2] {
        let mut low = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut high = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for tag in self.tags() {
            let (c, half) = (tag.centre_in_board(), 0.5 * tag.size_m());
            low = Point2::new(low.x.min(c.x - half), low.y.min(c.y - half));
            high = Point2::new(high.x.max(c.x + half), high.y.max(c.y + half));
        }
        [low, high]
    }

    /// The four features' points: the corners of [`TagBundle::black_extent_in_board`], in the tags' own
    /// corner order ([`AprilTag::corners_in_board`]: (−x, +y), (+x, +y), (+x, −y), (−x, −y)). For a single tag
    /// they are its corners; for a 2 × 2 bundle the outer corners of its four tags.
    pub fn outer_corners_in_board(&self) -> [Point3<f64>; MARKS] {
        let [low, high] = self.black_extent_in_board();
        [(low.x, high.y), (high.x, high.y), (high.x, low.y), (low.x, low.y)]
            .map(|(x, y)| Point3::new(x, y, 0.0))
    }

    /// The white sheet that holds every tag with the margin `vservoctl tag` prints round a tag alone (the
    /// union of the tags' sheets).
    pub fn sheet_extent_in_board(&self) -> [Point2<f64>; 2] {
        let mut low = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut high = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for tag in self.tags() {
            let [a, b] = tag.sheet_extent_in_board();
            low = Point2::new(low.x.min(a.x), low.y.min(a.y));
            high = Point2::new(high.x.max(b.x), high.y.max(b.y));
        }
        [low, high]
    }

    /// The bundle with the tags of `hidden` (bit k for tag k) covered whole by white patches: a scenario's
    /// occlusion. `None` when every tag is covered.
    pub fn with_tags_covered(&self, hidden: u8) -> Option<TagBundle> {
        let kept = self.tags().iter().enumerate().filter(|(k, _)| *k >= 8 || hidden & (1 << k) == 0);
        let mut tags = [self.tags[0]; MAX_BUNDLE_TAGS];
        let mut len = 0;
        for (_, tag) in kept {
            tags[len] = *tag;
            len += 1;
        }
        (len > 0).then_some(TagBundle { tags, len: len as u8 })
    }

    /// Whether a point of the board plane is on a black cell of one of the tags; `None` beside every black
    /// square.
    pub fn is_black_at(&self, x_m: f64, y_m: f64) -> Option<bool> {
        self.tags().iter().find_map(|tag| tag.is_black_at(x_m, y_m))
    }
}

/// Whether two tags' black squares, each grown by its white border of one cell, meet.
fn too_near(a: &AprilTag, b: &AprilTag) -> bool {
    let cell = a.size_m().max(b.size_m()) / f64::from(tag36h11::WIDTH_AT_BORDER);
    let half_sizes = 0.5 * (a.size_m() + b.size_m());
    let gap = |d: f64| d.abs() - half_sizes;
    let (ca, cb) = (a.centre_in_board(), b.centre_in_board());
    // a nanometre's grace: a gap written as exactly one cell is one, whatever the rounding
    let short = |d: f64| gap(d) < cell - 1e-9;
    short(ca.x - cb.x) && short(ca.y - cb.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tag(id: u32, size_m: f64, x: f64, y: f64) -> AprilTag {
        AprilTag::tag36h11(id, size_m, Point2::new(x, y)).expect("an id")
    }

    /// Four tags of 60 mm, 20 mm apart: the outer corners are the tags' outer corners.
    fn two_by_two() -> TagBundle {
        TagBundle::new(&[
            tag(0, 0.06, -0.04, 0.04),
            tag(1, 0.06, 0.04, 0.04),
            tag(2, 0.06, 0.04, -0.04),
            tag(3, 0.06, -0.04, -0.04),
        ])
        .expect("a bundle")
    }

    #[test]
    fn the_outer_corners_are_the_outer_tags_corners_in_the_tag_order() {
        let bundle = two_by_two();
        let outer = bundle.outer_corners_in_board();
        // corner k of tag k is the bundle's corner k
        for (k, tag) in bundle.tags().iter().enumerate() {
            assert!((outer[k] - tag.corners_in_board()[k]).norm() < 1e-15, "corner {k}");
        }
        let one = TagBundle::new(&[tag(5, 0.1, 0.02, -0.03)]).expect("one tag");
        assert_eq!(one.outer_corners_in_board(), tag(5, 0.1, 0.02, -0.03).corners_in_board());
    }

    #[test]
    fn bad_bundles_are_refused_and_say_why() {
        assert_eq!(TagBundle::new(&[]), Err(BundleError::Count(0)));
        let nine: Vec<AprilTag> = (0..9).map(|i| tag(i, 0.01, f64::from(i) * 0.1, 0.0)).collect();
        assert_eq!(TagBundle::new(&nine), Err(BundleError::Count(9)));
        let repeated = TagBundle::new(&[tag(4, 0.05, 0.0, 0.0), tag(4, 0.05, 0.2, 0.0)]);
        assert_eq!(repeated, Err(BundleError::RepeatedId { id: 4, first: 1, second: 2 }));
        // 60 mm tags 66 mm apart: 6 mm of white between them, less than a cell (7.5 mm)
        let touching = TagBundle::new(&[tag(1, 0.06, 0.0, 0.0), tag(2, 0.06, 0.066, 0.01)]);
        assert_eq!(touching, Err(BundleError::Overlap { first: 1, second: 2 }));
        assert!(TagBundle::new(&[tag(1, 0.06, 0.0, 0.0), tag(2, 0.06, 0.0675, 0.01)]).is_ok());
        assert!(TagBundle::new(&[tag(1, 0.06, 0.0, 0.0), tag(2, 0.06, 0.05, 0.07)]).is_ok());
    }

    #[test]
    fn a_covered_tag_is_gone_and_the_rest_keep_their_order() {
        let bundle = two_by_two();
        let covered = bundle.with_tags_covered(0b0010).expect("three left");
        let ids: Vec<u32> = covered.tags().iter().map(AprilTag::id).collect();
        assert_eq!(ids, [0, 2, 3]);
        assert_eq!(covered.is_black_at(0.04, 0.04 - 0.029), None, "tag 1's border is white");
        assert_eq!(bundle.is_black_at(0.04, 0.04 - 0.029), Some(true));
        assert!(bundle.with_tags_covered(0b1111).is_none());
    }
}
