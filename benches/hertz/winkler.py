"""Hertz contact of a rigid sphere on an elastic half-space through a Winkler layer.

The penalty spring of phyxel's contact (stiffness kappa E*/h per area, half the overlap
on each side) is a compliant layer in series with the elastic body: at pressure p it
overlaps by c_w p with c_w = 2 h / (kappa E*). This script solves that frictionless
contact numerically, independently of the engine, to say how much of the engine's
patch-radius and central-pressure error the layer alone explains
(docs/ACCURACY.md, "Hertz on a rigid plane").

Model: the contact area is a square grid of cells of side d carrying uniform pressure;
the surface displacement is Boussinesq's, w = (1/(pi E*)) * integral p / rho dA (a
cell's own term exact for a uniformly loaded square, 8 b ln(1 + sqrt 2) with b = d/2).
The contact condition on the loaded cells is w + c_w p = delta - r^2 / (2 R), with the
total force F given and delta unknown; cells that pull are dropped and cells that would
overlap are added until the set is stable. The patch radius and the central pressure
are estimated as in `validate::hertz_plane`: a from the second moment of the force
(sum f r^2 / sum f = 2 a^2 / 5) and p0 from the mean pressure over r < a/2 (0.9349 p0).

With c_w = 0 it returns Hertz: a and p0 within 0.3% (the discretisation's error).

Run: python3 benches/hertz/winkler.py  (needs numpy; about 15 s)
"""

import numpy as np

E_STAR = 1.0
R = 1.0
A_HERTZ = 0.15  # Hertz's patch radius for the load below, in units of R
F = 4.0 * E_STAR * R * A_HERTZ**3 / 3.0
P0_HERTZ = 3.0 * F / (2.0 * np.pi * A_HERTZ**2)


def solve(lam, n=81, half_width=1.6):
    """Errors of (a, p0) against Hertz for a layer of compliance lam * a / E*."""
    d = 2.0 * half_width * A_HERTZ / n
    xs = (np.arange(n) - (n - 1) / 2) * d
    x, y = (c.ravel() for c in np.meshgrid(xs, xs))
    rho = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    np.fill_diagonal(rho, 1.0)
    # Displacement per unit force on a cell.
    g = 1.0 / (np.pi * E_STAR * rho)
    np.fill_diagonal(g, 8.0 * (d / 2) * np.log(1.0 + np.sqrt(2.0)) / (np.pi * E_STAR * d * d))
    g += np.eye(len(x)) * lam * A_HERTZ / E_STAR / (d * d)
    r2 = x * x + y * y
    active = r2 < (1.1 * A_HERTZ) ** 2
    for _ in range(100):
        idx = np.where(active)[0]
        m = np.zeros((len(idx) + 1, len(idx) + 1))
        m[:-1, :-1] = g[np.ix_(idx, idx)]
        m[:-1, -1] = -1.0
        m[-1, :-1] = 1.0
        sol = np.linalg.solve(m, np.concatenate([-r2[idx] / (2 * R), [F]]))
        f = np.zeros(len(x))
        f[idx] = sol[:-1]
        gap = g @ f - sol[-1] + r2 / (2 * R)
        new = (active & (f >= 0)) | (~active & (gap < -1e-12))
        if (new == active).all():
            break
        active = new
    a = np.sqrt(2.5 * (f * r2).sum() / f.sum())
    inner = r2 < 0.25 * a * a
    p0 = f[inner].sum() / (inner.sum() * d * d) / 0.9349
    return a / A_HERTZ - 1.0, p0 / P0_HERTZ - 1.0


if __name__ == "__main__":
    kappa = 4.0
    print("| phyxels per R | h/a | layer c_w E*/a | a | p0 |")
    print("|---|---|---|---|---|")
    print("| (Hertz) | 0 | 0 | %+.1f%% | %+.1f%% |" % tuple(100 * e for e in solve(0.0)))
    for per in [8, 12, 16, 24, 32, 64]:
        h_over_a = 1.0 / (per * A_HERTZ)
        lam = 2.0 * h_over_a / kappa
        ea, ep = solve(lam)
        print("| %d | %.2f | %.3f | %+.1f%% | %+.1f%% |" % (per, h_over_a, lam, 100 * ea, 100 * ep))
