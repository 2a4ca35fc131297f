"""The Python package's overhead, against the CLI on the same machine in one sitting.

1. Stepping the paper-size `scale` scene (2 x 10k surfels in contact, 150 steps) from
   Python (`world.step(n)`) against `phyxel run scale --json`: steps/s of each, runs
   alternating, medians and their ratio (target: Python within 5% of the CLI).
2. Reading every surfel position of the 2 x 1M-surfel `scale` world into NumPy
   (`body.surfel_positions` for both bodies): milliseconds, median of 20 reads
   (target: under 10 ms).

    python benches/python.py [--runs N] [--cli target/release/phyxel]

Needs the package installed (`pip install .`) and the release CLI built.
"""

import argparse
import json
import statistics
import subprocess
import time

import phyxel


def python_steps_per_second(steps):
    """Steps per second of `world.step(steps)`, timed around the call (so the binding's
    work between steps counts; the summary's own figure times the steps only)."""
    world = phyxel.Scene.builtin("scale").build()
    t0 = time.perf_counter()
    world.step(steps)
    return steps / (time.perf_counter() - t0)


def cli_steps_per_second(cli, steps):
    out = subprocess.run([cli, "run", "scale", "--steps", str(steps), "--json"], capture_output=True, check=True)
    return json.loads(out.stdout)["steps_per_second"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--cli", default="target/release/phyxel")
    args = ap.parse_args()
    steps = phyxel.Scene.builtin("scale").steps
    py, cli = [], []
    for _ in range(args.runs):
        cli.append(cli_steps_per_second(args.cli, steps))
        py.append(python_steps_per_second(steps))
    mp, mc = statistics.median(py), statistics.median(cli)
    print(f"paper-size scale, {steps} steps, {args.runs} alternating runs each")
    print(f"  CLI    steps/s median {mc:8.1f}  ({', '.join(f'{x:.0f}' for x in cli)})")
    print(f"  Python steps/s median {mp:8.1f}  ({', '.join(f'{x:.0f}' for x in py)})")
    print(f"  Python / CLI = {mp / mc:.3f}")

    world = phyxel.Scene.builtin("scale").build(surfels=1_000_000, phyxels=20_000)
    bodies = world.objects
    n = sum(len(b.surfel_radii) for b in bodies)
    times = []
    for _ in range(20):
        t0 = time.perf_counter()
        arrays = [b.surfel_positions for b in bodies]
        times.append(time.perf_counter() - t0)
        assert sum(len(a) for a in arrays) == n
    print(f"reading {n:,} surfel positions into NumPy: median {1e3 * statistics.median(times):.2f} ms "
          f"(min {1e3 * min(times):.2f}, max {1e3 * max(times):.2f})")


if __name__ == "__main__":
    main()
