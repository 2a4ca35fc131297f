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


def test_tasks_take_any_scene_and_dotted_overrides():
    """A task's scene may be a `Scene`, a dict, TOML text or a name, and dotted keys
    override any scene key (`grid` expands them as any axis): the right sphere of
    `two-spheres` at two moduli gives rows equal, bit for bit, to `phyxel.run` of the
    scene changed by hand; a Dask worker gets the scene by value (a `Scene` task on a
    cluster gives the serial row); an unknown object is a row error naming the objects."""
    scene = phyxel.Scene.builtin("two-spheres")
    key = "objects.right.material.young"
    tasks = phyxel.grid(scene=[scene, scene.to_dict(), scene.to_toml(), "two-spheres"], steps=150,
                        **{key: [1e5, 3e5]})
    df = phyxel.sweep(tasks)
    assert len(df) == 8 and df["error"].isna().all(), df["error"].tolist()
    assert set(df["scene"]) == {"two-spheres"}
    for young in (1e5, 3e5):
        d = scene.to_dict()
        d["objects"][1]["material"]["young"] = young
        want = phyxel.run(phyxel.Scene.from_dict(d), steps=150)
        rows = df[df[key] == young]
        assert (rows["summary.energy_final.kinetic"] == want["energy_final"]["kinetic"]).all()
        assert (rows["summary.max_penetration"] == want["max_penetration"]).all()
    assert df[df[key] == 1e5]["summary.max_penetration"].iloc[0] != df[df[key] == 3e5]["summary.max_penetration"].iloc[0]
    (bad,) = phyxel.sweep([{"scene": scene, "steps": 5, "objects.middle.material.young": 1e5}], frame=False)
    assert "no object 'middle' (objects: left, right)" in bad["error"]
    distributed = pytest.importorskip("distributed")
    serial = comparable(phyxel.sweep(tasks[:2]))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            parallel = comparable(phyxel.sweep(tasks[:2], client=client))
    assert [{k: v for k, v in r.items()} for r in parallel] == serial
