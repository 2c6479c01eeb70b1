//! `[object]` and `[target]`: the board and what is printed on it (its marks, or an AprilTag).

use nalgebra::{Point2, Point3};
use vservo_scene::{AprilTag, Board, MARKS, MAX_BUNDLE_TAGS, TagBundle, Target, tag36h11};

use super::checker::Checker;
use crate::ConfigError;
use crate::raw::{RawObject, RawTagFamily, RawTarget, RawTargetKind};

/// The board: four marks, further apart than a mark's diameter, each whole on the board; or, with
/// `[target] kind = "apriltag"`, one tag with its white margin on the board (the marks are then its corners
/// and `object.marks_in_board_m` is not used).
pub fn board(check: &Checker, o: &RawObject, target: &RawTarget) -> Result<Board, ConfigError> {
    let mark_diameter_m = check.within("object.mark_diameter_m", o.mark_diameter_m, 0.001, 1.0, "m")?;
    match target.kind {
        RawTargetKind::AprilTag => {
            let tag = apriltag(check, target)?;
            let extent_in_board =
                tags_extent(check, o, std::slice::from_ref(&tag), tag.sheet_extent_in_board())?;
            return Ok(Board::with_apriltag(tag, extent_in_board));
        }
        RawTargetKind::Bundle => {
            let bundle = bundle(check, target)?;
            let extent_in_board = tags_extent(check, o, bundle.tags(), bundle.sheet_extent_in_board())?;
            return Ok(Board::with_bundle(bundle, extent_in_board));
        }
        RawTargetKind::Marks => {}
    }
    let marks_in_board = marks(check, o)?;
    marks_apart(check, o, &marks_in_board, mark_diameter_m)?;
    let extent_in_board = extent(check, o, &marks_in_board, mark_diameter_m)?;
    Ok(Board {
        marks_in_board,
        mark_diameter_m,
        extent_in_board,
        target: Target::Marks,
        calibration_grid: None,
    })
}

/// `[target]` for an AprilTag: the family (tag36h11 only, the parser refuses any other), an id of the
/// family, the black square's edge within 5 mm–2 m and its centre within ±5 m.
fn apriltag(check: &Checker, target: &RawTarget) -> Result<AprilTag, ConfigError> {
    let RawTagFamily::Tag36h11 = target.family;
    one_tag(check, "target.", target.id, target.tag_size_m, target.centre_in_board_m)
}

/// One tag's id, size and centre, checked as [`apriltag`] says, under the key prefix `at`.
fn one_tag(
    check: &Checker,
    at: &str,
    id: i64,
    size_m: f64,
    centre: [f64; 2],
) -> Result<AprilTag, ConfigError> {
    let last_id = tag36h11::CODES.len() as u32 - 1;
    let checked_id =
        check.whole(&format!("{at}id"), id, 0u32, last_id, &format!("tag36h11 has ids 0 to {last_id}"))?;
    let size_m = check.within(&format!("{at}tag_size_m"), size_m, 0.005, 2.0, "m")?;
    let [x, y] = check.all_within(&format!("{at}centre_in_board_m"), centre, -5.0, 5.0, "m")?;
    AprilTag::tag36h11(checked_id, size_m, Point2::new(x, y))
        .map_err(|e| check.invalid(&format!("{at}id"), id, e.to_string()))
}

/// `[target]` for a bundle: `tags`, 1 to 8 of them, each checked as one tag (`target.tags[k]`), no id twice and
/// no tag within another's white border.
fn bundle(check: &Checker, target: &RawTarget) -> Result<TagBundle, ConfigError> {
    let RawTagFamily::Tag36h11 = target.family;
    if !(1..=MAX_BUNDLE_TAGS).contains(&target.tags.len()) {
        return Err(check.invalid(
            "target.tags",
            format!("{} tags", target.tags.len()),
            format!(
                "a bundle lists 1 to {MAX_BUNDLE_TAGS} tags, {{ id, tag_size_m, centre_in_board_m }} each"
            ),
        ));
    }
    let mut tags = Vec::with_capacity(target.tags.len());
    for (k, raw) in target.tags.iter().enumerate() {
        tags.push(one_tag(
            check,
            &format!("target.tags[{k}]."),
            raw.id,
            raw.tag_size_m,
            raw.centre_in_board_m,
        )?);
    }
    TagBundle::new(&tags).map_err(|e| {
        let ids: Vec<u32> = tags.iter().map(AprilTag::id).collect();
        check.invalid("target.tags", format!("ids {ids:?}"), e.to_string())
    })
}

