"""Crystals from Python: a Crystal start and a Triclinic box round-trip
through RON, run, and their frames carry the tilts to freud and GSD."""

import numpy as np
import pytest

import hardbody as hb


def primitive_fcc(packing_fraction=0.6):
    return hb.Crystal(
        hb.Custom(vectors=[(0, 0.5, 0.5), (0.5, 0, 0.5), (0.5, 0.5, 0)], basis=[(0, 0, 0)]),
        cells=(6, 6, 6),
        packing_fraction=packing_fraction,
    )


def crystal_scene(tmp_path):
    return hb.Scene(
        species=[hb.Species("s", hb.Sphere(0.5), 216)],
        start=primitive_fcc(),
        stages=[hb.MonteCarlo(hb.Npt(20.0, box_moves="Triclinic"), sweeps=300)],
        log=hb.Log(str(tmp_path / "crystal.mcap"), stats_every=50, frames_every=100),
    )


def test_a_crystal_scene_round_trips_through_ron(tmp_path):
    scene = crystal_scene(tmp_path)
    again = hb.Scene.from_ron(scene.to_ron())
    assert again.start == scene.start
    assert again.box is None
    tilted = hb.Scene(
        box=hb.Triclinic((9.0, 9.0, 9.0), (0.2, 0.0, -0.1)),
        species=[hb.Species("s", hb.Sphere(0.5), 10)],
        stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10)],
    )
    assert hb.Scene.from_ron(tilted.to_ron()).box == tilted.box
    measured = hb.Scene(
        species=[hb.Species("s", hb.Sphere(0.5), 216)],
        start=primitive_fcc(),
        stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10, pressure_tensor=True)],
    )
    assert "pressure_tensor: true" in measured.to_ron()
    assert hb.Scene.from_ron(measured.to_ron()) == measured


def test_densest_superballs_are_built_and_mixed_exponents_refused():
    def superballs(exponents):
        return hb.Scene(
            species=[hb.Species("b", hb.Superellipsoid(0.5, 0.5, 0.5, exponents), 125)],
            start=hb.Crystal(hb.Densest(), cells=(5, 5, 5), packing_fraction=0.9),
            stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10)],
        )
    superballs((6.0, 6.0, 6.0))
    with pytest.raises(hb.SceneError, match="exponents differ"):
        superballs((4.0, 4.0, 6.0))


def test_a_tilted_crystal_runs_and_its_frames_carry_the_tilts(tmp_path):
    log = hb.run(crystal_scene(tmp_path), out=str(tmp_path / "crystal.mcap"), progress=False)
    frame = log.frames[-1]
    assert frame.tilts.shape == (3,)
    assert np.any(frame.tilts != 0.0)
    freud = pytest.importorskip("freud")
    box = frame.freud_box()
    assert box.xy == pytest.approx(frame.tilts[0])
    # Every centre lies in the box: fractional coordinates in [0, 1).
    fractional = box.make_fractional(frame.positions)
    assert np.all((fractional >= -1e-12) & (fractional < 1 + 1e-12))
    del freud


def test_crystal_refusals_name_the_field():
    with pytest.raises(hb.SceneError, match="start"):
        hb.Scene(species=[hb.Species("s", hb.Sphere(0.5), 216)], start=primitive_fcc(0.75),
                 stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10)])
    with pytest.raises(hb.SceneError, match="box"):
        hb.Scene(box=(20, 20, 20), species=[hb.Species("s", hb.Sphere(0.5), 216)],
                 start=primitive_fcc(), stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10)])
