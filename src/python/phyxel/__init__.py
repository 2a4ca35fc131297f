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
    (`energy_final.kinetic`). Needs pandas (`pip install phyxel[sweep]`)."""
    try:
        import pandas as pd
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_pandas needs pandas: pip install 'phyxel[sweep]'") from e
    if isinstance(rows, dict):
        rows = [rows]
    return pd.json_normalize(list(rows))
