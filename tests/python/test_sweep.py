"""`phyxel.sweep`: grids of runs and validations as tasks, serially and on a Dask
cluster.

Reference: the same tasks run one after another in this process — the cluster's
results must be equal bit for bit (wall times aside), since each task is a whole run of
the deterministic engine."""

import math

import pytest

import phyxel

pd = pytest.importorskip("pandas")

TASKS = phyxel.grid(scene=["two-spheres", "falling-sphere"], backend=list(phyxel.BACKENDS), steps=[20, 40])


def comparable(df):
    drop = [c for c in df.columns if c.startswith(tuple(f"summary.{k}" for k in phyxel.WALL_KEYS)) or c == "task_seconds"]
    return df.drop(columns=drop).to_dict(orient="records")


def same(a, b):
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_grid_is_the_product_of_its_axes():
    assert len(TASKS) == 2 * len(phyxel.BACKENDS) * 2
    assert TASKS[0] == {"scene": "two-spheres", "backend": "mls", "steps": 20}
    assert phyxel.grid(scene="pile", dt=[1e-4, 2e-4]) == [
        {"scene": "pile", "dt": 1e-4},
        {"scene": "pile", "dt": 2e-4},
    ]


def test_serial_sweep_rows_are_the_runs():
    df = phyxel.sweep(TASKS)
    assert len(df) == len(TASKS) and df["error"].isna().all()
    assert list(df["summary.backend"]) == [t["backend"] for t in TASKS]
    assert list(df["summary.steps"]) == [t["steps"] for t in TASKS]
    one = phyxel.run("two-spheres", backend="sph", steps=40)
    row = df[(df.scene == "two-spheres") & (df.backend == "sph") & (df.steps == 40)].iloc[0]
    assert row["summary.max_penetration"] == one["max_penetration"]
    assert row["summary.energy_final.kinetic"] == one["energy_final"]["kinetic"]


def test_dask_sweep_on_two_workers_equals_the_serial_sweep():
    distributed = pytest.importorskip("distributed")
    serial = comparable(phyxel.sweep(TASKS))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            parallel = comparable(phyxel.sweep(TASKS, client=client))
    assert len(parallel) == len(serial) == len(TASKS)
    for s, p in zip(serial, parallel):
        assert s.keys() == p.keys()
        differing = [k for k in s if not same(s[k], p[k])]
        assert not differing, f"{s['scene']} {s['backend']}: {differing}"


def test_a_failed_task_is_a_row_with_its_error():
    rows = phyxel.sweep(
        [
            {"scene": "two-spheres", "steps": 5},
            {"scene": "nope", "steps": 5},
            {"scene": "two-spheres", "steps": 5, "dt": 1.0},
            {"scene": "two-spheres", "stepz": 5},
        ],
        frame=False,
    )
    assert [r["error"] is None for r in rows] == [True, False, False, False]
    assert rows[1]["error"].startswith("SceneError: nope: not a built-in scene")
    assert rows[2]["error"].startswith("UnstableError")
    assert "unknown task keys ['stepz']" in rows[3]["error"]


def test_material_overrides_and_validation_tasks():
    df = phyxel.sweep(
        [
            {"scene": "falling-sphere", "steps": 3},
            {"scene": "falling-sphere", "steps": 3, "material": {"young": 4e7}},
            {"validate": "mls-consistency", "backend": "mls"},
        ]
    )
    soft, stiff = df["summary.dt"].iloc[0], df["summary.dt"].iloc[1]
    assert stiff < soft, "a stiffer material has a smaller stable dt"
    assert df["material.young"].iloc[1] == 4e7
    v = df[df["validate"] == "mls-consistency"]
    assert len(v) >= 1 and (v["case"] == "mls-consistency").all() and v["error"].isna().all()
