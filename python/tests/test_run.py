"""Runs from Python and their logs: the reader agrees with the command
line's `inspect`, arrays have the documented shapes and dtypes, partial
logs read, errors are the documented ones."""

import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import hardbody as hb
from conftest import ROOT, small_scene


def hardbody_cli():
    """The command line built beside the package (by the Rust tests)."""
    exe = os.environ.get("HARDBODY_EXE") or shutil.which("hardbody")
    if exe is None:
        candidate = ROOT / "target" / "release" / "hardbody"
        exe = str(candidate) if candidate.exists() else None
    if exe is None:
        pytest.skip("the hardbody command line is not built (cargo build --release)")
    return exe


def test_a_run_writes_the_log_the_reader_opens(small_log):
    log = small_log
    assert log.summary["interrupted"] is False
    assert len(log.summary["stages"]) == 4
    assert not log.truncated and log.damage is None and log.failure is None
    assert log.scene == small_scene()
    n = 64
    for frame in log.frames:
        assert frame.positions.shape == (n, 3) and frame.positions.dtype == np.float64
        assert frame.orientations.shape == (n, 4) and frame.orientations.dtype == np.float64
        assert frame.box.shape == (3,)
        assert frame.species_of.shape == (n,) and frame.species_of.dtype == np.int64
        assert np.allclose(np.linalg.norm(frame.orientations, axis=1), 1.0, atol=1e-12)
        assert np.all(np.abs(frame.positions) <= frame.box / 2 + 1e-12)
        if frame.stage == "dynamics":
            assert frame.velocities.shape == (n, 3) and frame.time is not None and frame.sweep is None
        else:
            assert frame.velocities is None and frame.sweep is not None and frame.time is None
    assert [s.count for s in log.frames[0].species] == [48, 16]
    stats = log.stats
    m = len(stats["stage_index"])
    assert stats["stage_index"].dtype == np.int64
    for key in ["packing_fraction", "pressure", "sweep", "time", "collisions", "temperature"]:
        assert stats[key].shape == (m,) and stats[key].dtype == np.float64, key
    assert stats["box"].shape == (m, 3)
    mc = stats["stage_index"] < 3
    # NaN where a value is null: sweeps in Monte Carlo, times in dynamics.
    assert np.all(np.isnan(stats["time"][mc])) and not np.any(np.isnan(stats["sweep"][mc]))
    assert np.all(np.isnan(stats["sweep"][~mc])) and not np.any(np.isnan(stats["time"][~mc]))
    assert set(stats["stage"]) == {"compress", "monte_carlo", "dynamics"}
    # The NPT stage's pressure is the imposed one.
    assert np.all(stats["pressure"][stats["stage_index"] == 1] == 2.0)


