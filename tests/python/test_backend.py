"""Dynamics backends written in Python (docs/mass_spring.py) in the engine's pipeline.

References: momentum conservation (springs and contact forces are equal and opposite:
total momentum stays within 1e-4 of one sphere's 4.375 kg·m/s through the collision,
float32 copies in and out of each step), the bounce (the spheres separate), and the
contract of the trait (fixed phyxels stay put, the step's bound is the backend's)."""

import importlib.util
import pathlib

import numpy as np
import pytest

import phyxel

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("mass_spring", ROOT / "docs" / "mass_spring.py")
mass_spring = importlib.util.module_from_spec(spec)
spec.loader.exec_module(mass_spring)
MassSpring = mass_spring.MassSpring


def test_a_python_backend_conserves_momentum_through_a_collision():
    w = phyxel.Scene.builtin("two-spheres").build(backend=MassSpring)
    assert [b.backend for b in w.objects] == ["numpy-springs"] * 2
    assert w.dt <= 0.9 * w.stable_dt * (1 + 1e-6)
    touched = False
    for _ in range(40):
        w.step(10)
        assert np.linalg.norm(w.momentum()) < 1e-4 * 4.375
        touched = touched or bool(w.patches())
    assert touched and w.max_penetration > 0
    left, right = w["left"], w["right"]
    assert left.phyxel_velocities[:, 0].mean() < 0 < right.phyxel_velocities[:, 0].mean(), "bounced"


def test_compare_runs_a_python_backend_beside_mls_and_reports_its_cost():
    rows = phyxel.compare("two-spheres", backends=["mls", MassSpring], steps=50)
    assert [r["backend"] for r in rows] == ["mls", "numpy-springs"]
    for r in rows:
        assert r["steps"] == 50 and r["finite"]
        assert r["phase_seconds"]["dynamics"] > 0


def test_fixed_phyxels_stay_put():
    w = phyxel.Scene.builtin("cantilever").build(backend=MassSpring)
    b = w.objects[0]
    x0 = b.phyxel_positions
    w.step(20)
    x1 = b.phyxel_positions
    moved = np.linalg.norm(x1 - x0, axis=1)
    assert (moved == 0).sum() > 0, "the clamped end holds"
    assert moved.max() > 0, "the free end sags"


class Raising:
    name = "raising"

    def __init__(self, phyxels, material):
        pass

    def step(self, phyxels, dt, gravity):
        raise RuntimeError("boom")


class NoStep:
    def __init__(self, phyxels, material):
        pass


class WrongShape(Raising):
    def step(self, phyxels, dt, gravity):
        phyxels.positions = np.zeros((2, 3))


def test_errors_of_a_python_backend_are_python_errors():
    with pytest.raises(phyxel.Error, match="Python backend 'raising' failed in step: RuntimeError: boom"):
        phyxel.Scene.builtin("falling-sphere").build(backend=Raising).step()
    with pytest.raises(TypeError, match="has no step"):
        phyxel.Scene.builtin("falling-sphere").build(backend=NoStep)
    with pytest.raises(phyxel.Error, match=r"positions: shape"):
        phyxel.Scene.builtin("falling-sphere").build(backend=WrongShape).step()
    with pytest.raises(TypeError, match="backend"):
        phyxel.Scene.builtin("falling-sphere").build(backend=3)


def test_a_dt_above_the_python_bound_is_refused():
    s = phyxel.Scene.builtin("two-spheres")
    bound = s.build(backend=MassSpring).stable_dt
    with pytest.raises(phyxel.UnstableError) as e:
        s.build(backend=MassSpring, dt=2 * bound)
    assert e.value.bound == pytest.approx(bound, rel=1e-5)
