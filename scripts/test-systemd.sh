#!/usr/bin/env bash
# vservo as an administrator installs it, under a real systemd: builds the Debian package, boots a minimal Debian
# with systemd in a container (mmdebstrap + systemd-nspawn, from Debian's packages; the mirror is the machine's
# own apt configuration's), installs the package and checks what README.md promises: READY and the STATUS line;
# the nodes run SCHED_FIFO as the `vservo` user; `systemctl reload` succeeds with a good file (gains version up)
# and fails with a bad one (old gains kept); a frozen node is ended and restarted by vservod while the service
# stays up; `systemctl stop` brings the arm to rest and exits 0; the journal has the daemon's lines; and the
# unit's exposure (systemd-analyze security) is at most 2.0.
# Needs root. A machine that cannot boot the container gets a line saying why, and exit 0 (the rest of CI runs).
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "test-systemd: $*"; }
skip() {
    say "SKIPPED: $*"
    exit 0
}
fail() {
    say "FAILED: $*"
    exit 1
}

# the unit's exposure, as systemd rates it
score="$(systemd-analyze security --offline=true config/systemd/vservo.service 2>/dev/null |
    sed -n 's/.*Overall exposure level for vservo.service: \([0-9.]*\).*/\1/p')"
[ -n "${score}" ] || fail "systemd-analyze security gave no rating"
awk -v s="${score}" 'BEGIN { exit !(s <= 2.0) }' || fail "exposure ${score} > 2.0"
say "systemd-analyze security: exposure ${score} (at most 2.0)"

[ "$(id -u)" -eq 0 ] || skip "needs root to boot a container"
missing=()
command -v mmdebstrap >/dev/null || missing+=(mmdebstrap)
command -v systemd-nspawn >/dev/null || missing+=(systemd-container)
if [ "${#missing[@]}" -gt 0 ]; then
    apt-get install -y -qq "${missing[@]}" >/dev/null || skip "cannot install ${missing[*]}"
fi

# the package of the binaries the tests ran (scripts/test.sh built them): what is checked here is the package, the
# unit and systemd around the same code, and an optimised build of everything would take CI ten minutes more
package="$(scripts/package-deb.sh --profile dev | tail -1)"
say "package ${package}"

suite="$(. /etc/os-release && echo "${VERSION_CODENAME:-}")"
[ -n "${suite}" ] || skip "not a Debian release with a codename"
# the machine's own mirror for its release (deb822 .sources or one-line .list entries)
mirror="$(python3 - "${suite}" <<'PY'
import glob, re, sys
suite = sys.argv[1]
for path in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
    for stanza in open(path).read().split("\n\n"):
        fields = dict(re.findall(r"^(\w[\w-]*):\s*(.*)$", stanza, re.M))
        if suite in fields.get("Suites", "").split() and "deb" in fields.get("Types", "").split():
            print(fields["URIs"].split()[0]); sys.exit()
for path in ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list")):
    try:
        lines = open(path).read().splitlines()
    except OSError:
        continue
    for line in lines:
        m = re.match(r"^deb\s+(?:\[[^]]*\]\s+)?(\S+)\s+(\S+)", line)
        if m and m.group(2) == suite:
            print(m.group(1)); sys.exit()
PY
)"
[ -n "${mirror}" ] || skip "no mirror for ${suite} in the machine's apt configuration"

work="target/systemd-test"
root="${work}/root"
if [ ! -x "${root}/usr/lib/systemd/systemd" ]; then
    rm -rf "${root}"
    mkdir -p "${work}"
    mmdebstrap --quiet --variant=minbase --include=systemd,systemd-sysv,dbus "${suite}" "${root}" "${mirror}" ||
        skip "mmdebstrap could not build a ${suite} root from ${mirror}"
fi
cp "${package}" "${root}/root/vservo.deb"
# the checks another user tries on the instance (tests/nobody-tries.sh), readable by nobody inside
install -D -m 0644 tests/nobody-tries.sh "${root}/usr/local/share/nobody-tries.sh"

machine="vservo-test-$$"
# nspawn's default capability set for a container lacks CAP_IPC_LOCK, which a real host's systemd has: grant it,
# so that the unit's AmbientCapabilities=CAP_IPC_LOCK is what is tested
systemd-nspawn --quiet --ephemeral --capability=CAP_IPC_LOCK -D "${root}" --boot --register=no --keep-unit --machine="${machine}" \
    >"${work}/console.log" 2>&1 &
nspawn=$!
cleanup() {
    kill "${nspawn}" 2>/dev/null || true
    wait "${nspawn}" 2>/dev/null || true
}
trap cleanup EXIT

# the container's init: nspawn's child
init=""
for _ in $(seq 100); do
    init="$(pgrep -P "${nspawn}" | head -1 || true)"
    [ -n "${init}" ] && break
    sleep 0.1
done
[ -n "${init}" ] || skip "systemd-nspawn did not start a container: $(tail -3 "${work}/console.log")"
inside() { nsenter -t "${init}" -a -- "$@"; }
booted=""
for _ in $(seq 300); do
    state="$(inside systemctl is-system-running 2>/dev/null || true)"
    case "${state}" in running | degraded) booted=yes && break ;; esac
    sleep 0.1
done
[ -n "${booted}" ] || skip "the container did not boot (state ${state:-none}): $(tail -3 "${work}/console.log")"
say "booted ${suite} in a container (systemd $(inside systemctl --version | head -1 | cut -d' ' -f2))"

