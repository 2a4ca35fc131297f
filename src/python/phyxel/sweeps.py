"""Parameter sweeps: a grid of runs (or validation cases) as tasks, on one process or on
a Dask cluster, collected into a pandas DataFrame.

Each task is a dict:

- a run: ``scene`` (a built-in name or a path), and optionally ``backend`` (a name or a
  picklable Python backend class), ``surfels``, ``phyxels``, ``dt``, ``steps``,
  ``allow_unstable`` and ``material`` (a dict of material keys set on every deformable
  object, e.g. ``{"young": 1e6}``); its row holds the task's keys and the run's
  summary (the dict of ``phyxel run --json``, nested keys dotted);
- a validation: ``validate`` (a case-name prefix), and optionally ``backend`` and
  ``quick`` (default True); it gives one row per validation row.

A task that fails gives one row with its ``error`` (the exception's type and message);
no result is lost. Results are the engine's own: the same task gives the same numbers
on any worker as in this process, bit for bit (wall times aside).
"""

import itertools
import time

from . import _phyxel

#: Summary keys that measure the machine, not the simulation.
WALL_KEYS = ("wall_seconds", "steps_per_second", "phase_seconds")

RUN_KEYS = ("scene", "backend", "surfels", "phyxels", "dt", "steps", "allow_unstable", "material")


def grid(**axes):
    """The product of the axes as task dicts: ``grid(scene=["two-spheres"],
    backend=["mls", "sph"], dt=[1e-4, 2e-4])`` gives four tasks. A scalar is one value."""
    names = list(axes)
    values = [v if isinstance(v, (list, tuple)) else [v] for v in axes.values()]
    return [dict(zip(names, combo)) for combo in itertools.product(*values)]


def _label(value):
    """A task value as a DataFrame cell: classes by name."""
    if isinstance(value, type):
        return getattr(value, "name", value.__name__)
    return value


def _scene(task):
    scene = _phyxel.Scene.load(task["scene"]) if str(task["scene"]).endswith(".toml") else _phyxel.Scene.builtin(task["scene"])
    material = task.get("material")
    if material:
        d = scene.to_dict()
        for o in d["objects"]:
            if not o.get("static", False):
                o.setdefault("material", {}).update(material)
        scene = _phyxel.Scene.from_dict(d, origin=scene.name)
    return scene


def run_task(task):
    """Runs one task in this process and returns its rows (a list of dicts)."""
    t0 = time.perf_counter()
    if not isinstance(task, dict):
        error = f"TypeError: a task is a dict of keys ({', '.join(RUN_KEYS)}), not {type(task).__name__} {task!r:.80}"
        return [dict(task=repr(task)[:80], error=error, task_seconds=time.perf_counter() - t0)]
    base = {k: _label(v) for k, v in task.items() if k != "material"}
    material = task.get("material")
    if isinstance(material, dict):
        for k, v in material.items():
            base[f"material.{k}"] = v
    elif material is not None:
        base["material"] = repr(material)[:80]
    try:
        if material is not None and not isinstance(material, dict):
            raise TypeError(f"material = {material!r:.80}: a dict of material keys (young, poisson, ...)")
        unknown = set(task) - set(RUN_KEYS) - {"validate", "quick"}
        if unknown:
            raise ValueError(f"unknown task keys {sorted(unknown)} (known: {', '.join(RUN_KEYS)}, validate, quick)")
        if "validate" in task:
            rows = _phyxel.validate(quick=task.get("quick", True), case=task["validate"], backend=task.get("backend"))
            return [dict(base, **row, error=None, task_seconds=time.perf_counter() - t0) for row in rows]
        if "scene" not in task:
            raise ValueError("a task needs `scene` (a run) or `validate` (a case prefix)")
        summary = _phyxel.run(
            _scene(task),
            steps=task.get("steps"),
            backend=task.get("backend"),
            surfels=task.get("surfels"),
            phyxels=task.get("phyxels"),
            dt=task.get("dt"),
            allow_unstable=task.get("allow_unstable", False),
        )
        return [dict(base, summary=summary, error=None, task_seconds=time.perf_counter() - t0)]
    except Exception as e:  # a failed task is a row, never a lost result
        return [dict(base, error=f"{type(e).__name__}: {e}", task_seconds=time.perf_counter() - t0)]


def sweep(tasks, client=None, frame=True):
    """Runs `tasks` (dicts, see the module doc; `grid(...)` makes a product) and returns
    a pandas DataFrame with one row per run (or validation row), in task order.

    `client`: a ``dask.distributed.Client`` (a ``LocalCluster``'s on a laptop, or one of
    dask-jobqueue's clusters on Slurm or PBS, docs/PYTHON.md): each task runs on a worker
    with phyxel installed. Without one the tasks run here, one after another.
    `frame=False` returns the list of row dicts instead (no pandas needed)."""
    if isinstance(tasks, dict):
        raise TypeError(
            "sweep takes a list of task dicts, not one dict: for the product of axes use "
            "sweep(grid(scene=[...], backend=[...], ...)); for one task, sweep([task])"
        )
    if isinstance(tasks, (str, bytes)):
        raise TypeError("sweep takes a list of task dicts, not a string")
    tasks = list(tasks)
    if client is None:
        nested = [run_task(t) for t in tasks]
    else:
        futures = client.map(run_task, tasks, pure=False)
        nested = client.gather(futures)
    rows = [row for task_rows in nested for row in task_rows]
    if not frame:
        return rows
    from . import to_pandas

    return to_pandas(rows)
