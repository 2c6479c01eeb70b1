//! `[calibration]`: the calibration board's grid, the poses `vservoctl calibrate` takes around it, and the
//! board printed on the simulated object.

use nalgebra::Point2;
use vservo_scene::{Board, TagGrid, TagGridError, Target};

use super::checker::Checker;
use crate::raw::{RawCalibration, RawObject};
use crate::{CalibrationSettings, ConfigError};

/// The grid (1–64 rows and columns, tags of 1 mm to 1 m, gaps from the tag's white border to its size, ids
/// within tag36h11's), 6 to 40 poses, a tilt of 5° to 60° and a distance of 0.1 to 3 m.
pub fn settings(check: &Checker, c: &RawCalibration) -> Result<CalibrationSettings, ConfigError> {
    let rows = check.whole("calibration.board_rows", c.board_rows, 1u32, 64, "from 1 to 64")?;
    let columns = check.whole("calibration.board_columns", c.board_columns, 1u32, 64, "from 1 to 64")?;
    let first_id = check.whole("calibration.first_id", c.first_id, 0u32, 586, "a tag36h11 id (0 to 586)")?;
    let board = TagGrid::new(rows, columns, c.tag_size_m, c.gap_m, first_id).map_err(|e| {
        let key = match e {
            TagGridError::Shape { .. } => "calibration.board_rows",
            TagGridError::Size { .. } => "calibration.tag_size_m",
            TagGridError::Id(_) => "calibration.first_id",
        };
        check.invalid(
            key,
            format!("{} × {} tags of {} m, {} m apart", rows, columns, c.tag_size_m, c.gap_m),
            e.to_string(),
        )
    })?;
    let poses = check.whole("calibration.poses", c.poses, 6usize, 40, "from 6 to 40")?;
    let tilt_rad = check.within("calibration.tilt_deg", c.tilt_deg, 5.0, 60.0, "°")?.to_radians();
    let distance_m =
        c.distance_m.map(|d| check.within("calibration.distance_m", d, 0.1, 3.0, "m")).transpose()?;
    Ok(CalibrationSettings { board, poses, tilt_rad, distance_m, output_file: c.output_file.clone() })
}

/// `calibration.printed_on_object`: the simulated board shows the grid, centred on the board frame's origin.
/// The board must hold it, and the target be an AprilTag that is one of the grid's tags (the same id, size
/// and place), so that the servo's target and the calibration board are one print.
pub fn printed(
    check: &Checker,
    c: &RawCalibration,
    o: &RawObject,
    board: &Board,
    grid: TagGrid,
) -> Result<TagGrid, ConfigError> {
    let [low, high] = grid.extent_in_board();
    let [board_low, board_high] = board.extent_in_board;
    // to a nanometre: a sheet written to the grid's extent holds it
    const ROUNDING_M: f64 = 1e-9;
    let outside = low.x < board_low.x - ROUNDING_M
        || low.y < board_low.y - ROUNDING_M
        || high.x > board_high.x + ROUNDING_M
        || high.y > board_high.y + ROUNDING_M;
    if outside {
        return Err(check.invalid(
            "object.board_extent_m",
            o.board_extent_m.map_or_else(
                || format!("{:?} (the tag's own sheet)", board.extent_in_board),
                |e| format!("{e:?}"),
            ),
            format!(
                "must hold the calibration board printed on it, from [{:.4}, {:.4}] to [{:.4}, {:.4}] m",
                low.x, low.y, high.x, high.y
            ),
        ));
    }
    let printed_in_the_grid = |tag: &vservo_scene::AprilTag| {
        grid.tag_with_id(tag.id()).is_some_and(|printed| {
            printed.size_m() == tag.size_m()
                && (printed.centre_in_board() - tag.centre_in_board()).norm() < 1e-9
        })
    };
    let one_of_the_grid = match board.target {
        Target::AprilTag(_) | Target::Bundle(_) => board.target_tags().iter().all(printed_in_the_grid),
        Target::Marks => false,
    };
    if !one_of_the_grid {
        let at = |id: u32| grid.tag_with_id(id).map(|t| t.centre_in_board()).unwrap_or(Point2::origin());
        let first = grid.tags().next().map(|t| t.id()).unwrap_or(0);
        return Err(check.invalid(
            "calibration.printed_on_object",
            c.printed_on_object,
            format!(
                "the target must then be one of the grid's tags, or a bundle of them ([target] kind = \"apriltag\" with its id, \
                 tag_size_m = {} and its centre, e.g. id {first} at [{:.4}, {:.4}])",
                grid.tag_size_m(),
                at(first).x,
                at(first).y
            ),
        ));
    }
    Ok(grid)
}
