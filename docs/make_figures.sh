#!/usr/bin/env bash
# Regenerate the figures embedded in README.md ("Results"): the thesis study and the
# bias-compensation study at their shipped R = 2000, then copy the headline SVGs here.
# Run again whenever the numbers change (about a minute on 2 cores).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release
bin=target/release/chassis-mc
"$bin" run studies/thesis.toml --out results/thesis --quiet
"$bin" run studies/bias_compensation.toml --out results/bias_compensation --quiet
mkdir -p docs/figures
for p in inv_mass drag_over_mass rolling_resistance; do
    cp "results/thesis/figures/se_$p.svg" "docs/figures/thesis_se_$p.svg"
    cp "results/bias_compensation/figures/bias_$p.svg" "docs/figures/bias_compensation_bias_$p.svg"
done
cp results/thesis/figures/ratio_drag_over_mass.svg docs/figures/thesis_ratio_drag_over_mass.svg
cp results/thesis/figures/cycles.svg docs/figures/thesis_cycles.svg
ls -la docs/figures
