#!/usr/bin/env bash
# The effect of a calibration, side by side (docs/REPRODUCTION.md, "Calibration"): config/calibration-demo.toml's
# simulated cell is calibrated (`vservoctl calibrate --lockstep`), then the robust law tracks the board on a
# circle (4 cm at 5 rev/min, the target's motion fed forward) three times in the lockstep simulator: believing
# the configured (nominal, wrong) camera, the calibrated one, and the truth; and three times more with two of the
# tag's corners covered for 1.5 s after the first revolution (the tag is then lost: the robust law steers the
# camera back the way the target was last seen to go, through the camera's pose from the joints and
# tool_from_camera). Prints one line per run and, last, one JSON object with the calibration's errors and each
# run's tracking and reacquiring errors (scripts/calibration-effect.py).
# usage: scripts/calibration-effect.sh [--bin-dir DIR]   (default: a release build)
set -euo pipefail
cd "$(dirname "$0")/.."
bin_dir=""
if [ "${1:-}" = "--bin-dir" ]; then bin_dir=$2; fi
if [ -z "$bin_dir" ]; then
    cargo build --release --locked -q -p vservoctl
    bin_dir=target/release
fi
scripts/setup.sh >/dev/null
out=target/calibration-effect
rm -rf "$out"
mkdir -p "$out"
demo="$(pwd)/config/calibration-demo.toml"
"$bin_dir/vservoctl" calibrate --config "$demo" --lockstep --json --python target/python-venv/bin/python \
    --out "$out/calibration.yaml" > "$out/calibration.json"
cat > "$out/nominal.toml" <<TOML
extends = "$demo"
[scenario]
duration_s = 30.0
initial_camera_translation_m = [0.0, 0.0, 0.0]
initial_camera_rotation_deg = [0.0, 0.0, 0.0]
object_motion = "circle"
circle_radius_m = 0.04
circle_rev_per_min = 5.0
TOML
cat > "$out/calibrated.toml" <<TOML
extends = "nominal.toml"
[camera]
calibration_file = "calibration.yaml"
TOML
# the truth: config/calibration-demo.toml's [camera.truth], believed
cat > "$out/truth.toml" <<TOML
extends = "nominal.toml"
[camera]
fx_px = 612.0
fy_px = 618.12
principal_point_px = [325.0, 234.0]
width_px = 640
height_px = 480
distortion = [-0.23, 0.07, 0.0, 0.0, 0.0]
tool_from_camera = { translation_m = [0.003, -0.004, 0.08], rotation_rpy_deg = [1.2, 1.6, -90.0] }
TOML
for belief in nominal calibrated truth; do
    cat > "$out/$belief-covered.toml" <<TOML
extends = "$belief.toml"
[scenario]
occlusions = [{ mark = 1, from_s = 14.0, until_s = 15.5 }, { mark = 2, from_s = 14.0, until_s = 15.5 }]
TOML
    for run in "$belief" "$belief-covered"; do
        "$bin_dir/vservoctl" sim --config "$out/$run.toml" --out "$out/$run" >/dev/null
        echo "$run: $(tr -d '\n' < "$out/$run/summary.json" | tr -s ' ')"
    done
    "$bin_dir/vservoctl" gains --config "$out/$belief.toml" --json > "$out/$belief-gains.json"
done
target/python-venv/bin/python scripts/calibration-effect.py "$out"
