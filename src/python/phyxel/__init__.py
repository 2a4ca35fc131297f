"""phyxel: contact handling for deformable point-based objects (Keiser et al. 2004).

Objects are point clouds: surfels sample the surface, phyxels the volume. A dynamics
backend moves the phyxels, the surfels follow, and the contact pipeline finds colliding
surfels, builds the contact surface and pushes back.

>>> import phyxel
>>> world = phyxel.Scene.builtin("two-spheres").build()
>>> world.step(100)
>>> world["left"].phyxel_positions.shape
(280, 3)

See docs/PYTHON.md for the whole API.
"""

from ._phyxel import (
    BACKENDS,
    Body,
    Error,
    NonFiniteError,
    Scene,
    SceneError,
    UnstableError,
    World,
    __version__,
    compare,
    run,
    scenes,
    validate,
)

from .sweeps import WALL_KEYS, grid, sweep

__all__ = [
    "BACKENDS",
    "Body",
    "Error",
    "NonFiniteError",
    "Scene",
    "WALL_KEYS",
    "SceneError",
    "UnstableError",
    "World",
    "__version__",
    "compare",
    "run",
    "grid",
    "scenes",
    "sweep",
    "to_pandas",
    "validate",
]


def to_pandas(rows):
    """Rows (a summary dict or a list of dicts, as `run`, `compare` and `validate`
    return) as a pandas DataFrame; nested dicts become dotted columns
    (`energy_final.kinetic`). A `World.run` record becomes one row per sample
    (`_record_frame`). Needs pandas (`pip install phyxel[sweep]`)."""
    try:
        import pandas as pd
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_pandas needs pandas: pip install 'phyxel[sweep]'") from e
    if isinstance(rows, dict) and "time" in rows and "step" in rows:
        return _record_frame(pd, rows)
    if isinstance(rows, dict):
        rows = [rows]
    return pd.json_normalize(list(rows))


def _record_frame(pd, record):
    """`World.run`'s record as a DataFrame: one row per sample, columns `time`, `step`,
    `BODY.com.x` (and `.y`, `.z`), `BODY.velocity.x`, `TOOL.tool_force.x`,
    `energy.kinetic` (and the other parts), `A/B.normal_force` (and `area`,
    `peak_pressure`, `max_penetration`)."""
    columns = {"time": record["time"], "step": record["step"]}
    for key, names in (("com", "bodies"), ("velocity", "bodies"), ("tool_force", "tools")):
        if key in record:
            for j, name in enumerate(record[names]):
                for c, axis in enumerate("xyz"):
                    columns[f"{name}.{key}.{axis}"] = record[key][:, j, c]
    for part, values in record.get("energy", {}).items():
        columns[f"energy.{part}"] = values
    for p, (a, b) in enumerate(record.get("pairs", [])):
        for key in ("normal_force", "area", "peak_pressure", "max_penetration"):
            columns[f"{a}/{b}.{key}"] = record[key][:, p]
    return pd.DataFrame(columns)
