"""The tutorial script (examples/python/tutorial.py) runs, and its two
routes to the mean-squared displacement (numpy on the frames, the
dynamics' own /stats) agree."""

import json
import subprocess
import sys

import pytest

from conftest import ROOT


def test_the_tutorial_runs(tmp_path):
    pytest.importorskip("freud", reason="the tutorial needs freud-analysis")
    pytest.importorskip("matplotlib", reason="the tutorial needs matplotlib")
    script = ROOT / "examples" / "python" / "tutorial.py"
    out = subprocess.run(
        [sys.executable, str(script), "--quick", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    summary = json.loads((tmp_path / "tutorial.json").read_text())
    assert summary["msd_worst_relative_difference"] < 1e-9
    assert summary["msd_final"] > 0
    # 2:1 ellipsoids at betaP = 3: a fluid near phi = 0.39.
    assert 0.35 < summary["packing_fraction"] < 0.45
    assert (tmp_path / "tutorial.png").stat().st_size > 10_000
    assert (tmp_path / "rods.mcap").exists()
