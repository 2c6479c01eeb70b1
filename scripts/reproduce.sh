#!/usr/bin/env bash
# Runs the paper's experiments (config/scenarios/) with the paper's controller and the delay-aware one, and
# keeps their summaries and figures in docs/figures/<scenario>-<law>/ for docs/REPRODUCTION.md.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked -q -p vservoctl
for scenario in translation-step rotation-step tracking-r-identity tracking-r-fig12; do
    for law in paper delay-aware; do
        out="docs/figures/${scenario}-${law}"
        ./target/release/vservoctl sim --config "config/scenarios/${scenario}.toml" --controller "$law" --out "$out" >/dev/null
        rm -f "$out/features.csv" "$out/joints.csv"
        echo "$scenario $law: $(tr -d '\n' < "$out/summary.json" | tr -s ' ')"
    done
done
# the ideal robot of docs/REPRODUCTION.md, for comparison
out="docs/figures/translation-step-paper-kinematic"
./target/release/vservoctl sim --config config/scenarios/translation-step.toml --plant kinematic --out "$out" >/dev/null
rm -f "$out/features.csv" "$out/joints.csv"
echo "translation-step paper kinematic: $(tr -d '\n' < "$out/summary.json" | tr -s ' ')"
