"""`hardbody analyze` from Python: what the command prints with `--json`,
as Python objects."""

from __future__ import annotations

import json
import os
import warnings
from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from . import _core
from ._log import RunLog

LogArg = Union[RunLog, str, os.PathLike]


def _path(log: LogArg) -> str:
    return log.path if isinstance(log, RunLog) else os.fspath(log)


def analyze(
    logs: Union[LogArg, Sequence[LogArg]],
    packing: bool = False,
    frame: Optional[int] = None,
    gap: Optional[float] = None,
) -> Dict[str, Any]:
    """The equilibrium averages of a log's stages, as `hardbody analyze
    LOG --json` gives them: per stage, whether it equilibrated and, per
    observable, the mean, its error (accounting for correlation), the
    statistical inefficiency and where equilibration began. Several logs
    (replicas of one scene) are averaged together; each one's stages are
    under "replicas".

    With `packing=True`, the structure of one frame (`frame`, default the
    last; negative counts from the end) as `hardbody analyze LOG --packing
    --json` gives it: the contact network at `gap` (relative to the
    smaller body's smallest half-extent; by default read from the packing,
    on the plateau of the contact count, with a RuntimeWarning where there
    is none: see report["gap"]), g(r), S(k) (numpy arrays), Steinhardt
    Q4/Q6, nematic and cubatic order."""
    if packing:
        if not isinstance(logs, (RunLog, str, os.PathLike)):
            raise TypeError("packing: one log at a time")
        report = json.loads(_core.analyze_packing(_path(logs), frame=frame, gap=gap))
        if report["gap"]["warning"]:
            warnings.warn(report["gap"]["warning"], RuntimeWarning, stacklevel=2)
        report["rdf"] = {k: np.asarray(v, dtype=float) for k, v in report["rdf"].items()}
        report["structure_factor"] = {
            k: np.asarray(v, dtype=float) for k, v in report["structure_factor"].items()
        }
        return report
    if isinstance(logs, (RunLog, str, os.PathLike)):
        logs = [logs]
    report = json.loads(_core.analyze_logs([_path(log) for log in logs]))
    for damage in report.pop("damages"):
        warnings.warn(f"{damage}; analysing the /stats before it", RuntimeWarning, stacklevel=2)
    never = [
        s
        for s in report["stages"]
        if s["stage"] not in ("compress", "jam") and not s["equilibrated"]
    ]
    if never:
        warnings.warn(
            "stage(s) "
            + ", ".join(str(s["stage_index"]) for s in never)
            + " never equilibrated: their averages are not equilibrium values; run them longer",
            RuntimeWarning,
            stacklevel=2,
        )
    return report
