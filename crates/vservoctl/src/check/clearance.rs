//! The preflight's judgement of the collision guard (`[collision]`): the nearest checked distance with the arm
//! where it is and along the first twist's frame (the cell's own rmrc from the joints now), against the guard's
//! stop distance. A cell whose start is already inside it is refused: the guard would stop its first motion.

use serde_json::{Value, json};
use vservo_cell::Cell;

use super::first_twist::first_motion;
use super::verdicts::{Line, Observed};

/// The nearest distance is looked for within this (m).
const LOOKED_WITHIN_M: f64 = 10.0;

/// Where the arm is, and over the first twist's frame, every checked distance is above the stop distance.
pub fn clearance(observed: &Observed, cell: &Cell) -> Line {
    let name = "clearance";
    let Some(guard) = cell.guard() else {
        return Line::new(
            name,
            true,
            "no collision guard ([collision] not given): nothing keeps the arm off what stands around it"
                .to_string(),
            json!({ "guard": false }),
        );
    };
    let Some(state) = observed.newest_state() else {
        return Line::new(
            name,
            false,
            "no joint state: the arm's place is not known".to_string(),
            Value::Null,
        );
    };
    let mut guard = guard.clone();
    let arm = cell.arm();
    let mut nearest = |q: &vservo_arm::JointVector| {
        guard.nearest(&arm.placement(q), LOOKED_WITHIN_M).map(|(between, d)| {
            let (first, second) = guard.names(between);
            (d, [first.to_string(), second.to_string()])
        })
    };
    let Some((now_m, [first, second])) = nearest(&state.q) else {
        return Line::new(name, true, "nothing within 10 m".to_string(), json!({ "guard": true }));
    };
    let along = first_motion(observed, cell).and_then(|motion| {
        motion
            .path
            .iter()
            .filter_map(|q| nearest(q).map(|(d, [a, b])| (d, format!("{a} – {b}"))))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    });
    let settings = cell.guard().map(|g| g.settings()).expect("a guard");
    let stop_m = settings.stop_distance_m;
    let pass = now_m >= stop_m && along.as_ref().is_none_or(|(d, _)| *d >= stop_m);
    let along_text = along.as_ref().map_or(String::from("; no first twist to follow"), |(d, between)| {
        format!(", {d:.3} m along the first twist's frame ({between})")
    });
    let verdict = if now_m < stop_m {
        "; the arm is already inside the stop distance: move it away (`vservoctl move-joints --out-of-hold`) first"
    } else if !pass {
        "; the first twist would bring it inside the stop distance, and the guard would stop it"
    } else {
        ""
    };
    Line::new(
        name,
        pass,
        format!(
            "nearest {first} – {second} {now_m:.3} m now{along_text} (stop {stop_m} m, slowdown {} m){verdict}",
            settings.slowdown_distance_m
        ),
        json!({
            "guard": true,
            "now_m": now_m,
            "between": [first, second],
            "along_first_frame_m": along.as_ref().map(|(d, _)| d),
            "stop_distance_m": stop_m,
            "slowdown_distance_m": settings.slowdown_distance_m,
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::super::verdicts::fixtures::{observed, ur5e};
    use super::*;
    use vservo_config::{Obstacle, Solid};

    /// A table 20 mm (then 200 mm) below the camera at the desired joints, where the fixtures hold the arm.
    fn with_table_below_camera_m(gap_m: f64) -> vservo_config::Config {
        let mut config = ur5e();
        let camera =
            config.cell.arm.base_from_tool(&config.cell.desired.joints) * config.cell.tool_from_camera;
        let under = camera.translation.vector - nalgebra::Vector3::new(0.0, 0.0, gap_m + 0.02);
        let collision = config.cell.collision.as_mut().expect("the UR5e file's guard");
        collision.obstacles.push(Obstacle {
            name: "table".to_string(),
            solid: Solid::Box { size_m: [0.3, 0.3, 0.04] },
            base_from_obstacle: nalgebra::IsometryMatrix3::from_parts(
                under.into(),
                nalgebra::Rotation3::identity(),
            ),
        });
        config
    }

    #[test]
    fn a_start_inside_the_stop_distance_is_refused_and_one_clear_of_it_passes() {
        let near = with_table_below_camera_m(0.02);
        let line = clearance(&observed(&near), &Cell::new(&near.cell).expect("the cell"));
        assert!(
            !line.pass && line.text.contains("camera – table") && line.text.contains("inside"),
            "{}",
            line.text
        );
        let clear = with_table_below_camera_m(0.2);
        let line = clearance(&observed(&clear), &Cell::new(&clear.cell).expect("the cell"));
        assert!(line.pass, "{}", line.text);
        assert!(line.values["now_m"].as_f64().is_some_and(|d| d >= 0.03), "{}", line.values);
        let mut without = ur5e();
        without.cell.collision = None;
        let line = clearance(&observed(&without), &Cell::new(&without.cell).expect("the cell"));
        assert!(line.pass && line.text.contains("no collision guard"), "{}", line.text);
    }
}
