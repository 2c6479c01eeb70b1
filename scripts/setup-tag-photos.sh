#!/usr/bin/env bash
# Real photographs of tag36h11 tags with the AprilTag C library's own expected detections, for the detector's tests
# and benchmark (docs/VISION.md, "Real photographs"): AprilRobotics' test data (three photographs from NASA's
# Swarmathon at KSC, CC BY-SA 2.0, and the C library's detections at full resolution as its own test expects them),
# as the PyPI package apriltag-python 3.4.5 ships them in its source distribution. Into target/tag-photos/ (or the
# folder given), with the data's README; nothing of it is committed. Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."
dest="${1:-target/tag-photos}"
[ -f "$dest/MANIFEST" ] && exit 0
python=target/python-venv/bin/python
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# only this package as its source (the build tools it names come as wheels); no dependency is installed
"$python" -m pip download -q --no-deps --no-binary apriltag-python apriltag-python==3.4.5 -d "$work" >&2
tar -xzf "$work/apriltag_python-3.4.5.tar.gz" -C "$work"
data="$work/apriltag_python-3.4.5/src/apriltag/apriltag/test/data"
mkdir -p "$dest"
cp "$data"/*.jpg "$data"/*.txt "$dest/"
cp "$data/README.md" "$dest/README-data.md"
cp "$work/apriltag_python-3.4.5/src/apriltag/apriltag/LICENSE.md" "$dest/LICENSE-apriltag.md"
# what is here, from where: the last file written, so that a broken copy is made again
{
    echo "source: PyPI apriltag-python 3.4.5 (sdist), src/apriltag/apriltag/test/data (AprilRobotics/apriltag test data)"
    echo "images: CC BY-SA 2.0 (README-data.md); detections: the C library's own test (BSD-2-Clause, LICENSE-apriltag.md)"
    (cd "$dest" && sha256sum ./*.jpg ./*.txt)
} > "$dest/MANIFEST"
echo "setup-tag-photos: $(ls "$dest"/*.jpg | wc -l) photographs in $dest" >&2
