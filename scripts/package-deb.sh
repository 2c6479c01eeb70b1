#!/usr/bin/env bash
# Builds the Debian package of vservo into target/debian/: vservod, vservoctl, vservo-ros2 (the ROS 2 bridge),
# vservo-ros2-driver (the ROS 2 driver) and
# vservo-franka (the Franka driver; the unit's network drop-in of docs/ROS2.md lets it reach the robot) in /usr/bin, the systemd unit,
# the default configuration as a conffile in /etc/vservo/, the `vservo` system user (sysusers.d), the
# documentation, the calibration solver in /usr/share/vservo/. Installing it is the whole installation:
#   apt install ./target/debian/vservo_<version>_<arch>.deb && systemctl enable --now vservo
# Needs dpkg-deb (Debian's dpkg) and cargo. Prints the package's path on its last line.
set -euo pipefail
cd "$(dirname "$0")/.."

version="$(sed -n '/^\[workspace.package\]/,/^\[/s/^version = "\(.*\)"/\1/p' Cargo.toml)"
arch="$(dpkg --print-architecture)"
# the release build; `--profile dev` packages the binaries of the test build instead (scripts/test-systemd.sh: the
# same code, without a second, optimised build of everything)
profile=release
case "${1:-}" in
    "") ;;
    --profile) profile="${2:?--profile NAME}" ;;
    *) echo "package-deb: unknown argument $1 (expected [--profile release|dev])" >&2; exit 2 ;;
esac
case "${profile}" in
    release)
        out=target/release
        cargo build --release --locked -p vservod -p vservoctl -p vservo-ros2 -p vservo-franka-driver
        ;;
    dev)
        # the very build the tests ran (every target of the workspace: built for only these packages, some
        # dependencies would take other features and be built again)
        out=target/debug
        cargo build --workspace --all-targets --locked
        ;;
    *) echo "package-deb: --profile is release or dev" >&2; exit 2 ;;
esac

stage="target/debian/stage"
rm -rf "${stage}"
for binary in vservod vservoctl vservo-ros2 vservo-ros2-driver vservo-franka; do
    install -D -m 755 "${out}/${binary}" "${stage}/usr/bin/${binary}"
done
install -D -m 644 config/systemd/vservo.service "${stage}/lib/systemd/system/vservo.service"
install -D -m 644 config/vservo.toml "${stage}/etc/vservo/vservo.toml"
# `vservoctl calibrate`'s solver, where the command looks for it (docs/CALIBRATION.md)
install -D -m 644 clients/python/vservo_calibrate.py "${stage}/usr/share/vservo/vservo_calibrate.py"
install -d -m 755 "${stage}/usr/lib/sysusers.d"
printf 'u vservo - "vservo visual-servo daemon" /nonexistent /usr/sbin/nologin\n' >"${stage}/usr/lib/sysusers.d/vservo.conf"
doc="${stage}/usr/share/doc/vservo"
install -D -m 644 README.md "${doc}/README.md"
for file in docs/*.md; do install -D -m 644 "${file}" "${doc}/${file}"; done
printf 'vservo\nLicense: Apache-2.0\n' >"${doc}/copyright"
strip --strip-unneeded "${stage}/usr/bin/vservod" "${stage}/usr/bin/vservoctl" "${stage}/usr/bin/vservo-ros2" \
    "${stage}/usr/bin/vservo-ros2-driver" "${stage}/usr/bin/vservo-franka"

# the shared libraries the binaries need, as Debian packages (dpkg -S on each), for Depends:
depends="$(
    for binary in vservod vservoctl vservo-ros2 vservo-ros2-driver vservo-franka; do ldd "${stage}/usr/bin/${binary}"; done |
        awk '/=>/ {print $3}' | sort -u |
        while read -r library; do dpkg -S "$(readlink -f "${library}")" 2>/dev/null || dpkg -S "${library}" 2>/dev/null || true; done |
        cut -d: -f1 | sort -u | paste -sd, | sed 's/,/, /g'
)"

install -d -m 755 "${stage}/DEBIAN"
cat >"${stage}/DEBIAN/control" <<CONTROL
Package: vservo
Version: ${version}
Architecture: ${arch}
Maintainer: vservo developers <vservo@localhost>
Depends: ${depends:-libc6}, systemd
Section: misc
Priority: optional
Installed-Size: $(du -sk "${stage}" | cut -f1)
Description: real-time visual-servo controller daemon
 vservo implements Hashimoto, Ebine & Kimura, "Visual servoing with hand-eye
 manipulator - optimal control approach" (IEEE T-RA 1996): an LQ visual servo
 for a PUMA 560 with a hand camera, as real-time processes over iceoryx2 shared
 memory under a systemd daemon. The simulated arm and camera are the defaults.
 vservoctl calibrate runs /usr/share/vservo/vservo_calibrate.py, which needs
 Python 3 with OpenCV 4.7 or later (pip: opencv-python-headless) and SciPy.
CONTROL
echo "/etc/vservo/vservo.toml" >"${stage}/DEBIAN/conffiles"
cat >"${stage}/DEBIAN/postinst" <<'SCRIPT'
#!/bin/sh
set -e
if [ "$1" = configure ]; then
    # the system user the daemon runs as
    if command -v systemd-sysusers >/dev/null 2>&1; then
        systemd-sysusers vservo.conf
    elif ! getent passwd vservo >/dev/null; then
        adduser --system --group --no-create-home --home /nonexistent vservo
    fi
    if [ -d /run/systemd/system ]; then
        systemctl daemon-reload
        # an upgrade restarts a running daemon on the new binaries; a new install waits for `enable --now`
        if systemctl is-active --quiet vservo; then systemctl restart vservo; fi
    fi
fi
SCRIPT
cat >"${stage}/DEBIAN/prerm" <<'SCRIPT'
#!/bin/sh
set -e
if [ "$1" = remove ] && [ -d /run/systemd/system ]; then
    systemctl disable --now vservo >/dev/null 2>&1 || true
fi
SCRIPT
cat >"${stage}/DEBIAN/postrm" <<'SCRIPT'
#!/bin/sh
set -e
if [ -d /run/systemd/system ]; then systemctl daemon-reload || true; fi
SCRIPT
chmod 755 "${stage}/DEBIAN/postinst" "${stage}/DEBIAN/prerm" "${stage}/DEBIAN/postrm"

package="target/debian/vservo_${version}_${arch}.deb"
dpkg-deb --root-owner-group --build "${stage}" "${package}" >/dev/null
echo "${package}"
