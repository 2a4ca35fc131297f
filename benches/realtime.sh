#!/usr/bin/env bash
# The real-time table (docs/PERFORMANCE.md, "Real time"): wall seconds per simulated
# second of every built-in scene but `scale`, on `mls` and `mls-implicit`, on one and two
# threads, over SIM seconds of simulated time (default 0.2) at the scene's default dt,
# then the tool rows: the squeezed cube (benches/realtime/squeezed-cube.toml) on both
# backends and the 1 kHz tool loop (benches/realtime/tool-1khz.toml, steps per second);
# at most 1 is real time. Each cell is the median of RUNS runs (default 1), the one- and
# two-thread runs alternated so that drift on a shared machine hits both alike. The
# implicit set-up (the preconditioner's factor) is inside the run, as a user sees it.
#
#   bash benches/realtime.sh               # the table
#   RUNS=3 SIM=0.5 bash benches/realtime.sh
#   SCENES="pile incline" bash benches/realtime.sh
#   PHYXEL_BIN=/path/to/other/phyxel bash benches/realtime.sh   # another build
#
# Needs python3 (it reads the runs' `--json` summaries).
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${RUNS:-1}
SIM=${SIM:-0.2}
bin=${PHYXEL_BIN:-}
if [ -z "$bin" ]; then
    cargo build --release --quiet
    bin=target/release/phyxel
fi
scenes=${SCENES:-$("$bin" scenes | awk '$1 != "scale" {print $1}')}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

for scene in $scenes; do
    for backend in mls mls-implicit; do
        # The scene's default dt at this backend, then the steps that cover SIM seconds.
        dt=$("$bin" run "$scene" --backend "$backend" --steps 1 --json 2>/dev/null |
            python3 -c 'import json,sys; print(json.load(sys.stdin)["dt"])')
        steps=$(python3 -c "import math; print(max(1, math.ceil($SIM / $dt)))")
        for r in $(seq "$RUNS"); do
            for threads in 1 2; do
                RAYON_NUM_THREADS=$threads "$bin" run "$scene" --backend "$backend" \
                    --steps "$steps" --json 2>/dev/null \
                    >"$out/$scene.$backend.$threads.$r.json"
            done
        done
        echo "  $scene $backend ($steps steps of $dt s)" >&2
    done
done

# The tool rows, two threads.
for backend in mls mls-implicit; do
    dt=$("$bin" run benches/realtime/squeezed-cube.toml --backend "$backend" --steps 1 \
        --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin)["dt"])')
    steps=$(python3 -c "import math; print(max(1, math.ceil($SIM / $dt)))")
    "$bin" run benches/realtime/squeezed-cube.toml --backend "$backend" --steps "$steps" \
        --json 2>/dev/null >"$out/cube.$backend.json"
done
"$bin" run benches/realtime/tool-1khz.toml --steps "$(python3 -c "print(max(1, round($SIM * 1000)))")" \
    --json 2>/dev/null >"$out/tool.json"

python3 - "$out" "$RUNS" $scenes <<'EOF'
import json, os, statistics, sys
out, runs, scenes = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def ratio(scene, backend, threads):
    cells = []
    for r in range(1, runs + 1):
        d = json.load(open(os.path.join(out, f"{scene}.{backend}.{threads}.{r}.json")))
        cells.append(d["wall_seconds"] / (d["steps"] * d["dt"]))
    return statistics.median(cells)
print("| scene | `mls` 1 thread | `mls` 2 threads | `mls-implicit` 1 | `mls-implicit` 2 |")
print("|---|---|---|---|---|")
for s in scenes:
    cells = [ratio(s, b, t) for b in ("mls", "mls-implicit") for t in (1, 2)]
    print(f"| {s} | " + " | ".join(f"{c:.2f}" for c in cells) + " |")
def cube(backend):
    d = json.load(open(os.path.join(out, f"cube.{backend}.json")))
    return d["wall_seconds"] / (d["steps"] * d["dt"]), d["dt"]
print()
print("| tool rows (2 threads) | `mls` | `mls-implicit` |")
print("|---|---|---|")
(m, mdt), (i, idt) = cube("mls"), cube("mls-implicit")
print(f"| squeezed cube, s/s (dt) | {m:.2f} ({mdt:.2e} s) | {i:.2f} ({idt:.2e} s) |")
t = json.load(open(os.path.join(out, "tool.json")))
print(f"| tool at 1 kHz, steps/s | {t['steps_per_second']:.0f} | |")
EOF
