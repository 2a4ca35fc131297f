"""Type stubs of the compiled module `phyxel._phyxel` (re-exported by `phyxel`)."""

from os import PathLike
from typing import Any, Optional, Protocol, Sequence, Union

import numpy as np
import numpy.typing as npt
from typing_extensions import final

__all__ = [
    "Error",
    "SceneError",
    "UnstableError",
    "NonFiniteError",
    "Scene",
    "World",
    "Body",
    "scenes",
    "run",
    "compare",
    "validate",
    "__version__",
    "BACKENDS",
]
__version__: str
BACKENDS: list[str]

class Error(Exception):
    """Base class of phyxel's errors."""

class SceneError(Error):
    """A scene that cannot be read or built."""
    origin: Optional[str]
    field: Optional[str]
    value: Optional[str]
    bound: Optional[float]

class UnstableError(SceneError):
    """A time step above the stable bound; `bound` is the bound in seconds."""

class NonFiniteError(Error):
    """The state became non-finite during a step; the world stays readable."""

class PhyxelArrays(Protocol):
    """What a Python backend receives: NumPy copies of one body's phyxel columns."""
    positions: npt.NDArray[np.float32]
    velocities: npt.NDArray[np.float32]
    forces: npt.NDArray[np.float32]
    rest: npt.NDArray[np.float32]
    masses: npt.NDArray[np.float32]
    fixed: npt.NDArray[np.bool_]

Backend = Union[str, type]

@final
class Scene:
    """A simulation scene (docs/SCENES.md)."""
    @staticmethod
    def builtin(name: str) -> Scene: ...
    @staticmethod
    def load(path: Union[str, PathLike[str]]) -> Scene: ...
    @staticmethod
    def from_toml(text: str, origin: str = "scene") -> Scene: ...
    @staticmethod
    def from_dict(d: dict[str, Any], origin: str = "scene") -> Scene: ...
    def to_toml(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    @property
    def name(self) -> str: ...
    @property
    def steps(self) -> int: ...
    @property
    def object_names(self) -> list[str]: ...
    def build(
        self,
        backend: Optional[Backend] = None,
        surfels: Optional[int] = None,
        phyxels: Optional[int] = None,
        dt: Optional[float] = None,
        allow_unstable: bool = False,
        preset: Optional[str] = None,
        max_memory: Optional[int] = None,
    ) -> World: ...

@final
class Body:
    """One object of a world; arrays are read-only copies, setters write."""
    @property
    def id(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def backend(self) -> str: ...
    @property
    def is_static(self) -> bool: ...
    @property
    def asleep(self) -> bool: ...
    @property
    def mass(self) -> float: ...
    @property
    def phyxel_positions(self) -> npt.NDArray[np.float32]: ...
    @phyxel_positions.setter
    def phyxel_positions(self, value: npt.ArrayLike) -> None: ...
    @property
    def phyxel_velocities(self) -> npt.NDArray[np.float32]: ...
    @phyxel_velocities.setter
    def phyxel_velocities(self, value: npt.ArrayLike) -> None: ...
    @property
    def phyxel_forces(self) -> npt.NDArray[np.float32]: ...
    def apply_forces(self, forces: npt.ArrayLike) -> None: ...
    @property
    def phyxel_masses(self) -> npt.NDArray[np.float32]: ...
    @property
    def surfel_positions(self) -> npt.NDArray[np.float32]: ...
    @property
    def surfel_normals(self) -> npt.NDArray[np.float32]: ...
    @property
    def surfel_radii(self) -> npt.NDArray[np.float32]: ...

@final
class World:
    """A simulation: the objects of a built scene and the state of the run."""
    def step(self, n: int = 1) -> None: ...
    def run(
        self, steps: int, record: Union[str, Sequence[str], None] = None, every: int = 1
    ) -> dict[str, Any]: ...
    def set_dt(self, dt: float, allow_unstable: bool = False) -> None: ...
    dt: float
    gravity: Sequence[float]
    @property
    def time(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def stable_dt(self) -> float: ...
    @property
    def max_penetration(self) -> float: ...
    @property
    def non_finite(self) -> Optional[str]: ...
    def energy(self) -> dict[str, float]: ...
    def momentum(self) -> npt.NDArray[np.float64]: ...
    def summary(self) -> dict[str, Any]: ...
    @property
    def objects(self) -> list[Body]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: Union[int, str], /) -> Body: ...
    def object(self, id: int) -> Body: ...
    def patches(self) -> list[dict[str, Any]]: ...
    def contact_totals(self) -> list[dict[str, Any]]: ...
    def write_frame(self, path: Union[str, PathLike[str]], format: str = "ply", phyxels: bool = False, contacts: bool = False, fixed_points: bool = False) -> None: ...
    def render(self, size: tuple[int, int] = ...) -> npt.NDArray[np.uint8]: ...

def scenes() -> list[tuple[str, str]]: ...
def run(
    scene: Union[Scene, str],
    steps: Optional[int] = None,
    backend: Optional[Backend] = None,
    surfels: Optional[int] = None,
    phyxels: Optional[int] = None,
    dt: Optional[float] = None,
    allow_unstable: bool = False,
    preset: Optional[str] = None,
    max_memory: Optional[int] = None,
) -> dict[str, Any]: ...
def compare(
    scene: Union[Scene, str],
    backends: Optional[Sequence[Backend]] = None,
    steps: Optional[int] = None,
    dt: Optional[float] = None,
    allow_unstable: bool = False,
) -> list[dict[str, Any]]: ...
def validate(quick: bool = True, case: Optional[str] = None, backend: Optional[str] = None, preset: str = "default") -> list[dict[str, Any]]: ...
