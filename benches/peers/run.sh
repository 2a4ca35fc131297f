#!/usr/bin/env bash
# Speed against error beside the peers (docs/PERFORMANCE.md, "Beside the peers"):
# phyxel's elastic backends and Rapier 0.36's soft bodies (benches/peers.rs), then
# SPlisHSPlasH 2.19's elastic solids (splishsplash.sh), on the cantilever and the ball
# thrown at a box, at three resolutions, one and two threads; then the chart.
#
# Usage: bash benches/peers/run.sh [--quick] [--threads 1,2]
#   (--threads 1: over an hour, most of it the implicit solvers on the finer balls;
#   --quick, the coarse resolution only: about ten minutes per thread count)
# Writes benches/peers/results/{rust,splishsplash}.jsonl and docs/peers.svg, and prints
# each case's Pareto front. Not part of CI.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${PEERS_OUT:-$here/results}
mkdir -p "$out"
cargo bench --quiet --manifest-path "$here/Cargo.toml" --bench peers -- "$@" > "$out/rust.jsonl"
bash "$here/splishsplash.sh" "$@" > "$out/splishsplash.jsonl"
cargo run --quiet --release --manifest-path "$here/Cargo.toml" --bin chart -- \
  "$here/../../docs/peers.svg" "$out/rust.jsonl" "$out/splishsplash.jsonl"
