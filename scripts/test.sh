#!/usr/bin/env bash
# The README's test command: set up a fresh machine, build everything, run every test.
# The tests run under cargo-nextest, each a process of its own, side by side where .config/nextest.toml lets them
# (the tests that measure timing alone, one ROS 2 domain space, one PyBullet and one MuJoCo at a time); a test still
# running after 10 minutes is ended and named, and nothing is retried. Doc tests, which nextest does not run, run
# first under cargo test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cargo build --workspace --all-targets --locked
cargo test --workspace --locked --doc
cargo nextest run --workspace --locked --no-fail-fast
# the Debian package under a real systemd, in a container (needs root; says why when it cannot run)
scripts/test-systemd.sh
