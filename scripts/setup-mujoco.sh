#!/usr/bin/env bash
# Installs what clients/python/mujoco_driver.py needs: headless OpenGL from Debian (Mesa's EGL, software
# rendering: no display, no GPU) and PyPI's mujoco in target/python-venv. Safe to run again: it only adds
# what is missing. scripts/setup.sh creates the venv (with iceoryx2) first; this script does too if it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

mujoco_version="4.0.0"
venv="target/python-venv"
# MuJoCo renders through libEGL + libOpenGL (glvnd) with Mesa's EGL and swrast/llvmpipe driver behind them
gl_packages=(libegl1 libegl-mesa0 libopengl0 libgl1-mesa-dri)

sudo_if_needed=""
[ "$(id -u)" -ne 0 ] && sudo_if_needed="sudo"
missing=()
for package in "${gl_packages[@]}"; do
    dpkg-query -W -f='${Status}' "${package}" 2>/dev/null | grep -q "install ok installed" || missing+=("${package}")
done
if [ "${#missing[@]}" -gt 0 ]; then
    ${sudo_if_needed} apt-get update -qq
    DEBIAN_FRONTEND=noninteractive ${sudo_if_needed} apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -x "${venv}/bin/python" ]; then
    mkdir -p target
    python3 -m venv "${venv}"
fi
"${venv}/bin/python" -c 'import iceoryx2' >/dev/null 2>&1 || "${venv}/bin/pip" install -q iceoryx2==0.10.0
if ! "${venv}/bin/python" -c "import mujoco, sys; sys.exit(mujoco.__version__ != '${mujoco_version}')" >/dev/null 2>&1; then
    "${venv}/bin/pip" install -q "mujoco==${mujoco_version}"
fi

# check that headless rendering works
MUJOCO_GL=egl "${venv}/bin/python" - <<'PY'
import mujoco
model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom type="sphere" size="1"/></worldbody></mujoco>')
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer = mujoco.Renderer(model, 32, 32)
renderer.update_scene(data)
renderer.render()
PY
echo "setup-mujoco: mujoco ${mujoco_version} with headless EGL rendering in ${venv}"
