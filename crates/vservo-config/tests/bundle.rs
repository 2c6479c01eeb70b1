//! `[target] kind = "bundle"`: several tags on one board; the four marks are the corners of the box that holds
//! their black squares, and the desired features follow; a bad list, id, size, placement or pair of tags is
//! refused naming its key.

use vservo_config::{Config, ConfigError};

const BUNDLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-bundle.toml");
const DEFAULT: &str = include_str!("../../../config/vservo.toml");

/// The default file (the paper's board) with a bundle of `tags` as its target.
fn default_with_tags(tags: &str) -> Result<Config, ConfigError> {
    Config::from_toml(&format!("{DEFAULT}\n[target]\nkind = \"bundle\"\ntags = [{tags}]\n"), "test.toml")
}

/// A 40 mm tag at (x, y).
fn tag(id: i64, x: f64, y: f64) -> String {
    format!("{{ id = {id}, tag_size_m = 0.04, centre_in_board_m = [{x}, {y}] }}")
}

#[test]
fn the_bundle_cell_servoes_on_the_outer_corners_of_its_tags() {
    let config = Config::load(BUNDLE).expect("config/vservo-bundle.toml is valid");
    let bundle = config.cell.board.bundle().expect("a bundle target");
    let ids: Vec<u32> = bundle.tags().iter().map(|t| t.id()).collect();
    assert_eq!(ids, [10, 11, 12, 13]);
    assert_eq!(config.cell.board.marks_in_board, bundle.outer_corners_in_board());
    // the bundle spans 0.16 m round the same centre as config/vservo-apriltag.toml's 0.16 m tag, so its outer
    // corners image where that tag's corners do at the same desired pose
    let expected = [226.0, 333.96, 418.0, 333.96, 418.0, 140.04, 226.0, 140.04];
    for (f, e) in config.cell.desired.features.iter().zip(expected) {
        assert!((f - e).abs() < 1e-9, "{}", config.cell.desired.features);
    }
}

#[test]
fn bad_bundles_are_refused_naming_their_key() {
    let nine: Vec<String> = (0..9).map(|i| tag(i, -0.14 + 0.03 * i as f64, -0.1)).collect();
    let cases = [
        (String::new(), "target.tags"),
        (nine.join(", "), "1 to 8 tags"),
        (format!("{}, {}", tag(1, -0.05, -0.1), tag(587, 0.05, -0.1)), "target.tags[1].id"),
        (
            format!(
                "{}, {{ id = 2, tag_size_m = 0.0, centre_in_board_m = [0.0, -0.1] }}",
                tag(1, -0.05, -0.1)
            ),
            "target.tags[1].tag_size_m",
        ),
        (format!("{}, {}", tag(4, -0.05, -0.1), tag(4, 0.05, -0.1)), "both have id 4"),
        // 40 mm tags 43 mm apart: 3 mm of white between them, less than a cell (5 mm)
        (format!("{}, {}", tag(1, 0.0, -0.1), tag(2, 0.043, -0.1)), "white border"),
        // off the paper's board
        (format!("{}, {}", tag(1, 0.0, -0.1), tag(2, 0.5, -0.1)), "object.board_extent_m"),
        ("{ id = 1, tag_size_m = 0.04, centre_in_board_m = [0.0, -0.1], roll = 1 }".into(), "roll"),
    ];
    for (tags, key) in cases {
        let error = default_with_tags(&tags).expect_err("refused");
        assert!(error.to_string().contains(key), "{tags}: {error}");
    }
    let taken = default_with_tags(&format!("{}, {}", tag(1, 0.0, -0.1), tag(2, 0.045, -0.1)));
    taken.expect("two tags a cell apart are taken");
}
