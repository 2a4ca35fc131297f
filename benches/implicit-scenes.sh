#!/usr/bin/env bash
# Every built-in scene on `mls-implicit` at the frame-rate step (1/120 s) for 1 s,
# beside `mls` at its own default dt for the same simulated time: finite or not, the
# solver's work and convergence per body (the worst body), and wall seconds per
# simulated second (both threads).
#
# Usage: benches/implicit-scenes.sh   (about 5 minutes)
set -euo pipefail
bin=${PHYXEL_BIN:-target/release/phyxel}
summary='
import json, sys
d = json.load(sys.stdin)
s = [b["solver"] for b in d["bodies"] if b.get("solver")]
worst = max(s, key=lambda x: x["unconverged"] * 1e9 + x["cg_iterations"]) if s else None
it = "" if not worst else "  newton/step %.1f  cg/step %6.1f  unconverged %3d/%d" % (
    worst["newton_iterations"] / worst["steps"], worst["cg_iterations"] / worst["steps"],
    worst["unconverged"], worst["steps"])
print("%-16s %-12s dt %.2e  finite %-5s  %8.2f wall s/s%s" % (
    d["scene"], d["backend"], d["dt"], d["finite"], d["wall_seconds"] / max(d["time"], 1e-30), it))'
for scene in $("$bin" scenes | awk '{print $1}'); do
  "$bin" run "$scene" --backend mls-implicit --dt 0.008333333 --steps 120 --json 2>/dev/null | python3 -c "$summary" || echo "$scene mls-implicit: failed"
  dt=$("$bin" run "$scene" --backend mls --steps 1 --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin)["dt"])')
  steps=$(python3 -c "print(max(1, round(1.0 / $dt)))")
  "$bin" run "$scene" --backend mls --steps "$steps" --json 2>/dev/null | python3 -c "$summary" || echo "$scene mls: failed"
done
