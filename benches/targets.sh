#!/usr/bin/env bash
# The performance issue's targets in one sitting (docs/PERFORMANCE.md, "At a glance"):
# whole runs of the `scale` scene from the CLI, then the SIMD-against-scalar kernel
# benches, with the ratios worked out. About 2.5 minutes on the 2-core CI machine once
# the benches are built.
#
#   bash benches/targets.sh             # two runs per row
#   RUNS=1 SKIP_BENCH=1 bash benches/targets.sh   # the CLI rows once, no criterion
#
# Run it on a quiet machine and compare figures from one sitting only: on the shared
# machine the same code runs 5-60% slower on some days. Runs that are compared (1 and 2
# threads, 100k and 1M) alternate, so that drift hits both alike. Needs python3, which
# reads the runs' `--json` summaries and criterion's estimates.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${RUNS:-2}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

cargo build --release --quiet
bin=target/release/phyxel
run() { # run NAME ARGS...: one `phyxel run scale` summary into $out/NAME.json
    local name=$1
    shift
    "$bin" run scale "$@" --json >"$out/$name.json"
    echo "  $name done" >&2
}

echo "whole runs of the scale scene ($RUNS per row)" >&2
for r in $(seq "$RUNS"); do
    run "paper_$r"
    run "m1_2t_$r" --surfels 1000000 --phyxel-count 20000
    RAYON_NUM_THREADS=1 run "m1_1t_$r" --surfels 1000000 --phyxel-count 20000
    # The scaling protocol: 100k over the same simulated time as 1M, i.e. with the 1M
    # run's own dt (the default dt shrinks with the phyxel spacing).
    dt=$(python3 -c 'import json,sys; print(repr(json.load(open(sys.argv[1]))["dt"]))' "$out/m1_2t_$r.json")
    run "k100_$r" --surfels 100000 --phyxel-count 3900 --dt "$dt"
done

if [ -z "${SKIP_BENCH:-}" ]; then
    flags=(--warm-up-time 1 --measurement-time 3 --noplot)
    cargo bench --quiet --bench kernels -- "${flags[@]}" >"$out/kernels.txt" 2>&1
    cargo bench --quiet --bench grid -- rebuild "${flags[@]}" >"$out/grid.txt" 2>&1
fi

python3 - "$out" "$RUNS" <<'EOF'
import json, os, sys
out, runs = sys.argv[1], int(sys.argv[2])
load = lambda n: json.load(open(os.path.join(out, n + ".json")))
def per_step(d):
    return {k: v / d["steps"] * 1e3 for k, v in d["phase_seconds"].items() if v > 0}
def us_per_surfel_step(d):
    return d["wall_seconds"] / d["steps"] / d["surfels"] * 1e6

rows = range(1, runs + 1)
paper = [load(f"paper_{r}")["steps_per_second"] for r in rows]
two = [load(f"m1_2t_{r}") for r in rows]
one = [load(f"m1_1t_{r}") for r in rows]
k100 = [load(f"k100_{r}") for r in rows]
fmt = lambda xs, f="%.1f": ", ".join(f % x for x in xs)
print("| target | goal | measured |")
print("|---|---|---|")
print(f"| paper size (2 x 10k surfels) | >= 500 steps/s | {fmt(paper)} steps/s |")
print(f"| 2 x 1M surfels, 2 x 20k phyxels | >= 10 steps/s | {fmt(d['steps_per_second'] for d in two)} steps/s |")
print(f"| 1M, one thread | - | {fmt(d['steps_per_second'] for d in one)} steps/s |")
ratios = [o["wall_seconds"] / t["wall_seconds"] for t, o in zip(two, one)]
print(f"| 2 threads / 1 thread at 1M | >= 1.7x | {fmt(ratios, '%.2fx')} |")
flat = [us_per_surfel_step(k) / us_per_surfel_step(t) for k, t in zip(k100, two)]
print(f"| us per surfel-step, 100k / 1M, same dt ({two[0]['dt']:.6g} s) | <= 2x | "
      f"{fmt((us_per_surfel_step(k) for k in k100), '%.4f')} / "
      f"{fmt((us_per_surfel_step(t) for t in two), '%.4f')}: {fmt(flat, '%.2fx')} |")

pairs = [
    ("implicit-surface sums", "implicit_sums/simd", "implicit_sums/scalar"),
    ("force distribution", "distribute/simd", "distribute/scalar"),
    ("MLS forces, 390 phyxels", "mls_forces/simd_390", "mls_forces/scalar_390"),
    ("MLS forces, 20k phyxels", "mls_forces/simd_20k", "mls_forces/scalar_20k"),
    ("grid build, 100k lattice", "grid/build_rebuild", "grid/build_rebuild_scalar"),
    ("grid build, 1M sphere, spiral order", "grid/sphere_1m_rebuild", "grid/sphere_1m_rebuild_scalar"),
    ("grid build, 1M sphere, Morton order", "grid/sphere_1m_morton_rebuild", "grid/sphere_1m_morton_rebuild_scalar"),
    ("grid build, 1M sphere, far-grid cells", "grid/sphere_1m_far_rebuild", "grid/sphere_1m_far_rebuild_scalar"),
]
def median_us(bench):
    path = os.path.join("target", "criterion", bench, "new", "estimates.json")
    return json.load(open(path))["median"]["point_estimate"] / 1e3
if os.path.exists(os.path.join(out, "kernels.txt")):
    for label, simd, scalar in pairs:
        a, b = median_us(simd), median_us(scalar)
        print(f"| {label}, SIMD / scalar | >= 3x | {a:.1f} / {b:.1f} us: {b / a:.2f}x |")

print()
print("1M step by phase, ms/step (two threads):")
for name in two[0]["phase_seconds"]:
    vals = [per_step(d).get(name, 0.0) for d in two]
    if max(vals) >= 0.005:
        print(f"  {name:16} {fmt(vals, '%.2f')}")
EOF
