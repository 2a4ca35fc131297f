"""Speed against error of the backends on one case, as a chart.

Runs the validation suite's `cantilever-deflection` case (tip deflection of a clamped
bar against Euler–Bernoulli, at several resolutions) for every backend (`mls`,
`mls-implicit`, `sph`, `lj`) through `phyxel.validate`, and plots wall seconds per
simulated second (the cost of a step over its dt: backends step at different dt)
against relative error, one line per backend, with matplotlib.

    python docs/compare_backends.py [--full] [--case NAME] [--out chart.png]

`--full` uses the suite's full resolutions (minutes); the default quick ones take
seconds. Needs matplotlib.
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import phyxel  # noqa: E402


def measure(case, quick):
    """{backend: [(wall s per simulated s, relative error)]} from the validation rows."""
    points = {}
    for backend in phyxel.BACKENDS:
        for row in phyxel.validate(quick=quick, case=case, backend=backend):
            if row["case"] == case and row["rel_error"] == row["rel_error"]:  # not NaN
                cost = row["seconds_per_step"] / row["dt"]
                points.setdefault(backend, []).append((cost, abs(row["rel_error"])))
    return points


def plot(points, case, out):
    fig, ax = plt.subplots(figsize=(6, 4))
    for backend, pts in sorted(points.items()):
        pts.sort()
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=backend)
    ax.set_xlabel("wall seconds per simulated second")
    ax.set_ylabel("relative error")
    ax.set_title(f"{case}: speed against error")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--case", default="cantilever-deflection")
    ap.add_argument("--out", default="compare_backends.png")
    args = ap.parse_args(argv)
    points = measure(args.case, quick=not args.full)
    for backend, pts in sorted(points.items()):
        print(backend, ", ".join(f"{s * 1e3:.3f} ms/step: {e:.3%}" for s, e in sorted(pts)))
    plot(points, args.case, args.out)
    print("chart:", args.out)
    return points


if __name__ == "__main__":
    main()