def test_the_reader_and_the_command_line_agree(small_log):
    out = subprocess.run([hardbody_cli(), "inspect", small_log.path], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    counts = dict(re.findall(r"^  (/\w+): (\d+) messages$", text, re.M))
    assert int(counts["/stats"]) == len(small_log.stats["stage_index"]) == small_log.counts["/stats"]
    assert int(counts["/state"]) == len(small_log.frames) == small_log.counts["/state"]
    per_stage = {int(i): int(n) for i, n in re.findall(r"^  (\d+) \w+: (\d+) stats messages", text, re.M)}
    stage_index = small_log.stats["stage_index"]
    assert per_stage == {i: int(np.sum(stage_index == i)) for i in range(4)}
    last = json.loads(text[text.index("last stats:") + len("last stats:"):])
    for key in ["packing_fraction", "pressure", "time", "temperature", "nematic_order", "collisions"]:
        assert small_log.stats[key][-1] == last[key], key
    assert list(small_log.stats["box"][-1]) == last["box"]
    assert small_log.stats["solver.distances"][-1] == last["solver"]["distances"]


def test_a_partial_log_reads_up_to_its_last_complete_frame(small_log, tmp_path):
    data = open(small_log.path, "rb").read()
    cut = tmp_path / "cut.mcap.partial"
    cut.write_bytes(data[: len(data) * 2 // 3])
    log = hb.open_log(cut)
    assert log.truncated
    assert 0 < len(log.frames) < len(small_log.frames)
    last = log.frames[-1]
    whole = next(f for f in small_log.frames if f.log_time == last.log_time)
    assert np.array_equal(last.positions, whole.positions)
    # And it is resumed to the run in one go.
    resumed = hb.resume(cut, out=tmp_path / "resumed.mcap", progress=False)
    assert len(resumed.frames) == len(small_log.frames)
    assert np.array_equal(resumed.frames[-1].positions, small_log.frames[-1].positions)


def test_logs_that_cannot_be_read_raise_the_documented_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        hb.open_log(tmp_path / "missing.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not an MCAP file at all" * 10)
    with pytest.raises(hb.LogError):
        hb.open_log(junk)


def test_a_run_never_damages_an_existing_file(in_tmp):
    scene = small_scene()
    precious = in_tmp / "scene.ron"
    precious.write_text(scene.to_ron())
    loaded = hb.Scene.load(precious)
    with pytest.raises(ValueError, match="input"):
        hb.run(loaded, out=precious, progress=False)
    assert precious.read_text() == scene.to_ron()
    with pytest.raises(ValueError, match="does not exist"):
        hb.run(scene, out=in_tmp / "no" / "such" / "dir.mcap", progress=False)


def test_a_failing_run_raises_run_error_and_keeps_its_log(in_tmp):
    # Spheres that cannot reach the target under the sweep budget.
    scene = hb.Scene(
        box=(6, 6, 6),
        species=[hb.Species("a", hb.Sphere(0.5), 64)],
        stages=[hb.Compress(packing_fraction=0.60, max_sweeps=20)],
    )
    with pytest.raises(hb.RunError, match="partial"):
        hb.run(scene, out="failing.mcap", progress=False)
    assert not (in_tmp / "failing.mcap").exists()
    log = hb.open_log("failing.mcap.partial")
    assert log.failure is not None and len(log.frames) >= 1


def test_progress_reaches_a_callback(in_tmp):
    events = []
    hb.run(small_scene(), out="p.mcap", progress=lambda *e: events.append(e))
    stages = [e for e in events if e[0] == "stage"]
    assert [e[1] for e in stages] == [0, 1, 2, 3]
    assert all(e[2] == 4 for e in stages)
    assert sum(e[0] == "done" for e in events) == 4
    assert any(e[0] == "tick" for e in events)


def test_an_error_in_the_progress_callback_stops_the_run_cleanly(in_tmp):
    def boom(event, *args):
        if event == "tick":
            raise RuntimeError("callback failed")

    with pytest.raises(RuntimeError, match="callback failed"):
        hb.run(small_scene(), out="stopped.mcap", progress=boom)
    log = hb.open_log("stopped.mcap")
    assert log.summary is None and len(log.frames) >= 1


def test_the_seed_changes_the_run(in_tmp):
    a = hb.run(small_scene(), out="a.mcap", seed=11, progress=False)
    b = hb.run(small_scene(), out="b.mcap", seed=12, progress=False)
    assert a.scene.seed == 11 and b.scene.seed == 12
    assert not np.array_equal(a.frames[-1].positions, b.frames[-1].positions)


def test_ctrl_c_stops_the_run_with_its_log_complete(in_tmp):
    script = (
        "import hardbody as hb, os, signal, sys\n"
        # Python's own handler, even where SIGINT came ignored (a job
        # started in the background with nohup).
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "from conftest import small_scene\n"
        "s = small_scene()\n"
        "s.stages[2] = hb.MonteCarlo(hb.Nvt(), sweeps=10**7)\n"
        "seen = []\n"
        "def kick(event, *a):\n"
        "    seen.append(event)\n"
        "    if event == 'tick' and len(seen) == 30:\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "try:\n"
        "    hb.run(s, out='ctrl-c.mcap', progress=kick)\n"
        "except KeyboardInterrupt as e:\n"
        "    print('interrupted', e.log)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", script, os.path.dirname(__file__)], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert "interrupted ctrl-c.mcap" in out.stdout, out.stdout + out.stderr
    log = hb.open_log("ctrl-c.mcap")
    assert not log.truncated and log.frames[-1].stage_index == 2


def test_gsd_export_and_frames_as_gsd(small_log, tmp_path):
    gsd_hoomd = pytest.importorskip("gsd.hoomd", reason="the gsd package is not installed")
    path = tmp_path / "small.gsd"
    assert small_log.to_gsd(path) == len(small_log.frames)
    stats = small_log.stats
    with gsd_hoomd.open(path, "r") as trajectory:
        assert len(trajectory) == len(small_log.frames)
        last = trajectory[-1]
        assert np.allclose(last.particles.position, small_log.frames[-1].positions, atol=1e-6)
        rods = small_log.frames[0].species_of == 0
        for frame, g in zip(small_log.frames, trajectory):
            # The exact time and stage, and the log time in ns as the step.
            assert g.configuration.step == frame.log_time
            assert g.log["hardbody/stage_index"][0] == frame.stage_index
            if frame.time is None:
                assert np.isnan(g.log["hardbody/time"][0]) and g.log["hardbody/sweep"][0] == frame.sweep
            else:
                assert g.log["hardbody/time"][0] == frame.time
            # The pressure of the /stats message at the frame, where one is.
            at = (stats["log_time"] == frame.log_time) & (stats["stage_index"] == frame.stage_index)
            if at.any():
                np.testing.assert_equal(g.log["hardbody/pressure"][0], stats["pressure"][at][0])
            # Masses 1; rods 2 x 0.8 long, the principal moments of a solid
            # ellipsoid in the dynamics' frames (true inertia, the default),
            # their mean elsewhere (spherical tops); spheres not turning.
            assert np.all(g.particles.mass == 1.0)
            assert np.allclose(g.particles.diameter, np.where(rods, 1.6, 0.8))
            own = np.array([2 * 0.4**2, 0.8**2 + 0.4**2, 0.8**2 + 0.4**2]) / 5
            dynamics = isinstance(small_log.scene.stages[frame.stage_index], hb.Dynamics)
            moments = own if dynamics else own.mean()
            assert np.allclose(g.particles.moment_inertia[rods], moments, rtol=1e-6)
            assert np.all(g.particles.moment_inertia[~rods] == 0.0)
            if frame.angular_velocities is not None:
                # L_body from HOOMD's quaternion 2 q (0, L_body) is I w_body.
                q, p = frame.orientations, g.particles.angmom.astype(float)
                l_body = 0.5 * quaternion_product(q * [1, -1, -1, -1], p)
                assert np.allclose(l_body[:, 0], 0.0, atol=1e-5)
                w_body = rotate(q * [1, -1, -1, -1], frame.angular_velocities)
                expected = w_body * g.particles.moment_inertia
                assert np.allclose(l_body[rods, 1:], expected[rods], atol=1e-5)
    frame = small_log.frames[-1].to_gsd()
    assert frame.particles.N == 64 and frame.particles.types == ["rod", "ball"]
    out = tmp_path / "one.gsd"
    with gsd_hoomd.open(out, "w") as f:
        f.append(frame)
    with gsd_hoomd.open(out, "r") as f:
        assert np.allclose(f[0].particles.orientation, small_log.frames[-1].orientations, atol=1e-6)


def quaternion_product(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=1,
    )


def rotate(q, v):
    """v rotated by the unit quaternions q (rows)."""
    p = np.concatenate([np.zeros((len(v), 1)), v], axis=1)
    return quaternion_product(quaternion_product(q, p), q * [1, -1, -1, -1])[:, 1:]


def test_frames_go_to_freud(small_log):
    freud = pytest.importorskip("freud", reason="the freud-analysis package is not installed")
    frame = small_log.frames[-1]
    box = frame.freud_box()
    assert np.allclose([box.Lx, box.Ly, box.Lz], frame.box)
    # freud takes the positions as they are (no wrapping needed), and
    # finds the same neighbours as a brute-force minimum-image search.
    r_max = 1.5
    query = freud.locality.AABBQuery(box, frame.positions)
    pairs = {(i, j) for i, j in query.query(frame.positions, {"r_max": r_max, "exclude_ii": True}).toNeighborList()[:]}
    d = frame.positions[:, None, :] - frame.positions[None, :, :]
    d -= frame.box * np.round(d / frame.box)
    r = np.linalg.norm(d, axis=2)
    brute = {(i, j) for i, j in zip(*np.nonzero((r < r_max) & (r > 0)))}
    assert pairs == brute


def test_stages_after_a_jam_and_their_gsd_frames_have_the_grown_sizes(tmp_path):
    gsd_hoomd = pytest.importorskip("gsd.hoomd", reason="the gsd package is not installed")
    scene = hb.Scene(
        seed=3,
        box=(6.0, 6.0, 6.0),
        species=[hb.Species("rod", hb.Ellipsoid(0.6, 0.3, 0.3), 64)],
        stages=[
            hb.Jam(growth_rate=0.01, packing_fraction=0.35),
            hb.Dynamics(duration=0.5, stats_every=0.1, frames_every=0.25),
        ],
        log=hb.Log(path="grown.mcap"),
    )
    log = hb.run(scene, out=tmp_path / "grown.mcap", progress=False)
    # The a of the ellipsoids at which 64 of them fill 0.35 of the box.
    grown = 0.6 * (0.35 * 216.0 / (64 * 4 / 3 * np.pi * 0.6 * 0.3 * 0.3)) ** (1 / 3)
    after = [f for f in log.frames if f.stage_index == 1]
    assert after, "frames of the dynamics"
    stats = log.stats
    dynamics = stats["stage_index"] == 1
    assert np.allclose(stats["packing_fraction"][dynamics], 0.35, rtol=1e-9)
    path = tmp_path / "grown.gsd"
    assert log.to_gsd(path) == len(log.frames)
    with gsd_hoomd.open(path, "r") as trajectory:
        # The jam stage's first frame holds the scene's size.
        assert trajectory[0].particles.type_shapes[0]["a"] == pytest.approx(0.6)
        for frame, g in zip(log.frames, trajectory):
            a = g.particles.type_shapes[0]["a"]
            assert np.allclose(g.particles.diameter, 2 * a, rtol=1e-6)
            if frame.stage_index == 1:
                assert a == pytest.approx(grown, rel=1e-9)