/// `object.board_extent_m` with tags: within ±5 m, min < max, holding every tag and its white margin (one
/// cell, an eighth of the black square, on every side: the detector needs it). Where none is written for the
/// tags (`layers::tag_board`), their own sheet (`sheet`: `AprilTag::sheet_extent_in_board` or the bundle's,
/// what `vservoctl tag` prints).
fn tags_extent(
    check: &Checker,
    o: &RawObject,
    tags: &[AprilTag],
    sheet: [Point2<f64>; 2],
) -> Result<[Point2<f64>; 2], ConfigError> {
    let Some([[x0, y0], [x1, y1]]) = o.board_extent_m else {
        return Ok(sheet);
    };
    let extent_ok = [x0, y0, x1, y1].iter().all(|v| v.is_finite() && v.abs() <= 5.0) && x0 < x1 && y0 < y1;
    let on_board = |tag: &AprilTag| {
        let reach =
            tag.size_m() * 0.5 * f64::from(tag36h11::TOTAL_WIDTH) / f64::from(tag36h11::WIDTH_AT_BORDER);
        let c = tag.centre_in_board();
        c.x - reach >= x0 && c.x + reach <= x1 && c.y - reach >= y0 && c.y + reach <= y1
    };
    if !extent_ok || !tags.iter().all(on_board) {
        return Err(check.invalid(
            "object.board_extent_m",
            format!("{:?}", o.board_extent_m),
            "must be [[x_min, y_min], [x_max, y_max]] within ±5 m with min < max, holding every tag whole with its \
             white margin of one cell",
        ));
    }
    Ok([Point2::new(x0, y0), Point2::new(x1, y1)])
}

/// `object.marks_in_board_m`: [`MARKS`] points within ±5 m.
fn marks(check: &Checker, o: &RawObject) -> Result<[Point3<f64>; MARKS], ConfigError> {
    let key = "object.marks_in_board_m";
    if o.marks_in_board_m.len() != MARKS {
        return Err(check.invalid(
            key,
            format!("{:?}", o.marks_in_board_m),
            format!("must list exactly {MARKS} marks, [x, y] each; it lists {}", o.marks_in_board_m.len()),
        ));
    }
    let mut marks_in_board = [Point3::origin(); MARKS];
    for (mark, written) in marks_in_board.iter_mut().zip(&o.marks_in_board_m) {
        let [x, y] = check.all_within(key, *written, -5.0, 5.0, "m")?;
        *mark = Point3::new(x, y, 0.0);
    }
    Ok(marks_in_board)
}

/// No two marks within a mark's diameter of each other.
fn marks_apart(
    check: &Checker,
    o: &RawObject,
    marks_in_board: &[Point3<f64>; MARKS],
    mark_diameter_m: f64,
) -> Result<(), ConfigError> {
    for i in 0..MARKS {
        for j in (i + 1)..MARKS {
            let gap = (marks_in_board[i] - marks_in_board[j]).norm();
            if gap <= mark_diameter_m {
                return Err(check.invalid(
                    "object.marks_in_board_m",
                    format!("{:?}", o.marks_in_board_m),
                    format!(
                        "marks {} and {} are {gap} m apart, no more than a mark's diameter",
                        i + 1,
                        j + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// `object.board_extent_m`: within ±5 m, min < max, holding every mark whole.
fn extent(
    check: &Checker,
    o: &RawObject,
    marks_in_board: &[Point3<f64>; MARKS],
    mark_diameter_m: f64,
) -> Result<[Point2<f64>; 2], ConfigError> {
    let [[x0, y0], [x1, y1]] = o.board_extent_m.ok_or_else(|| {
        check.invalid(
            "object.board_extent_m",
            "nothing",
            "must be given for a board of marks (only a tag's is derived)",
        )
    })?;
    let extent_ok = [x0, y0, x1, y1].iter().all(|v| v.is_finite() && v.abs() <= 5.0) && x0 < x1 && y0 < y1;
    let radius = 0.5 * mark_diameter_m;
    let marks_on_board = marks_in_board
        .iter()
        .all(|m| m.x - radius >= x0 && m.x + radius <= x1 && m.y - radius >= y0 && m.y + radius <= y1);
    if !extent_ok || !marks_on_board {
        return Err(check.invalid(
            "object.board_extent_m",
            format!("{:?}", o.board_extent_m),
            "must be [[x_min, y_min], [x_max, y_max]] within ±5 m with min < max, holding every mark whole",
        ));
    }
    Ok([Point2::new(x0, y0), Point2::new(x1, y1)])
}
