# Sourced by scripts/run-*.sh, which run vservod with a driver for a while and summarise the run: what they do
# alike. Expects the repository root as the working directory, and `json` (0 or 1) and `python` set.

# say TEXT…: to stdout, or to stderr with --json (the JSON summary stays the last line on stdout).
say() { [ "${json:-0}" = 1 ] && echo "$*" >&2 || echo "$*"; }

# cell_binaries PACKAGE…: sets `bin` to the directory of vservod, vservoctl and the packages' binaries: the
# one VSERVO_BIN_DIR names (binaries already built: the integration tests pass theirs), else target/release
# after a release build.
cell_binaries() {
    bin="${VSERVO_BIN_DIR:-}"
    if [ -z "$bin" ]; then
        local packages=()
        for package in vservod vservoctl "$@"; do packages+=(-p "$package"); done
        cargo build --release --locked -q "${packages[@]}" >&2
        bin=./target/release
    fi
    bin="$(cd "$bin" && pwd)"
}

# wait_for_cell INSTANCE OUT: until vservod has claimed the instance (OUT/vservod.log says it starts the nodes)
# and its nodes have made their services (at most 20 s each).
wait_for_cell() {
    local instance="$1" out="$2"
    for _ in $(seq 200); do
        grep -q "starting the nodes" "$out/vservod.log" 2>/dev/null && break
        sleep 0.1
    done
    for _ in $(seq 200); do
        "$bin/vservoctl" echo features --instance "$instance" --duration-s 0.05 > /dev/null 2>&1 && break
        sleep 0.1
    done
}

# hold_then_resume INSTANCE HELD_S OUT: the first motion of a cell that starts held (robot.start = "held"): records
# HELD_S seconds of camera twists, joint commands and joint states to OUT/held-*.jsonl while it is held, then
# `vservoctl resume` (retried while the resume is refused, at most 20 s: the driver's first joint states). The
# held phase's summary is OUT/held.json (scripts/held_summary.py).
hold_then_resume() {
    local instance="$1" held_s="$2" out="$3" recorders=()
    wait_for_cell "$instance" "$out"
    for topic in camera_twist joint_command joint_state; do
        "$bin/vservoctl" echo "$topic" --instance "$instance" --duration-s "$held_s" > "$out/held-$topic.jsonl" &
        recorders+=($!)
    done
    pids+=("${recorders[@]}")
    wait "${recorders[@]}" || true
    local resumed=0
    for _ in $(seq 100); do
        if "$bin/vservoctl" resume --instance "$instance" > "$out/resume.txt" 2>&1; then
            resumed=1
            break
        fi
        sleep 0.2
    done
    "$python" scripts/held_summary.py "$out" "$resumed" > "$out/held.json"
}

# record_run INSTANCE DURATION OUT [commands]: once vservod has claimed the instance (OUT/vservod.log says it
# starts the nodes) and its nodes have made their services (at most 20 s each), records DURATION seconds of
# features to OUT/features.jsonl — from the first frame on — and, with `commands`, the rmrc's joint commands to
# OUT/commands.jsonl (for the capture → command latency); then the status to OUT/status.txt. No client of the
# instance is made before the claim: one would find the last run's prefix and make its shared memory first.
record_run() {
    local instance="$1" duration="$2" out="$3"
    wait_for_cell "$instance" "$out"
    "$bin/vservoctl" echo features --instance "$instance" --duration-s "$duration" > "$out/features.jsonl" &
    local features=$!
    pids+=("$features")
    if [ "${4:-}" = commands ]; then
        "$bin/vservoctl" echo joint_command --instance "$instance" --duration-s "$duration" > "$out/commands.jsonl" &
        pids+=($!)
    fi
    wait "$features" || true
    "$bin/vservoctl" status --instance "$instance" > "$out/status.txt" 2>&1 || true
}

# stop_processes PID…: SIGTERM, up to 5 s to end, then SIGKILL.
stop_processes() {
    for pid in "$@"; do kill -TERM "$pid" 2>/dev/null || true; done
    for _ in $(seq 50); do
        local alive=0
        for pid in "$@"; do kill -0 "$pid" 2>/dev/null && alive=1; done
        [ "$alive" = 0 ] && return 0
        sleep 0.1
    done
    for pid in "$@"; do kill -KILL "$pid" 2>/dev/null || true; done
}

# with_instance CONFIG NAME OUT: the file to run: CONFIG itself when NAME is empty, else OUT/instance.toml, which
# extends CONFIG (by its absolute path) under instance NAME (--instance of the run scripts).
with_instance() {
    local config="$1" name="$2" out="$3"
    if [ -z "$name" ]; then
        echo "$config"
        return
    fi
    printf '# written by %s: %s under instance %s\nextends = "%s"\n\n[instance]\nname = "%s"\n' \
        "$0" "$config" "$name" "$(cd "$(dirname "$config")" && pwd)/$(basename "$config")" "$name" > "$out/instance.toml"
    echo "$out/instance.toml"
}

# remove_runtime_dir INSTANCE: removes the run's own runtime directory ($VSERVO_RUNTIME_DIR) and the instance's
# shared memory (its prefix is in the directory).
remove_runtime_dir() {
    local instance="$1" prefix
    if [ -f "$VSERVO_RUNTIME_DIR/$instance/prefix" ]; then
        prefix="$(cat "$VSERVO_RUNTIME_DIR/$instance/prefix")"
        [ -n "$prefix" ] && rm -f /dev/shm/"$prefix"* 2>/dev/null || true
    fi
    rm -rf "$VSERVO_RUNTIME_DIR"
}

# run_folder NAME [TAG]: sets `out` to a folder of this run's own, target/NAME-run/[TAG-]PID, made new, and points
# target/NAME-run/latest at it: two runs at once never share a folder, so each keeps its own logs and recordings.
# The summary's `run_folder` names it.
run_folder() {
    local base="target/$1-run" leaf="${2:+$2-}$$"
    out="$base/$leaf"
    rm -rf "$out"
    mkdir -p "$out"
    ln -sfn "$leaf" "$base/latest"
}

# with_run_folder SUMMARY: the summary with `run_folder` (the absolute path of `out`) added.
with_run_folder() {
    merge_json "$1" "{\"run_folder\": \"$(cd "$out" && pwd)\"}"
}

# say_summary NAME JSON: the run's summary for people, a row per figure ("  final_error_px  0.0481"; a nested
# object's keys as a.b; a list joined, "none" when empty); with --json on stderr, the JSON line being stdout's last.
say_summary() {
    say "$("$python" - "$1" "$2" <<'PY'
import json, sys
name, summary = sys.argv[1], json.loads(sys.argv[2])
rows = []
def walk(prefix, value):
    if isinstance(value, dict) and value:
        for key, inner in value.items():
            walk(f"{prefix}{key}.", inner)
    else:
        rows.append((prefix[:-1], value))
walk("", summary)
def shown(value):
    if isinstance(value, bool) or value is None:
        return {True: "yes", False: "no", None: "—"}[value]
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list):
        return ", ".join(shown(v) for v in value) or "none"
    if isinstance(value, dict):
        return "—"
    return str(value)
width = max((len(key) for key, _ in rows), default=0)
print(f"{name}: the run's summary")
for key, value in rows:
    print(f"  {key:<{width}}  {shown(value)}")
PY
)"
}

# merge_json A B: the JSON object A with B's keys added.
merge_json() {
    "$python" -c 'import json,sys; a=json.loads(sys.argv[1]); a.update(json.loads(sys.argv[2])); print(json.dumps(a))' "$1" "$2"
}
