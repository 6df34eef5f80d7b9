"""Free energies and coexistence from Python, as `hardbody free-energy`
and `hardbody coexistence` compute them: the scenes run (their logs
written), the paths integrated with the GIL released, the results as the
commands' JSON, parsed."""

from __future__ import annotations

import json
import os
from typing import Optional, Union

from . import _core
from ._run import ProgressArg, _interrupted, _progress, _sigterm_stops_the_run
from ._scene import Scene

SceneArg = Union[Scene, str, os.PathLike]


def _scene(scene: SceneArg) -> Scene:
    return scene if isinstance(scene, Scene) else Scene.load(scene)


def _parsed(call, *args, **keywords) -> dict:
    """The JSON `call` returns, parsed; SIGTERM stops it as Ctrl-C does."""
    try:
        with _sigterm_stops_the_run():
            return json.loads(call(*args, **keywords))
    except KeyboardInterrupt as e:
        _interrupted(e)
        raise


def free_energy(
    scene: SceneArg,
    out: Optional[Union[str, os.PathLike]] = None,
    seed: Optional[int] = None,
    points: Optional[int] = None,
    sweeps: Optional[int] = None,
    spring: Optional[float] = None,
    progress: ProgressArg = True,
) -> dict:
    """βF/N of the state `scene` ends in (Λ = 1 length unit), as a dict:
    `method` ("frenkel_ladd" for a scene that starts from a Crystal,
    "equation_of_state" for a fluid), `free_energy_per_particle`,
    `error`, `excess_free_energy_per_particle`, `n`,
    `packing_fraction`, and the path point by point. The scene is run
    first, its log at `out` (default its log path). Raises ValueError for
    what cannot have a free energy (a melting crystal is a RunError)."""
    scene = _scene(scene)
    return _parsed(
        _core.free_energy_json,
        scene.to_ron(),
        out=None if out is None else os.fspath(out),
        seed=seed,
        inputs=[scene._path] if scene._path is not None else [],
        points=points,
        sweeps=sweeps,
        spring=spring,
        progress=_progress(progress),
    )


def coexistence(
    fluid: SceneArg,
    solid: SceneArg,
    seed: Optional[int] = None,
    points: Optional[int] = None,
    sweeps: Optional[int] = None,
    spring: Optional[float] = None,
    progress: ProgressArg = True,
) -> dict:
    """Fluid–crystal coexistence of the fluid scene `fluid` and the
    crystal scene `solid` (each run to its own log path), as a dict:
    `pressure`, `pressure_error`, `fluid_packing_fraction`,
    `solid_packing_fraction` with their errors, `chemical_potential`,
    both branches and βμ of each on a grid of βP."""
    fluid, solid = _scene(fluid), _scene(solid)
    return _parsed(
        _core.coexistence_json,
        fluid.to_ron(),
        solid.to_ron(),
        seed=seed,
        inputs=[s._path for s in (fluid, solid) if s._path is not None],
        points=points,
        sweeps=sweeps,
        spring=spring,
        progress=_progress(progress),
    )
