#!/usr/bin/env bash
# Speed against error of the stiff cantilever (E = 1e8 Pa), one thread: wall seconds per
# simulated second of `mls` (at its stable dt) and `mls-implicit` (at 1 ms and frame-rate
# steps), at 4 and 8 phyxels through the thickness (640 and 5,120 phyxels), with the
# implicit solver's iterations; then the tip-deflection errors from `phyxel validate`
# (Euler–Bernoulli reference; the static sag does not depend on dt, the dt rows show it).
#
# Usage: benches/implicit.sh   (about 3 minutes)
set -euo pipefail
bin=${PHYXEL_BIN:-target/release/phyxel}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
export RAYON_NUM_THREADS=1
for spacing in 0.025 0.0125; do
  "$bin" scenes --show cantilever | sed "s/^spacing = .*/spacing = $spacing/; s/^surfel_spacing = .*/surfel_spacing = $spacing/" > "$dir/bar.toml"
  row() { # backend dt steps
    "$bin" run "$dir/bar.toml" --backend "$1" ${2:+--dt "$2"} --steps "$3" --json 2>/dev/null | python3 -c '
import json, sys
d = json.load(sys.stdin); b = d["bodies"][0]; s = b.get("solver")
it = "" if not s else "  newton/step %.2f  cg/step %.2f  max residual %.1e  unconverged %d" % (
    s["newton_iterations"] / s["steps"], s["cg_iterations"] / s["steps"], s["max_residual"], s["unconverged"])
print("%-13s %6d phyxels  dt %.2e  %7.3f wall s per simulated s%s" % (
    b["backend"], b["phyxels"], d["dt"], d["wall_seconds"] / d["time"], it))'
  }
  row mls "" 4000
  row mls-implicit 0.001 200
  row mls-implicit 0.004166667 60
  row mls-implicit 0.008333333 60
  row mls-implicit 0.016666667 60
done
"$bin" validate --case cantilever-d --backend mls-implicit --json 2>/dev/null | python3 -c '
import json, sys
for r in json.load(sys.stdin):
    print("%-26s %5d phyxels  dt %.2e  error %+.1f%%  (%s)" % (r["case"], r["phyxels"], r["dt"],
          100 * (r["measured"] - r["reference"]) / r["reference"], r["status"]))'
