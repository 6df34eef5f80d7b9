"""Runs from Python, as `hardbody run` runs them: progress in a terminal or
a notebook, Ctrl-C stopping the run cleanly with its log complete up to
the last frame."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
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


def _sigterm_as_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum} (SIGTERM)")


@contextlib.contextmanager
def _sigterm_stops_the_run():
    """While a run goes on, SIGTERM (what a scheduler sends a job it
    preempts) stops it as Ctrl-C does, cleanly with its log complete up to
    the last frame, as on the command line; Python's default would kill
    the process mid-write. A handler the program set itself is left alone,
    and so is every thread but the main one (only it receives signals)."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return
    signal.signal(signal.SIGTERM, _sigterm_as_interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


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
    raises KeyboardInterrupt (its `log` attribute is the log's path);
    SIGTERM does the same (unless the program handles it itself).
    Raises `SceneError` for a scene that cannot run, `RunError` for a run
    that failed."""
    if not isinstance(scene, Scene):
        scene = Scene.load(scene)
    inputs = [scene._path] if scene._path is not None else []
    try:
        with _sigterm_stops_the_run():
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
        with _sigterm_stops_the_run():
            summary = _core.resume_log(
                os.fspath(log),
                out=None if out is None else os.fspath(out),
                progress=_progress(progress),
            )
    except KeyboardInterrupt as e:
        _interrupted(e)
        raise
    return _finish(summary)
