"""Runs from Python, as `hardbody run` runs them: progress in a terminal or
a notebook, Ctrl-C stopping the run cleanly with its log complete up to
the last frame."""

from __future__ import annotations

import os
import sys
import warnings
from typing import Callable, Optional, Union

from . import _core
from ._log import RunLog, open_log
from ._scene import Scene

ProgressArg = Union[bool, Callable[..., None]]


class _Bars:
    """A tqdm bar per stage (tqdm.auto: a widget in Jupyter)."""

    def __init__(self):
        from tqdm.auto import tqdm

        self._tqdm = tqdm
        self._bar = None

    def __call__(self, event, *args):
        if event == "stage":
            index, count, description, ticks = args
            self._close()
            self._bar = self._tqdm(
                total=ticks or None,
                desc=f"stage {index + 1}/{count}: {description}",
                unit="",
                leave=True,
            )
        elif event == "tick" and self._bar is not None:
            tick, message = args
            self._bar.set_postfix_str(message, refresh=False)
            self._bar.update(tick - self._bar.n)
        elif event == "done" and self._bar is not None:
            (message,) = args
            self._bar.set_postfix_str(message, refresh=False)
            self._close()

    def _close(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _progress(progress: ProgressArg):
    if progress is True:
        return _Bars()
    if progress is False or progress is None:
        return None
    if callable(progress):
        return progress
    raise TypeError("progress: True, False or a callable(event, *args)")


def _finish(summary: dict) -> RunLog:
    for note in summary["notes"]:
        warnings.warn(note, RuntimeWarning, stacklevel=3)
    summary["log"] = os.fspath(summary["log"])
    log = open_log(summary["log"])
    log.summary = summary
    return log


def _interrupted(e: KeyboardInterrupt):
    path = getattr(e, "log", None)
    if path is not None:
        print(
            f"hardbody: interrupted; the log is complete up to the last frame: {os.fspath(path)}",
            file=sys.stderr,
        )


def run(
    scene: Union[Scene, str, os.PathLike],
    out: Optional[Union[str, os.PathLike]] = None,
    seed: Optional[int] = None,
    progress: ProgressArg = True,
) -> RunLog:
    """Runs every stage of `scene` (a `Scene`, or the path of a scene
    file) and returns the log, opened. `out` replaces the scene's log
    path, `seed` its seed. The GIL is released while it runs; Ctrl-C ends
    the run at the next sweep or output event with a final frame, then
    raises KeyboardInterrupt (its `log` attribute is the log's path).
    Raises `SceneError` for a scene that cannot run, `RunError` for a run
    that failed."""
    if not isinstance(scene, Scene):
        scene = Scene.load(scene)
    inputs = [scene._path] if scene._path is not None else []
    try:
        summary = _core.run_scene(
            scene.to_ron(),
            out=None if out is None else os.fspath(out),
            seed=seed,
            inputs=inputs,
            progress=_progress(progress),
        )
    except KeyboardInterrupt as e:
        _interrupted(e)
        raise
    return _finish(summary)


def resume(
    log: Union[str, os.PathLike],
    out: Optional[Union[str, os.PathLike]] = None,
    progress: ProgressArg = True,
) -> RunLog:
    """Continues the run logged in `log` (complete, stopped, or cut off)
    from its last frame, as `hardbody run --resume LOG`; the new log (at
    `out`, default the log's path without `.partial`) is the same bit for
    bit as the uninterrupted run's."""
    try:
        summary = _core.resume_log(
            os.fspath(log), out=None if out is None else os.fspath(out), progress=_progress(progress)
        )
    except KeyboardInterrupt as e:
        _interrupted(e)
        raise
    return _finish(summary)
