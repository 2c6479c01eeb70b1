#!/usr/bin/env bash
# Installs what a fresh machine needs to build and test vservo. Safe to run again: it only adds what is missing.
set -euo pipefail

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
