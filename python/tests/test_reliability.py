"""The Python surfaces as an adversary tried them (issue 51, item 19):
threads, close, read-only state, values a scene cannot hold, SIGTERM."""

import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import hardbody as hb
from conftest import small_scene


def test_a_call_from_another_thread_during_a_step_says_so(in_tmp):
    scene = small_scene()
    scene.stages[1] = hb.MonteCarlo(hb.Nvt(), sweeps=200000)
    sim = hb.Simulation(scene, out="threads.mcap")
    sim.run_stage(progress=False)
    errors = []

    def step():
        try:
            sim.run(sweeps=2000, progress=False)
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    worker = threading.Thread(target=step)
    worker.start()
    deadline = time.time() + 30
    while not sim._core.running and worker.is_alive() and time.time() < deadline:
        time.sleep(0.001)
    assert sim._core.running, "the step ended before it could be caught running"
    assert repr(sim) == "<Simulation running a step>"
    with pytest.raises(RuntimeError, match="running a step"):
        sim.positions
    # close() during the step is refused, not half done ...
    with pytest.raises(RuntimeError, match="running a step"):
        sim.close()
    worker.join()
    assert not errors, errors
    # ... and the step's simulation is there to close afterwards.
    log = sim.close()
    assert not log.truncated and log.path.endswith("threads.mcap")
    assert os.path.exists("threads.mcap") and not os.path.exists("threads.mcap.partial")
    assert repr(sim) == f"<Simulation closed, log {log.path}>"


def test_the_state_of_a_simulation_is_read_only_and_positions_must_be_in_reach(in_tmp):
    sim = hb.Simulation(small_scene(), out="state.mcap")
    sim.run_stage(progress=False)
    with pytest.raises(ValueError, match="read-only"):
        sim.positions[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        sim.orientations[0, 0] = 1.0
    positions = sim.positions.copy()
    far = positions.copy()
    far[3, 0] = 1e300
    with pytest.raises(ValueError, match="position 3: .*box edges away"):
        sim.positions = far
    assert np.array_equal(sim.positions, positions)
    sim.close()
    with pytest.raises(ValueError, match="closed"):
        sim.positions


@pytest.mark.parametrize(
    "change, field",
    [
        (lambda s: setattr(s.species[0], "shape", hb.Sphere(float("nan"))), "species[0].shape.radius"),
        (lambda s: setattr(s.species[1], "shape", hb.Ellipsoid(0.8, float("inf"), 0.4)), "species[1].shape.b"),
        (lambda s: setattr(s, "box", (9.0, float("nan"), 9.0)), "box[1]"),
        (lambda s: s.stages.__setitem__(3, hb.Dynamics(duration=float("nan"))), "stages[3].duration"),
    ],
)
def test_a_value_that_is_not_a_number_names_its_field(change, field):
    scene = small_scene()
    change(scene)
    with pytest.raises(hb.SceneError, match="^" + re.escape(field) + ": must be a finite number"):
        scene.check()


def test_sigterm_ends_a_python_run_cleanly_as_the_command_line_does(tmp_path):
    script = textwrap.dedent(
        """
        import sys
        import hardbody as hb
        sys.path.insert(0, sys.argv[1])
        from conftest import small_scene
        scene = small_scene()
        scene.stages[1] = hb.MonteCarlo(hb.Nvt(), sweeps=10**7)
        hb.run(scene, out="term.mcap", progress=False)
        """
    )
    here = os.path.dirname(os.path.abspath(__file__))
    child = subprocess.Popen(
        [sys.executable, "-c", script, here], cwd=tmp_path, stderr=subprocess.PIPE, text=True
    )
    partial = tmp_path / "term.mcap.partial"
    deadline = time.time() + 60
    while not partial.exists() and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # into the long stage
    child.send_signal(signal.SIGTERM)
    _, err = child.communicate(timeout=60)
    assert child.returncode != 0, err
    assert "interrupted; the log is complete up to the last frame" in err, err
    log = hb.open_log(tmp_path / "term.mcap")
    assert not log.truncated
    assert log.frames[-1].stage_index == 1
    assert not partial.exists()
