#!/usr/bin/env bash
# Installs what a fresh machine needs to build and test vservo. Safe to run again: it only adds what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
    echo "setup: cargo is missing; install Rust (rustup) first" >&2
    exit 1
fi
# rustfmt and clippy are checked by CI; add them when the toolchain lacks them
for component in rustfmt clippy; do
    if ! rustup component list --installed 2>/dev/null | grep -q "^${component}"; then
        rustup component add "${component}"
    fi
done

# the test runner (scripts/test.sh, .config/nextest.toml): cargo-nextest, built from crates.io where the machine lacks it
if ! cargo nextest --version >/dev/null 2>&1; then
    cargo install --locked cargo-nextest
fi

# The Python client (clients/python/) and its test need the iceoryx2 bindings from PyPI, in a venv of their own.
venv="target/python-venv"
if ! "${venv}/bin/python" -c 'import iceoryx2' >/dev/null 2>&1; then
    mkdir -p target
    rm -rf "${venv}"
    if ! python3 -m venv "${venv}" >/dev/null 2>&1; then
        # Debian and Ubuntu ship venv (ensurepip) as a package of its own
        sudo_if_needed=""
        [ "$(id -u)" -ne 0 ] && sudo_if_needed="sudo"
        version="$(python3 -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')"
        ${sudo_if_needed} apt-get install -y -qq "python${version}-venv" >/dev/null ||
            ${sudo_if_needed} apt-get install -y -qq python3-venv >/dev/null
        rm -rf "${venv}"
        python3 -m venv "${venv}"
    fi
    "${venv}/bin/pip" install -q iceoryx2==0.10.0
fi
# the recording and live-view tests read as a user's own tooling would: mcap with its protobuf decoder, and a
# WebSocket client, from PyPI
if ! "${venv}/bin/python" -c 'import mcap, mcap_protobuf, websockets' >/dev/null 2>&1; then
    "${venv}/bin/pip" install -q mcap==1.6.0 mcap-protobuf-support==0.6.0 websockets==17.4
fi

# the lens model's OpenCV reference (scripts/lens-reference.py writes the fixtures its tests read)
if ! "${venv}/bin/python" -c 'import cv2' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q opencv-python-headless==4.14.0.94
fi

# the tag detector's reference (crates/vservo-vision's tests, docs/VISION.md): the AprilTag C library as Python users
# run it (pupil-apriltags), and real photographs with the C library's own expected detections
if ! "${venv}/bin/python" -c 'import pupil_apriltags' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q pupil-apriltags==1.0.4.post11
fi
scripts/setup-tag-photos.sh

# `vservoctl calibrate`'s solver (clients/python/vservo_calibrate.py): OpenCV's calibration and hand-eye
# functions, SciPy's least squares for the joint refinement
if ! "${venv}/bin/python" -c 'import scipy' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q scipy==1.17.1
fi

# the ROS 2 bridge's tests (docs/ROS2.md): Eclipse Cyclone DDS as ROS 2 nodes speak it (the wheel bundles the C
# library), and the rosbags library that reads `vservoctl record --ros2` as ROS users' tooling does
if ! "${venv}/bin/python" -c 'import cyclonedds, rosbags' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q cyclonedds==11.0.1 rosbags==0.11.9
fi

# The PyBullet reference driver (clients/python/pybullet_driver.py, scripts/run-pybullet.sh) and the arms' URDFs
# it ships in pybullet_data (xArm6, Franka Panda: config/arms/ reads them through target/pybullet_data)
if ! "${venv}/bin/python" -c 'import pybullet' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q pybullet==3.2.7
fi
ln -sfn "$("${venv}/bin/python" -c 'import pybullet_data; print(pybullet_data.getDataPath())')" target/pybullet_data

# The collision model's reference (crates/vservo-collision's tests, scripts/collision-reference.py): PyPI coal 3.x,
# FCL's successor from the Pinocchio team. The UR5e's collision meshes (config/arms/ur5e.urdf reads them through
# target/airo_models): airo-models, MIT (its only dependency, xmltodict, is not needed for the files)
if ! "${venv}/bin/python" -c 'import coal' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q coal==3.0.3
fi
if ! "${venv}/bin/python" -c 'import importlib.util as u; assert u.find_spec("airo_models")' >/dev/null 2>&1; then
    "${venv}/bin/python" -m pip install -q --no-deps airo-models==0.0.12
fi
ln -sfn "$("${venv}/bin/python" -c 'import importlib.util as u, os; print(os.path.dirname(u.find_spec("airo_models").origin))')" target/airo_models

# `vservoctl top`'s test runs it in a terminal: tmux, from Debian
if ! command -v tmux >/dev/null 2>&1; then
    sudo_if_needed=""
    [ "$(id -u)" -ne 0 ] && sudo_if_needed="sudo"
    ${sudo_if_needed} apt-get install -y -qq tmux >/dev/null
fi

# The GStreamer camera driver (crates/vservo-camera-gst) builds against Debian's GStreamer (1.22 on Debian 12);
# its tests and scripts/run-rtp-camera.sh run videotestsrc, videoconvert, rawvideoparse (-base), the RTP and UDP
# elements (-good) and gst-launch-1.0 (-tools)
gst_packages=(libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev gstreamer1.0-plugins-base
    gstreamer1.0-plugins-good gstreamer1.0-tools)
missing=()
for package in "${gst_packages[@]}"; do
    dpkg-query -W -f='${Status}' "${package}" 2>/dev/null | grep -q "install ok installed" || missing+=("${package}")
done
if [ "${#missing[@]}" -gt 0 ]; then
    sudo_if_needed=""
    [ "$(id -u)" -ne 0 ] && sudo_if_needed="sudo"
    # a fresh machine's package lists can be older than its installed libraries (the -dev packages then
    # depend on versions the lists do not know): refresh them first
    ${sudo_if_needed} apt-get update -qq
    DEBIAN_FRONTEND=noninteractive ${sudo_if_needed} apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# The MuJoCo reference driver (clients/python/mujoco_driver.py, scripts/run-mujoco.sh and its test): headless
# OpenGL from Debian and PyPI's mujoco in the same venv.
scripts/setup-mujoco.sh

# The Franka's own protocol checked by a third party's robot side (crates/vservo-franka's tests, the Franka driver's,
# scripts/run-franka-sim.sh): franka-sim (an FCI server on MuJoCo with the FCI's motion-limit checker) and franky-sim
# (its FR3 model) in a venv of their own (franka-sim pins numpy 1.26.4 and mujoco < 3.3)
scripts/setup-franka-sim.sh "$(pwd)" >/dev/null
