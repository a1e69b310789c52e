#!/usr/bin/env bash
# Regenerates the figures in docs/img/figures/ with host-tool itself (the PNGs the docs show;
# the same commands with .svg or .pdf give the vector forms). Deterministic: the simulator
# runs are seeded and the figures use only the bundled font, so a rerun gives the same files.
#   bash tools/figures/docs-figures.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --locked -p host-tool
ht=target/release/host-tool
out=docs/img/figures
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# docs/ik.md: the README's helix fit, and the paper's infeasible pop-outs with --all-states.
"$ht" ik --n 3 --beta 31.72 --modules 14 --target helix:radius=1,pitch=2,turns=1 \
  --metric ordered --algo exact --png "$out/ik-helix.png" >/dev/null
"$ht" ik --n 4 --beta 35 --modules 10 --target helix:radius=1,pitch=2,turns=1 \
  --all-states --png "$out/ik-helix-all-states.png" >/dev/null
# docs/ik.md: the feasible β bands of n = 3 … 8 (host-tool design).
"$ht" design --n 3..8 --png "$out/design-bands.png" >/dev/null
"$ht" design --n 3,4 --target helix:radius=1,pitch=2,turns=1 --modules 14 --metric ordered \
  --png "$out/design-helix.png" >/dev/null
# The crane's two β alternating along a 12-module boom fitted to a sine.
"$ht" ik --n 3 --beta 35,31.72,35,31.72,35,31.72,35,31.72,35,31.72,35,31.72 --modules 12 \
  --target sine --png "$out/ik-sine-two-betas.png" >/dev/null

# docs/recording.md: a recorded plan F&P → D&D on the simulator (seed 7), plotted.
"$ht" plan --sim --seed 7 --target 'D&D' --record "$tmp/plan.mcap" --json >/dev/null
"$ht" log plot "$tmp/plan.mcap" --out "$out/log-plot-plan.png" >/dev/null
ls -l "$out"
