#!/usr/bin/env bash
# The README's test command: set up a fresh machine, build everything, run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo build --workspace --all-targets --locked
cargo test --workspace --locked
# the Debian package under a real systemd, in a container (needs root; says why when it cannot run)
scripts/test-systemd.sh
