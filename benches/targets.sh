#!/usr/bin/env bash
# Whole-step throughput in one sitting (docs/PERFORMANCE.md, "At a glance"): release
# runs of the CLI at the paper's size (`two-spheres`, and `scale` with contact in every
# step), the 2 x 1M `scale` run on two threads and on one, and the time per surfel-step
# at 1M against 100k over the same simulated time. About 20 seconds per round on the
# 2-core CI machine once built.
#
#   bash benches/targets.sh           # two rounds
#   RUNS=1 bash benches/targets.sh    # one round
#
# Compare figures from one sitting only: on the shared machine the same code runs
# 5-60% slower on some days. Runs that are compared (1 and 2 threads, 100k and 1M)
# alternate, so that drift hits both alike. Needs python3, which reads the runs'
# `--json` summaries.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${RUNS:-2}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

cargo build --release --quiet
bin=target/release/phyxel
run() { # run NAME SCENE ARGS...: one `phyxel run SCENE` summary into $out/NAME.json
    local name=$1 scene=$2
    shift 2
    "$bin" run "$scene" "$@" --json >"$out/$name.json"
    echo "  $name done" >&2
}

echo "whole runs ($RUNS per row)" >&2
for r in $(seq "$RUNS"); do
    run "spheres_$r" two-spheres
    run "paper_$r" scale
    run "m1_2t_$r" scale --surfels 1000000 --phyxel-count 20000
    RAYON_NUM_THREADS=1 run "m1_1t_$r" scale --surfels 1000000 --phyxel-count 20000
    # The scaling protocol: 100k over the same simulated time as 1M, i.e. with the 1M
    # run's own dt (the default dt shrinks with the phyxel spacing).
    dt=$(python3 -c 'import json,sys; print(repr(json.load(open(sys.argv[1]))["dt"]))' "$out/m1_2t_$r.json")
    run "k100_$r" scale --surfels 100000 --phyxel-count 3900 --dt "$dt"
done

python3 - "$out" "$RUNS" <<'EOF'
import json, os, sys
out, runs = sys.argv[1], int(sys.argv[2])
load = lambda n: json.load(open(os.path.join(out, n + ".json")))
def per_step(d):
    return {k: v / d["steps"] * 1e3 for k, v in d["phase_seconds"].items() if v > 0}
def us_per_surfel_step(d):
    return d["wall_seconds"] / d["steps"] / d["surfels"] * 1e6

rows = range(1, runs + 1)
spheres = [load(f"spheres_{r}")["steps_per_second"] for r in rows]
paper = [load(f"paper_{r}")["steps_per_second"] for r in rows]
two = [load(f"m1_2t_{r}") for r in rows]
one = [load(f"m1_1t_{r}") for r in rows]
k100 = [load(f"k100_{r}") for r in rows]
fmt = lambda xs, f="%.1f": ", ".join(f % x for x in xs)
print("| quantity | goal | measured |")
print("|---|---|---|")
print(f"| `two-spheres` scene (2 x 10k surfels, contact in part of the run) | - | {fmt(spheres)} steps/s |")
print(f"| paper size in contact (`scale`, 2 x 10k surfels) | >= 500 steps/s | {fmt(paper)} steps/s |")
print(f"| 2 x 1M surfels, 2 x 20k phyxels | >= 60 steps/s | {fmt(d['steps_per_second'] for d in two)} steps/s |")
print(f"| 1M, one thread | - | {fmt(d['steps_per_second'] for d in one)} steps/s |")
ratios = [o["wall_seconds"] / t["wall_seconds"] for t, o in zip(two, one)]
print(f"| 2 threads / 1 thread at 1M | >= 1.7x | {fmt(ratios, '%.2fx')} |")
flat = [us_per_surfel_step(t) / us_per_surfel_step(k) for k, t in zip(k100, two)]
print(f"| us per surfel-step, 1M against 100k, same dt ({two[0]['dt']:.6g} s) | <= 2x | "
      f"{fmt((us_per_surfel_step(t) for t in two), '%.4f')} / "
      f"{fmt((us_per_surfel_step(k) for k in k100), '%.4f')}: {fmt(flat, '%.2fx')} |")

print()
print("1M step by phase, ms/step (two threads):")
for name in two[0]["phase_seconds"]:
    vals = [per_step(d).get(name, 0.0) for d in two]
    if max(vals) >= 0.005:
        print(f"  {name:16} {fmt(vals, '%.2f')}")
EOF
