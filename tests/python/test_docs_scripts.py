"""The scripts in docs/ run: the backend comparison draws its chart from real
validation rows (one point per backend and resolution)."""

import importlib.util
import pathlib

import phyxel
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_compare_backends_plots_speed_against_error(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "chart.png"
    points = load("compare_backends").main(["--out", str(out)])
    assert set(points) == set(phyxel.BACKENDS)
    assert all(len(p) >= 2 for p in points.values()), "several resolutions per backend"
    assert all(s > 0 and e >= 0 for pts in points.values() for s, e in pts)
    assert out.read_bytes().startswith(b"\x89PNG")
