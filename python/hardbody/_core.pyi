"""The extension module (Rust); the public API is in the `hardbody`
package, which builds on these."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike]
_Progress = Optional[Callable[..., None]]

class SceneError(ValueError):
    field: Optional[str]
    line: Optional[int]

class LogError(ValueError): ...
class RunError(RuntimeError): ...

def scene_from_ron(text: str) -> str: ...
def scene_from_json(json: str) -> str: ...
def scene_to_ron(json: str) -> str: ...
def scene_plan(json: str) -> str: ...
def run_scene(
    text: str,
    out: Optional[_Path] = None,
    seed: Optional[int] = None,
    inputs: Sequence[_Path] = ...,
    progress: _Progress = None,
) -> Dict[str, Any]: ...
def resume_log(log: _Path, out: Optional[_Path] = None, progress: _Progress = None) -> Dict[str, Any]: ...
def free_energy_json(
    text: str,
    out: Optional[_Path] = None,
    seed: Optional[int] = None,
    inputs: Sequence[_Path] = ...,
    points: Optional[int] = None,
    sweeps: Optional[int] = None,
    spring: Optional[float] = None,
    progress: _Progress = None,
) -> str: ...
def coexistence_json(
    fluid: str,
    solid: str,
    seed: Optional[int] = None,
    inputs: Sequence[_Path] = ...,
    points: Optional[int] = None,
    sweeps: Optional[int] = None,
    spring: Optional[float] = None,
    progress: _Progress = None,
) -> str: ...
def read_log(path: _Path) -> Dict[str, Any]: ...
def export_gsd(path: _Path, out: _Path) -> int: ...
def analyze_logs(paths: Sequence[_Path]) -> str: ...
def analyze_packing(path: _Path, frame: Optional[int] = None, gap: float = 0.01) -> str: ...

class Frame:
    log_time: int
    stage_index: int
    stage: str
    sweep: Optional[int]
    time: Optional[float]
    box: npt.NDArray[np.float64]
    tilts: npt.NDArray[np.float64]
    positions: npt.NDArray[np.float64]
    orientations: npt.NDArray[np.float64]
    velocities: Optional[npt.NDArray[np.float64]]
    angular_velocities: Optional[npt.NDArray[np.float64]]
    sizes: Optional[npt.NDArray[np.float64]]
    species_of: npt.NDArray[np.int64]
    species_json: str
    def __len__(self) -> int: ...

class Simulation:
    stage_index: Optional[int]
    paused: bool
    closed: bool
    running: bool
    def __init__(
        self,
        text: str,
        out: Optional[_Path] = None,
        seed: Optional[int] = None,
        inputs: Sequence[_Path] = ...,
    ) -> None: ...
    def run_stage(self, progress: _Progress = None) -> Dict[str, Any]: ...
    def advance(
        self, sweeps: Optional[int] = None, time: Optional[float] = None, progress: _Progress = None
    ) -> Dict[str, Any]: ...
    def state(self) -> Frame: ...
    def set_configuration(self, positions: npt.ArrayLike, orientations: npt.ArrayLike) -> None: ...
    def finish(self) -> Dict[str, Any]: ...
