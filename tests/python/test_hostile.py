"""Hostile input through Python (issue 51): no Rust panic reaches Python, outputs refuse
what is not a regular file, setters take real numbers only, dt is checked as the build
checks it, scene dicts are limited and named by key, sweeps keep every task's row."""

import os
import subprocess
import sys

import numpy as np
import pytest

import phyxel


def two_spheres():
    return phyxel.Scene.builtin("two-spheres").build()


def test_phyxel_frames_of_any_count_are_written(tmp_path):
    """The padded mass column panicked here (1220 phyxels, not a multiple of 8)."""
    w = phyxel.Scene.builtin("plastic-fracture").build()
    path = tmp_path / "p.ply"
    w.write_frame(str(path), phyxels=True)
    assert path.read_bytes().startswith(b"ply\n")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_write_frame_refuses_a_fifo_and_a_device(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    w = two_spheres()
    for dest in [str(fifo), "/dev/null"]:
        with pytest.raises(phyxel.Error, match="not a regular file"):
            w.write_frame(dest)
    assert os.path.exists("/dev/null") and not os.path.isfile("/dev/null")
    assert not fifo.is_file() and fifo.exists()


def test_a_failing_python_backend_raises_and_prints_nothing():
    """A backend that raises gives `phyxel.Error` (an `Exception`), with nothing printed
    (a Rust panic message and backtrace were printed once per body)."""
    code = (
        "import phyxel\n"
        "class Bad:\n"
        "    def __init__(self, p, m): pass\n"
        "    def step(self, p, dt, g): raise RuntimeError('boom')\n"
        "w = phyxel.Scene.builtin('two-spheres').build(backend=Bad)\n"
        "try:\n"
        "    w.step()\n"
        "except Exception as e:\n"
        "    assert isinstance(e, phyxel.Error) and 'boom' in str(e), e\n"
        "    print('raised')\n"
        "try:\n"
        "    w.step()\n"
        "except phyxel.Error as e:\n"
        "    assert 'stopped working' in str(e), e\n"
        "    print('stays an error')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["raised", "stays", "an", "error"]
    assert "panicked" not in out.stderr and "RUST_BACKTRACE" not in out.stderr, out.stderr


@pytest.mark.parametrize(
    "bad",
    [
        lambda n: np.zeros((n, 3), dtype="datetime64[s]"),
        lambda n: np.zeros((n, 3), dtype=complex),
        lambda n: np.ma.masked_array(np.zeros((n, 3)), mask=True),
        lambda n: np.full((n, 3), "1.0"),
        lambda n: np.zeros((n, 3), dtype=bool),
    ],
    ids=["datetime", "complex", "masked", "strings", "bool"],
)
def test_setters_take_real_numbers_only(bad):
    w = two_spheres()
    body = w["left"]
    before = body.phyxel_velocities.copy()
    n = before.shape[0]
    with pytest.raises((TypeError, ValueError)):
        body.phyxel_velocities = bad(n)
    with pytest.raises((TypeError, ValueError)):
        body.apply_forces(bad(n))
    np.testing.assert_array_equal(body.phyxel_velocities, before)
    body.phyxel_velocities = np.ones((n, 3), dtype=np.int64)
    assert (body.phyxel_velocities == 1.0).all()


def test_dt_is_checked_as_the_build_checks_it():
    w = two_spheres()
    with pytest.raises(phyxel.UnstableError) as e:
        w.dt = 0.05
    assert 0 < e.value.bound < 0.05
    with pytest.raises(ValueError, match="range of f32"):
        w.dt = 1e-45
    w.set_dt(0.05, allow_unstable=True)
    assert abs(w.dt - 0.05) < 1e-9


def test_scene_dicts_are_named_by_key_and_limited():
    d = phyxel.Scene.builtin("two-spheres").to_dict()
    d["objects"][0]["spacing"] = float("nan")
    with pytest.raises(phyxel.SceneError, match=r"objects\[0\]\.spacing: spacing = NaN"):
        phyxel.Scene.from_dict(d)
    d["objects"][0]["spacing"] = True
    with pytest.raises(phyxel.SceneError, match="spacing = true: invalid type") as e:
        phyxel.Scene.from_dict(d)
    assert "line" not in str(e.value)
    d["objects"][0]["spacing"] = 0.025
    d["objects"][0]["position"] = np.array([-0.15, 0.0, 0.0])
    assert phyxel.Scene.from_dict(d).name == "two-spheres"
    d["objects"][0]["fixed"] = [{"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]}] * 1_000_000
    with pytest.raises(phyxel.SceneError, match="larger than the 16777216 bytes"):
        phyxel.Scene.from_dict(d)
    with pytest.raises(phyxel.SceneError, match="more than the limit"):
        phyxel.Scene.from_toml("#" * (17 << 20))


def test_compare_and_validate_check_their_arguments_first():
    with pytest.raises(ValueError, match="at least one"):
        phyxel.compare("two-spheres", backends=[], steps=1)
    with pytest.raises(ValueError, match="twice"):
        phyxel.compare("two-spheres", backends=["mls", "mls"], steps=1)
    with pytest.raises(ValueError, match="no case"):
        phyxel.validate(case="zzz")
    with pytest.raises(ValueError, match="empty"):
        phyxel.validate(case="")


def test_a_sweep_keeps_every_row():
    rows = phyxel.sweep(
        [{"scene": "two-spheres", "steps": 2}, 5, {"scene": "two-spheres", "steps": 2, "material": 5}],
        frame=False,
    )
    assert len(rows) == 3
    assert rows[0]["error"] is None and rows[0]["summary"]["steps"] == 2
    assert "a task is a dict" in rows[1]["error"]
    assert "material = 5" in rows[2]["error"]
    with pytest.raises(TypeError, match="grid"):
        phyxel.sweep({"scene": ["two-spheres"]})
