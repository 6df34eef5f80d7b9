"""A run taken a step at a time: stages run one by one or part way, the
state read and set between steps, the log written as it goes."""

from __future__ import annotations

import os
from typing import Optional, Union

import numpy as np

from . import _core
from ._log import Frame, RunLog
from ._run import ProgressArg, _finish, _interrupted, _progress, _sigterm_stops_the_run
from ._scene import Scene


class Simulation:
    """A scene run step by step.

    >>> sim = Simulation(scene, out="steps.mcap")
    >>> sim.run(sweeps=500)          # 500 sweeps of the stage under way
    >>> sim.positions                # numpy (N, 3)
    >>> sim.run_stage()              # the rest of it
    >>> sim.run(time=2.5)            # dynamics stages take simulated time
    >>> log = sim.close()            # the log, completed and opened

    A stage paused part way writes a frame there and goes on from it as a
    resumed run would: Monte Carlo stages give the states of the run in
    one go bit for bit; the dynamics restarts its predictions at a pause
    (the same trajectory to round-off). Setting `positions` or
    `orientations` checks for overlaps; a refused configuration leaves
    the state unchanged. Until `close()` the log is `<out>.partial`, a
    log `hardbody.resume` continues."""

    def __init__(
        self,
        scene: Union[Scene, str, os.PathLike],
        out: Optional[Union[str, os.PathLike]] = None,
        seed: Optional[int] = None,
    ):
        if not isinstance(scene, Scene):
            scene = Scene.load(scene)
        self.scene = scene
        inputs = [scene._path] if scene._path is not None else []
        self._core = _core.Simulation(
            scene.to_ron(), out=None if out is None else os.fspath(out), seed=seed, inputs=inputs
        )
        self.log: Optional[RunLog] = None

    @property
    def stage_index(self) -> Optional[int]:
        """The stage the next step runs; None once every stage has run."""
        return self._core.stage_index

    @property
    def paused(self) -> bool:
        """Whether that stage has begun and paused part way."""
        return self._core.paused

    def _step(self, call, progress: ProgressArg) -> dict:
        try:
            with _sigterm_stops_the_run():
                return call(_progress(progress))
        except KeyboardInterrupt:
            print("hardbody: interrupted; the simulation paused at its last frame", file=__import__("sys").stderr)
            raise

    def run_stage(self, progress: ProgressArg = True) -> dict:
        """Runs the rest of the stage under way (or the next one)."""
        return self._step(lambda p: self._core.run_stage(progress=p), progress)

    def run(
        self,
        sweeps: Optional[int] = None,
        time: Optional[float] = None,
        progress: ProgressArg = True,
    ) -> dict:
        """Runs the stage under way on by `sweeps` (Monte Carlo and
        compression stages; growth chunks of a jam stage) or `time`
        (dynamics), or to its end if that comes first. With neither, runs
        every stage left."""
        if sweeps is None and time is None:
            step = None
            while self.stage_index is not None:
                step = self.run_stage(progress)
            return step
        return self._step(lambda p: self._core.advance(sweeps=sweeps, time=time, progress=p), progress)

    @property
    def frame(self) -> Frame:
        """The state where the run stands, as a log frame."""
        return Frame(self._core.state())

    @property
    def box(self) -> np.ndarray:
        return _read_only(self.frame.box)

    @property
    def positions(self) -> np.ndarray:
        """Centres, (N, 3), read-only (a copy: set the whole array, which
        is checked for overlaps)."""
        return _read_only(self.frame.positions)

    @positions.setter
    def positions(self, value) -> None:
        self._core.set_configuration(_rows(value, 3), self.frame.orientations)

    @property
    def orientations(self) -> np.ndarray:
        """Unit quaternions [w, x, y, z], (N, 4), read-only (a copy: set
        the whole array, which is checked for overlaps)."""
        return _read_only(self.frame.orientations)

    @orientations.setter
    def orientations(self, value) -> None:
        self._core.set_configuration(self.frame.positions, _rows(value, 4))

    def set_configuration(self, positions, orientations) -> None:
        """Sets positions and orientations at once (a move that needs
        both to stay free of overlaps)."""
        self._core.set_configuration(_rows(positions, 3), _rows(orientations, 4))

    @property
    def velocities(self) -> Optional[np.ndarray]:
        """Velocities (N, 3) in dynamics, else None (read-only)."""
        velocities = self.frame.velocities
        return None if velocities is None else _read_only(velocities)

    @property
    def species_of(self) -> np.ndarray:
        return _read_only(self.frame.species_of)

    def close(self) -> RunLog:
        """Completes the log (renamed from `<out>.partial`) and returns it,
        opened. Stages not run are not run."""
        if self.log is None:
            self.log = _finish(self._core.finish())
        return self.log

    def __enter__(self) -> "Simulation":
        return self

    def __exit__(self, *exc) -> None:
        if not self._core.closed:
            self.close()

    def __repr__(self):
        if self._core.closed:
            log = f", log {self.log.path}" if self.log is not None else ""
            return f"<Simulation closed{log}>"
        if self._core.running:
            return "<Simulation running a step>"
        where = "finished" if self.stage_index is None else f"at stage {self.stage_index}"
        return f"<Simulation {where}{' (paused)' if self.paused else ''}>"


def _read_only(array: np.ndarray) -> np.ndarray:
    """`array` marked read-only: writing into a copy of the state would
    change nothing, so numpy refuses it instead of saying nothing."""
    array.flags.writeable = False
    return array


def _rows(value, k: int) -> np.ndarray:
    array = np.ascontiguousarray(value, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != k:
        raise ValueError(f"expected an array of shape (N, {k}), got {array.shape}")
    return array
