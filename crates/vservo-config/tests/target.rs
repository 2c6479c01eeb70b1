//! `[target]`: the default is the paper's marks; an AprilTag's corners become the four marks and the desired
//! features follow; a bad family, id or size is refused naming its key.

use vservo_config::{Config, ConfigError};
use vservo_scene::Target;

const APRILTAG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-apriltag.toml");
const DEFAULT: &str = include_str!("../../../config/vservo.toml");

/// The default file with a `[target]` section appended.
fn default_with_target(target: &str) -> Result<Config, ConfigError> {
    Config::from_toml(&format!("{DEFAULT}\n[target]\n{target}\n"), "test.toml")
}

#[test]
fn the_default_target_is_the_marks() {
    let config = Config::from_toml(DEFAULT, "vservo.toml").expect("valid");
    assert_eq!(config.cell.board.target, Target::Marks);
}

#[test]
fn the_apriltag_cell_servoes_on_the_tags_corners_in_the_tags_order() {
    let config = Config::load(APRILTAG).expect("config/vservo-apriltag.toml is valid");
    let tag = config.cell.board.apriltag().expect("an AprilTag target");
    assert_eq!(tag.id(), 3);
    assert_eq!(config.cell.board.marks_in_board, tag.corners_in_board());
    // 0.5 m fronto-parallel in front of a 0.16 m tag with fx = 600 px, fy = 606 px: 192 × 193.92 px (the
    // pinhole's: ξ_d is undistorted), centred at the principal point (322, 237); bottom left, bottom right,
    // top right, top left
    let expected = [226.0, 333.96, 418.0, 333.96, 418.0, 140.04, 226.0, 140.04];
    for (f, e) in config.cell.desired.features.iter().zip(expected) {
        assert!((f - e).abs() < 1e-9, "{}", config.cell.desired.features);
    }
    assert_eq!((config.cell.camera.width_px(), config.cell.camera.height_px()), (640, 480));
}

#[test]
fn another_family_is_refused_naming_it() {
    let error = default_with_target("kind = \"apriltag\"\nfamily = \"tag25h9\"").expect_err("refused");
    let message = error.to_string();
    assert!(message.contains("family") && message.contains("tag25h9"), "{message}");
}

#[test]
fn bad_ids_sizes_and_placements_are_refused_naming_their_key() {
    let cases = [
        ("kind = \"apriltag\"\nid = 587\ntag_size_m = 0.05\ncentre_in_board_m = [0.0, -0.135]", "target.id"),
        ("kind = \"apriltag\"\nid = -1\ntag_size_m = 0.05\ncentre_in_board_m = [0.0, -0.135]", "target.id"),
        (
            "kind = \"apriltag\"\nid = 1\ntag_size_m = 0.0\ncentre_in_board_m = [0.0, -0.135]",
            "target.tag_size_m",
        ),
        // 0.2 m with its margin is 0.25 m: more than the board's 0.21 m height
        (
            "kind = \"apriltag\"\nid = 1\ntag_size_m = 0.2\ncentre_in_board_m = [0.0, -0.135]",
            "object.board_extent_m",
        ),
        (
            "kind = \"apriltag\"\nid = 1\ntag_size_m = 0.05\ncentre_in_board_m = [0.5, -0.135]",
            "object.board_extent_m",
        ),
        ("kind = \"tags\"", "kind"),
    ];
    for (target, key) in cases {
        let error = default_with_target(target).expect_err("refused");
        assert!(error.to_string().contains(key), "{target}: {error}");
    }
    default_with_target("kind = \"apriltag\"\nid = 1\ntag_size_m = 0.05\ncentre_in_board_m = [0.0, -0.135]")
        .expect("a small tag on the board is taken");
}

/// An overlay of `config/vservo.toml` (in a folder of its own) with `text`, loaded by its path.
fn overlay_of_the_default(name: &str, text: &str) -> Result<Config, ConfigError> {
    let dir = std::env::temp_dir().join(format!("vservo-target-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a folder");
    let base = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml");
    let path = dir.join("cell.toml");
    std::fs::write(&path, format!("extends = {base:?}\n{text}")).expect("written");
    let loaded = Config::load(&path);
    let _ = std::fs::remove_dir_all(&dir);
    loaded
}

/// A newcomer's tag away from the paper's board: with no board written for it, the board is the tag's own sheet
/// (the square and a quarter of its edge all round, as `vservoctl tag` prints it), not the base's board, which
/// would not hold it.
#[test]
fn a_tag_without_a_board_of_its_own_is_on_its_own_sheet() {
    let tag = "[desired.camera_from_board]\ntranslation_m = [-0.3, -0.3, 0.5]\nrotation_rpy_deg = [0.0, 0.0, 0.0]\n\
               [target]\nkind = \"apriltag\"\nid = 3\ntag_size_m = 0.08\ncentre_in_board_m = [0.3, 0.3]\n";
    let config = overlay_of_the_default("derived", tag).expect("the tag's own sheet holds it");
    let [low, high] = config.cell.board.extent_in_board;
    for (got, want) in [(low.x, 0.24), (low.y, 0.24), (high.x, 0.36), (high.y, 0.36)] {
        assert!((got - want).abs() < 1e-12, "{:?}", config.cell.board.extent_in_board);
    }
    // a board written with the tag is taken as written, and refused when it does not hold the tag
    let written = format!("{tag}[object]\nboard_extent_m = [[0.2, 0.2], [0.5, 0.45]]\n");
    let config = overlay_of_the_default("written", &written).expect("valid");
    assert_eq!((config.cell.board.extent_in_board[1].x, config.cell.board.extent_in_board[1].y), (0.5, 0.45));
    let short = format!("{tag}[object]\nboard_extent_m = [[0.2, 0.2], [0.32, 0.45]]\n");
    let error = overlay_of_the_default("short", &short).expect_err("refused").to_string();
    assert!(error.contains("object.board_extent_m") && error.contains("white margin"), "{error}");
}

/// A file over the one that set the tag inherits the board written with it (config/vservo-apriltag.toml keeps
/// the paper's board).
#[test]
fn a_board_written_with_the_tag_is_inherited() {
    let dir = std::env::temp_dir().join(format!("vservo-target-{}-inherited", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a folder");
    let path = dir.join("cell.toml");
    std::fs::write(&path, format!("extends = {APRILTAG:?}\n[target]\nid = 5\n")).expect("written");
    let config = Config::load(&path).expect("valid");
    let _ = std::fs::remove_dir_all(&dir);
    let paper = Config::from_toml(DEFAULT, "vservo.toml").expect("valid");
    assert_eq!(config.cell.board.extent_in_board, paper.cell.board.extent_in_board);
    assert_eq!(config.cell.board.apriltag().map(|t| t.id()), Some(5));
}
