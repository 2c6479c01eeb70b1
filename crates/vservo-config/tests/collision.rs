//! `[collision]` and `[[scene.obstacles]]`: what is refused, naming the key, and what a valid scene gives.

#[allow(dead_code)] // `with` is the other test files'
mod common;

use common::{DEFAULT, refused};
use vservo_config::Config;
use vservo_settings::collision::Solid;

fn with_scene(extra: &str) -> String {
    format!("{DEFAULT}\n{extra}")
}

const TABLE: &str = "[[scene.obstacles]]\nname = \"table\"\nshape = \"box\"\nsize_m = [1.0, 0.8, 0.04]\ntranslation_m = [0.5, 0.0, -0.02]\n";

#[test]
fn a_scene_with_the_guard_gives_its_obstacles_and_distances() {
    let text = with_scene(&format!(
        "[collision]\nstop_distance_m = 0.02\ncamera_box_m = [0.05, 0.05, 0.04]\n{TABLE}\
         [[scene.obstacles]]\nname = \"post\"\nshape = \"cylinder\"\nradius_m = 0.05\nlength_m = 0.6\n\
         translation_m = [0.3, 0.4, 0.3]\n[[scene.obstacles]]\nname = \"floor\"\nshape = \"plane\"\n"
    ));
    let config = Config::from_toml(&text, "t.toml").expect("valid");
    let collision = config.cell.collision.expect("the guard");
    assert_eq!((collision.slowdown_distance_m, collision.stop_distance_m), (0.10, 0.02));
    assert!(collision.arm_urdf.is_none(), "the PUMA 560 has no URDF shapes");
    let solids: Vec<Solid> = collision.obstacles.iter().map(|o| o.solid).collect();
    assert_eq!(
        solids,
        [
            Solid::Box { size_m: [1.0, 0.8, 0.04] },
            Solid::Cylinder { radius_m: 0.05, length_m: 0.6 },
            Solid::HalfSpace
        ]
    );
    assert_eq!(collision.obstacles[1].base_from_obstacle.translation.vector.y, 0.4);
}

#[test]
fn the_guard_is_off_without_its_section_and_obstacles_alone_are_refused() {
    assert!(Config::from_toml(DEFAULT, "t.toml").expect("the default").cell.collision.is_none());
    let error = refused(&with_scene(TABLE)).to_string();
    assert!(error.contains("scene.obstacles") && error.contains("[collision]"), "{error}");
}

#[test]
fn bad_distances_shapes_names_and_workspaces_are_refused_by_key() {
    let cases = [
        (
            "[collision]\nslowdown_distance_m = 0.02\nstop_distance_m = 0.05\n",
            "collision.slowdown_distance_m",
        ),
        ("[collision]\nstop_distance_m = -0.01\n", "collision.stop_distance_m"),
        ("[collision]\nworkspace_min_m = [0.0, 0.0, 0.0]\n", "collision.workspace_min_m"),
        (
            "[collision]\nworkspace_min_m = [0.0, 0.0, 0.0]\nworkspace_max_m = [1.0, 1.0, 0.0]\n",
            "collision.workspace_max_m",
        ),
        ("[collision]\ncamera_box_m = [0.05, 0.0, 0.04]\n", "collision.camera_box_m"),
        (
            "[collision]\n[[scene.obstacles]]\nname = \"t\"\nshape = \"box\"\nsize_m = [1.0, 1.0, 1.0]\nradius_m = 0.1\n",
            "scene.obstacles[0].radius_m",
        ),
        (
            "[collision]\n[[scene.obstacles]]\nname = \"t\"\nshape = \"sphere\"\n",
            "scene.obstacles[0].radius_m",
        ),
        (
            "[collision]\n[[scene.obstacles]]\nname = \"t\"\nshape = \"sphere\"\nradius_m = 0.1\ntranslation_m = [99.0, 0.0, 0.0]\n",
            "scene.obstacles[0].translation_m",
        ),
        (
            "[collision]\n[[scene.obstacles]]\nname = \"a\"\nshape = \"plane\"\n[[scene.obstacles]]\nname = \"a\"\nshape = \"plane\"\n",
            "scene.obstacles[1].name",
        ),
        ("[collision]\n[[scene.obstacles]]\nname = \"a\"\nshape = \"cone\"\n", "shape"),
    ];
    for (extra, key) in cases {
        let error = refused(&with_scene(extra)).to_string();
        assert!(error.contains(key), "{extra:?}: {error}");
    }
}
