"""A dynamics backend written in Python with NumPy: a mass-spring network.

Each phyxel is a mass; springs join rest neighbours closer than 1.8 lattice spacings
(the 6 face and 12 edge neighbours of a cubic lattice), with stiffness k = E·h (a cube
of side h in tension) and a dashpot. Forces are equal and opposite per spring, so the
network conserves momentum; the engine's contact forces arrive in `phyxels.forces`.

    import phyxel
    from mass_spring import MassSpring
    rows = phyxel.compare("two-spheres", backends=["mls", MassSpring])
    for r in rows:
        print(r["backend"], r["steps_per_second"], r["phase_seconds"]["dynamics"] / r["steps"])

Run as a script, it prints that comparison (cost per step of the dynamics phase, the
rest of the step, and the largest penetration) for two-spheres.
"""

import numpy as np


class MassSpring:
    """Springs between rest neighbours, integrated by symplectic Euler."""

    name = "numpy-springs"

    #: Damping ratio of one spring on the mean phyxel mass.
    ZETA = 0.05
    #: Fraction of the explicit limit 2/ω the step may use.
    MARGIN = 0.8

    def __init__(self, phyxels, material):
        rest = phyxels.rest.astype(np.float64)
        n = len(rest)
        d = np.linalg.norm(rest[:, None, :] - rest[None, :, :], axis=-1)
        np.fill_diagonal(d, np.inf)
        spacing = float(np.median(d.min(axis=1))) if n > 1 else 1.0
        i, j = np.nonzero(np.triu(d < 1.8 * spacing))
        self.i, self.j, self.rest_length = i, j, d[i, j]
        self.mass = phyxels.masses.astype(np.float64)
        self.k = material["young"] * spacing
        self.c = 2.0 * self.ZETA * np.sqrt(self.k * self.mass.mean())
        self.degree = np.bincount(np.r_[i, j], minlength=n)

    def stable_dt(self, phyxels):
        """0.8 · 2/ω with the Gershgorin bound ω² ≤ max 4 k · degree / m."""
        if len(self.i) == 0:
            return float("inf")
        omega = np.sqrt(4.0 * self.k * (self.degree / self.mass).max())
        return float(self.MARGIN * 2.0 / omega)

    def step(self, phyxels, dt, gravity):
        x = phyxels.positions.astype(np.float64)
        v = phyxels.velocities.astype(np.float64)
        f = phyxels.forces.astype(np.float64) + np.outer(self.mass, gravity)
        d = x[self.j] - x[self.i]
        length = np.linalg.norm(d, axis=1)
        u = d / length[:, None]
        stretch = self.k * (length - self.rest_length)
        damping = self.c * np.einsum("ij,ij->i", v[self.j] - v[self.i], u)
        fs = (stretch + damping)[:, None] * u
        np.add.at(f, self.i, fs)
        np.add.at(f, self.j, -fs)
        v += dt * f / self.mass[:, None]
        x += dt * v
        phyxels.velocities[:] = v
        phyxels.positions[:] = x


if __name__ == "__main__":
    import phyxel

    rows = phyxel.compare("two-spheres", backends=["mls", MassSpring])
    print(f"{'backend':<14} {'dynamics ms/step':>17} {'rest ms/step':>13} {'max penetration':>16}")
    for r in rows:
        per_step = {k: 1e3 * v / r["steps"] for k, v in r["phase_seconds"].items()}
        dynamics = per_step.pop("dynamics")
        print(f"{r['backend']:<14} {dynamics:17.3f} {sum(per_step.values()):13.3f} {r['max_penetration']:16.4f}")
