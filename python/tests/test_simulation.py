"""A run step by step: the same states as the run in one go, the state
read and set between steps, requests it cannot follow refused."""

import numpy as np
import pytest

import hardbody as hb
from conftest import small_scene


def test_steps_give_the_run_in_one_go(small_log, in_tmp):
    with hb.Simulation(small_scene(), out="steps.mcap") as sim:
        assert sim.stage_index == 0 and not sim.paused
        sim.run(sweeps=7, progress=False)
        assert sim.paused and sim.frame.sweep == 7
        sim.run_stage(progress=False)
        while sim.stage_index in (1, 2):
            sim.run(sweeps=33, progress=False)
        sim.run(time=0.2, progress=False)
        assert sim.frame.time == pytest.approx(0.2)
        assert sim.velocities.shape == (64, 3)
        sim.run(progress=False)
        assert sim.stage_index is None
    log = sim.log
    assert len(log.summary["stages"]) == 4
    frames = {f.log_time: f for f in log.frames}
    for whole in small_log.frames:
        steps = frames[whole.log_time]
        if whole.stage == "dynamics" and whole.time > 0.2:
            assert np.allclose(steps.positions, whole.positions, atol=1e-8)
        else:
            assert np.array_equal(steps.positions, whole.positions)
            assert np.array_equal(steps.orientations, whole.orientations)


def test_setting_the_state_checks_overlaps(in_tmp):
    sim = hb.Simulation(small_scene(), out="set.mcap")
    sim.run_stage(progress=False)
    before = sim.positions
    overlapping = before.copy()
    overlapping[1] = overlapping[0]
    with pytest.raises(ValueError, match="overlap"):
        sim.positions = overlapping
    assert np.array_equal(sim.positions, before)
    with pytest.raises(ValueError, match="shape"):
        sim.positions = before[:, :2]
    with pytest.raises(ValueError, match="unit quaternion"):
        sim.orientations = 2 * sim.orientations
    shifted = before + np.array([0.1, 0.0, 0.0])
    sim.positions = shifted
    box = sim.box
    d = sim.positions - shifted
    assert np.allclose(d - box * np.round(d / box), 0.0, atol=1e-12)
    sim.run(sweeps=10, progress=False)
    assert sim.frame.stage_index == 1
    log = sim.close()
    assert not log.truncated


def test_requests_a_stage_cannot_follow_are_refused(in_tmp):
    sim = hb.Simulation(small_scene(), out="refused.mcap")
    with pytest.raises(ValueError, match="sweeps"):
        sim.run(time=1.0, progress=False)
    with pytest.raises(ValueError, match="not both"):
        sim._core.advance(sweeps=1, time=1.0)
    sim.run(progress=False)
    with pytest.raises(ValueError, match="every stage"):
        sim.run_stage(progress=False)
    sim.close()
    with pytest.raises(ValueError, match="closed"):
        sim.run_stage(progress=False)