# the whole installation
# as README.md says: apt install, then enable --now (apt resolves the package's dependencies; on this minimal
# system they are all there already)
inside env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq /root/vservo.deb >/dev/null ||
    fail "apt install ./vservo_*.deb"
inside systemctl enable --now vservo || fail "systemctl enable --now vservo: $(inside journalctl -u vservo --no-pager | tail -20)"
status() { inside runuser -u vservo -- vservoctl status --json --config /etc/vservo/vservo.toml 2>/dev/null; }
field() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }
wait_for() {
    for _ in $(seq "$1"); do
        if eval "$2"; then return 0; fi
        sleep 0.2
    done
    return 1
}
wait_for 100 '[ "$(status | field "d[\"state\"]")" = running ]' ||
    fail "not running: $(inside systemctl status vservo --no-pager | tail -20)"
say "systemctl enable --now vservo: running"

# READY (the unit is active only after READY=1) and the STATUS line
[ "$(inside systemctl show -p ActiveState --value vservo)" = active ] || fail "not active"
status_line="$(inside systemctl show -p StatusText --value vservo)"
case "${status_line}" in running\ nodes\ 4/4*) ;; *) fail "STATUS: ${status_line}" ;; esac
say "READY, STATUS=${status_line:0:60}…"

# SCHED_FIFO and the user, for every node
for role in plant rmrc servo; do
    pid="$(status | field "d['nodes']['${role}']['pid']")"
    policy="$(inside chrt -p "${pid}" | head -1)"
    case "${policy}" in *SCHED_FIFO*) ;; *) fail "${role}: ${policy}" ;; esac
    user="$(inside ps -o user= -p "${pid}" 2>/dev/null || inside stat -c %U "/proc/${pid}")"
    [ "${user}" = vservo ] || fail "${role} runs as ${user}"
done
say "plant, rmrc and servo run SCHED_FIFO as vservo"

# reload: good file → gains version up; bad file → failed, old gains kept
version="$(status | field "d['gains_version']")"
inside sed -i 's/^q = 300.0/q = 310.0/' /etc/vservo/vservo.toml
inside systemctl reload vservo || fail "a good reload was reported failed"
wait_for 25 '[ "$(status | field "d[\"gains_version\"]")" -gt "${version}" ]' || fail "gains version did not go up"
version="$(status | field "d['gains_version']")"
inside sed -i 's/^q = 310.0/q = -1.0/' /etc/vservo/vservo.toml
if inside systemctl reload vservo 2>/dev/null; then fail "a bad reload was reported successful"; fi
now="$(status | field "d['gains_version']")"
[ "${now}" = "${version}" ] || fail "a bad reload changed the gains (v${version} → v${now})"
inside sed -i 's/^q = -1.0/q = 300.0/' /etc/vservo/vservo.toml
say "systemctl reload: applied (gains v${version}); a bad file refused, reported failed, gains kept"

# a frozen node: vservod finds it hung, kills and restarts it; the service stays up (no watchdog restart)
main_pid="$(inside systemctl show -p MainPID --value vservo)"
servo="$(status | field "d['nodes']['servo']['pid']")"
# a minimal system has no kill(1): the shell's builtin
inside sh -c "kill -STOP ${servo}"
wait_for 50 '[ "$(status | field "d[\"nodes\"][\"servo\"][\"restarts\"]")" -ge 1 ] && [ "$(status | field "d[\"state\"]")" = running ]' ||
    fail "the frozen servo was not restarted: $(inside journalctl -u vservo --no-pager | tail -10)"
[ "$(inside systemctl show -p MainPID --value vservo)" = "${main_pid}" ] || fail "the service was restarted"
say "a frozen servo (SIGSTOP) was ended and restarted by vservod; the service stayed up"

# another user: nothing of the instance to read, write, create or remove (docs/PROTOCOL.md)
prefix="$(inside cat /run/vservo/default/prefix)"
case "${prefix}" in vservo_*_) ;; *) fail "the instance's prefix: ${prefix}" ;; esac
# shellcheck disable=SC2016
targets="$(inside sh -c 'find /run/vservo; ls -d /dev/shm/"$1"*' sh "${prefix}" || true)"
[ "$(grep -c global_mgmt <<<"${targets}")" = 1 ] || fail "no node counter among ${targets}"
# shellcheck disable=SC2086
managed="$(inside runuser -u nobody -- sh /usr/local/share/nobody-tries.sh ${targets})"
[ -z "${managed}" ] || fail "nobody managed: ${managed}"
[ "$(status | field "d['state']")" = running ] || fail "not running after nobody's attempts"
say "nobody could read, write, create in or remove any of the instance's $(wc -l <<<"${targets}") files, directories and shared-memory objects"

# stop: the arm at rest, exit 0
inside systemctl stop vservo
result="$(inside systemctl show -p Result --value vservo)"
[ "${result}" = success ] || fail "stop result ${result}"
journal="$(inside journalctl -u vservo --no-pager -o cat)"
grep -q "the arm is at rest" <<<"${journal}" || fail "no 'the arm is at rest' in the journal"
grep -q "ready: every node runs" <<<"${journal}" || fail "the journal lacks the daemon's lines"
# mlockall and SCHED_FIFO were permitted with the unit's two capabilities (the nodes warn when refused)
refused="$(grep -E "mlockall failed|SCHED_FIFO not permitted|timer_slack" <<<"${journal}" || true)"
[ -z "${refused}" ] || fail "a real-time request was refused: ${refused}"
say "systemctl stop: the arm at rest, exit 0; the journal has the daemon's lines, no refused mlockall or SCHED_FIFO"
inside systemctl poweroff >/dev/null 2>&1 || true
say "passed"
