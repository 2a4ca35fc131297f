"""Parameter sweeps: a grid of runs (or validation cases) as tasks, on one process or on
a Dask cluster, collected into a pandas DataFrame.

Each task is a dict:

- a run: ``scene`` (a built-in name, a ``.toml`` path, TOML text, a ``Scene`` or a
  scene dict), and optionally ``backend`` (a name or a picklable Python backend class),
  ``surfels``, ``phyxels``, ``dt``, ``steps``, ``allow_unstable``, ``material`` (a dict
  of material keys set on every deformable object, e.g. ``{"young": 1e6}``) and dotted
  overrides of any scene key: ``"objects.right.material.young": 3e5`` (an object by
  name or index), ``"output.every": 5``; its row holds the task's keys and the run's
  summary (the dict of ``phyxel run --json``, nested keys dotted);
- a validation: ``validate`` (a case-name prefix), and optionally ``backend`` and
  ``quick`` (default True); it gives one row per validation row.

A task that fails gives one row with its ``error`` (the exception's type and message);
no result is lost. ``sweep`` reads each task's scene here and sends it to the worker by
value (a dict; a mesh's path made absolute): a worker needs no scene file, only the mesh
files a scene names. Results are the engine's own: the same task gives the same numbers
on any worker as in this process, bit for bit (wall times aside).
"""

import copy
import itertools
import os
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


def scene_value(scene):
    """A task's ``scene`` as a scene dict: a ``Scene``, a dict (checked when the run builds
    it), a built-in name, a ``.toml`` path (mesh paths made absolute) or TOML text."""
    if isinstance(scene, _phyxel.Scene):
        return scene.to_dict()
    if isinstance(scene, dict):
        return scene
    if not isinstance(scene, (str, os.PathLike)):
        raise TypeError(f"scene = {scene!r:.80}: a name, a .toml path, TOML text, a Scene or a dict")
    text = os.fspath(scene)
    if "\n" in text:
        return _phyxel.Scene.from_toml(text).to_dict()
    if text.endswith(".toml"):
        d = _phyxel.Scene.load(text).to_dict()
        base = os.path.dirname(os.path.abspath(text))
        for o in d["objects"]:
            shape = o.get("shape", {})
            if shape.get("type") == "mesh" and not os.path.isabs(shape["path"]):
                shape["path"] = os.path.join(base, shape["path"])
        return d
    return _phyxel.Scene.builtin(text).to_dict()


def _override(d, key, value):
    """Sets the dotted `key` of the scene dict `d` (``objects.NAME`` or ``objects.K``
    picks an object)."""
    path = key.split(".")
    node = d
    for depth, part in enumerate(path[:-1]):
        if depth == 1 and path[0] == "objects":
            objects = node
            names = [o.get("name") or f"object{k}" for k, o in enumerate(objects)]
            if part in names:
                node = objects[names.index(part)]
            elif part.isdigit() and int(part) < len(objects):
                node = objects[int(part)]
            else:
                raise KeyError(f"{key}: no object '{part}' (objects: {', '.join(names)})")
            continue
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, (dict, list)):
            raise KeyError(f"{key}: '{part}' is {child!r:.40}, not a table")
        node = child
    node[path[-1]] = value


def _scene(task):
    d = task["_scene"] if "_scene" in task else scene_value(task["scene"])
    d = copy.deepcopy(d)
    for key, value in task.items():
        if "." in key:
            _override(d, key, value)
    material = task.get("material")
    if material:
        for o in d["objects"]:
            if not o.get("static", False):
                o.setdefault("material", {}).update(material)
    return _phyxel.Scene.from_dict(d, origin=str(d.get("name") or "scene"))


def run_task(task):
    """Runs one task in this process and returns its rows (a list of dicts)."""
    t0 = time.perf_counter()
    if not isinstance(task, dict):
        error = f"TypeError: a task is a dict of keys ({', '.join(RUN_KEYS)}), not {type(task).__name__} {task!r:.80}"
        return [dict(task=repr(task)[:80], error=error, task_seconds=time.perf_counter() - t0)]
    base = {k: _label(v) for k, v in task.items() if k not in ("material", "_scene")}
    if not isinstance(base.get("scene"), (str, type(None))):
        scene = task["scene"]
        name = scene.get("name") if isinstance(scene, dict) else getattr(scene, "name", None)
        base["scene"] = name or type(scene).__name__
    material = task.get("material")
    if isinstance(material, dict):
        for k, v in material.items():
            base[f"material.{k}"] = v
    elif material is not None:
        base["material"] = repr(material)[:80]
    try:
        if material is not None and not isinstance(material, dict):
            raise TypeError(f"material = {material!r:.80}: a dict of material keys (young, poisson, ...)")
        unknown = {k for k in task if "." not in k} - set(RUN_KEYS) - {"validate", "quick", "_scene"}
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


def _by_value(task):
    """The task with its scene read here, as a dict under ``_scene`` (a scene that
    cannot be read stays as given: its task's row then says why)."""
    if not isinstance(task, dict) or "scene" not in task:
        return task
    try:
        d = scene_value(task["scene"])
    except Exception:
        return task
    label = task["scene"] if isinstance(task["scene"], str) and "\n" not in task["scene"] else None
    return dict(task, scene=label or d.get("name") or "scene", _scene=d)


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
    tasks = [_by_value(t) for t in tasks]
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
