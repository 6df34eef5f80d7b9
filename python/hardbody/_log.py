"""Logs read back: the frames as numpy arrays, the `/stats` messages as
columns, the scene that made them."""

from __future__ import annotations

import json
import os
from typing import Dict, List, Optional, Sequence, Union

import numpy as np

from . import _core
from ._scene import Scene, SceneError, Species, _decode


class Frame:
    """The state at one log time. Arrays are numpy: `box` (3,),
    `positions` (N, 3), `orientations` (N, 4) as [w, x, y, z] from body to
    lab, `velocities` and `angular_velocities` (N, 3) or None (Monte
    Carlo frames), `species_of` (N,)."""

    __slots__ = ("_core",)

    def __init__(self, core: "_core.Frame"):
        self._core = core

    @property
    def box(self) -> np.ndarray:
        return self._core.box

    @property
    def tilts(self) -> np.ndarray:
        """Tilt factors (xy, xz, yz), HOOMD-blue's: zeros for an
        orthorhombic box."""
        return self._core.tilts

    @property
    def positions(self) -> np.ndarray:
        return self._core.positions

    @property
    def orientations(self) -> np.ndarray:
        return self._core.orientations

    @property
    def velocities(self) -> Optional[np.ndarray]:
        return self._core.velocities

    @property
    def angular_velocities(self) -> Optional[np.ndarray]:
        return self._core.angular_velocities

    @property
    def sizes(self) -> Optional[np.ndarray]:
        """Each body's size, the scale factor of its species' shape (a
        polydisperse species'); None where every body has its species'
        size."""
        return self._core.sizes

    @property
    def species_of(self) -> np.ndarray:
        return self._core.species_of

    @property
    def species(self) -> List[Species]:
        """The species of the frame (count: how many of each in it); a jam
        stage's frames hold the grown shapes."""
        counts = np.bincount(self.species_of, minlength=0)
        out = []
        for i, s in enumerate(json.loads(self._core.species_json)):
            count = int(counts[i]) if i < len(counts) else 0
            out.append(Species(s["name"], _decode(s["shape"]), count, rotation=s["rotation"]))
        return out

    @property
    def stage_index(self) -> int:
        return self._core.stage_index

    @property
    def stage(self) -> str:
        """`"compress"`, `"monte_carlo"`, `"dynamics"` or `"jam"`."""
        return self._core.stage

    @property
    def sweep(self) -> Optional[int]:
        """The sweep in the stage (Monte Carlo stages), else None."""
        return self._core.sweep

    @property
    def time(self) -> Optional[float]:
        """The simulated time in the stage (dynamics), else None."""
        return self._core.time

    @property
    def log_time(self) -> int:
        """The MCAP log time in ns (README, "Logs")."""
        return self._core.log_time

    def __len__(self) -> int:
        return len(self._core)

    def __repr__(self):
        at = f"sweep {self.sweep}" if self.sweep is not None else f"t = {self.time}"
        return f"<Frame: {len(self)} particles, stage {self.stage_index} ({self.stage}), {at}>"

    def freud_box(self):
        """The box as a `freud.box.Box` (positions already lie in
        [-L/2, L/2), freud's convention): `freud.AABBQuery(frame.freud_box(),
        frame.positions)`."""
        import freud

        lx, ly, lz = self.box
        xy, xz, yz = self.tilts
        return freud.box.Box(Lx=lx, Ly=ly, Lz=lz, xy=xy, xz=xz, yz=yz)

    def to_gsd(self):
        """The frame as a `gsd.hoomd.Frame` (types named after the
        species; orientations as GSD orders them, w first; a polydisperse
        frame's spheres with their diameters)."""
        import gsd.hoomd

        frame = gsd.hoomd.Frame()
        frame.configuration.box = [*map(float, self.box), *map(float, self.tilts)]
        frame.configuration.step = int(self.log_time // 1_000_000)
        frame.particles.N = len(self)
        frame.particles.types = [s["name"] for s in json.loads(self._core.species_json)]
        frame.particles.typeid = self.species_of.astype(np.uint32)
        frame.particles.position = self.positions.astype(np.float32)
        frame.particles.orientation = self.orientations.astype(np.float32)
        if self.velocities is not None:
            frame.particles.velocity = self.velocities.astype(np.float32)
        if self.sizes is not None:
            species = json.loads(self._core.species_json)
            radius = np.array([_sphere_radius(species[k]["shape"]) for k in self.species_of])
            frame.particles.diameter = (2.0 * radius * self.sizes).astype(np.float32)
        return frame


def _sphere_radius(shape: dict) -> float:
    """The radius of a sphere's JSON shape (sizes are for spheres only)."""
    return float(shape["Sphere"]["radius"])


class RunLog:
    """A hardbody log opened for reading (`open_log`). Partial logs (a
    killed run) are read up to their last complete record (`truncated`
    is then True)."""

    def __init__(self, path: Union[str, os.PathLike]):
        self.path = os.fspath(path)
        contents = _core.read_log(self.path)
        self.metadata: Dict[str, str] = contents["metadata"]
        self.counts: Dict[str, int] = contents["counts"]
        self.stats: Dict[str, np.ndarray] = {
            k: v if isinstance(v, np.ndarray) else np.asarray(v) for k, v in contents["stats"].items()
        }
        self.frames: List[Frame] = [Frame(f) for f in contents["frames"]]
        self.failure: Optional[str] = contents["failure"]
        self.truncated: bool = contents["truncated"]
        self.damage: Optional[str] = contents["damage"]
        self.summary: Optional[dict] = None

    @property
    def scene(self) -> Scene:
        """The scene that ran (as recorded in the log, with the seed and
        any other override applied)."""
        text = self.metadata.get("scene_resolved", self.metadata.get("scene"))
        if text is None:
            raise SceneError(f"{self.path}: no scene in the log's metadata")
        return Scene.from_ron(text)

    def to_gsd(self, path: Union[str, os.PathLike]) -> int:
        """Writes every frame to a GSD file (HOOMD's schema, shapes in
        `particles/type_shapes`); returns the number of frames."""
        return _core.export_gsd(self.path, os.fspath(path))

    def __repr__(self):
        state = " (partial)" if self.truncated else ""
        return f"<RunLog {self.path!r}{state}: {len(self.frames)} frames, {self.counts.get('/stats', 0)} stats>"


def open_log(path: Union[str, os.PathLike]) -> RunLog:
    """Opens a hardbody log: `.frames`, `.stats` (a dict of numpy arrays,
    NaN where a value is null), `.scene`, `.to_gsd(path)`."""
    return RunLog(path)
