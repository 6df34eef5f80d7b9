"""`hardbody.analyze` returns what `hardbody analyze --json` prints."""

import json
import subprocess
import warnings

import numpy as np
import pytest

import hardbody as hb
from conftest import small_scene
from test_run import hardbody_cli


def cli_json(*args):
    out = subprocess.run([hardbody_cli(), "analyze", *map(str, args), "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_the_averages_are_the_command_lines(small_log):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = hb.analyze(small_log)
    assert report == cli_json(small_log.path)
    stages = {s["stage_index"]: s for s in report["stages"]}
    assert set(stages) == {0, 1, 2, 3}
    # The NPT stage reports its imposed pressure as a constant.
    assert stages[1]["observables"]["pressure"]["mean"] == 2.0


def test_a_stage_too_short_to_equilibrate_is_flagged(small_log):
    with pytest.warns(RuntimeWarning, match="never equilibrated"):
        report = hb.analyze(small_log.path)
    assert any(not s["equilibrated"] for s in report["stages"] if s["stage"] != "compress")


def test_replicas_are_averaged_as_the_command_line_does(in_tmp):
    a = hb.run(small_scene(), out="a.mcap", seed=1, progress=False)
    b = hb.run(small_scene(), out="b.mcap", seed=2, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = hb.analyze([a, b])
    expected = cli_json(a.path, b.path)
    assert report["stages"] == expected["stages"] and report["logs"] == expected["logs"]
    assert len(report["replicas"]) == 2
    other = small_scene()
    other.species[0].count = 40
    c = hb.run(other, out="c.mcap", progress=False)
    with pytest.raises(hb.LogError, match="not a replica"):
        hb.analyze([a, c])


def test_the_packing_report_is_the_command_lines(small_log):
    report = hb.analyze(small_log, packing=True, gap=0.05)
    expected = cli_json(small_log.path, "--packing", "--gap", "0.05")
    assert isinstance(report["rdf"]["g"], np.ndarray)
    assert np.array_equal(report["rdf"]["g"], expected["rdf"]["g"])
    assert np.array_equal(report["structure_factor"]["s"], expected["structure_factor"]["s"])
    for key in ["gap", "network", "steinhardt", "nematic", "cubatic", "steinhardt_cutoff", "frame"]:
        assert report[key] == expected[key], key
    assert report["gap"]["source"] == "given"
    # Without a gap, one read from the packing: a fluid has no plateau,
    # and says so.
    with pytest.warns(RuntimeWarning, match="no plateau"):
        own = hb.analyze(small_log, packing=True)
    assert own["gap"] == cli_json(small_log.path, "--packing")["gap"]
    assert own["gap"]["source"] == "no_plateau"
    with pytest.warns(RuntimeWarning, match="no plateau"):
        first = hb.analyze(small_log, packing=True, frame=0)
    assert first["frame"] == 0 and first["network"]["bodies"] == 64
    with pytest.raises(IndexError):
        hb.analyze(small_log, packing=True, frame=len(small_log.frames))
    with pytest.raises(ValueError, match="gap"):
        hb.analyze(small_log, packing=True, gap=-1.0)
