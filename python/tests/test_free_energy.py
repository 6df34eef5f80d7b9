"""Free energies from Python: the same results as the command line's
JSON, and the same refusals."""

import math

import pytest

import hardbody as hb


def fcc_scene(tmp_path, packing_fraction=0.5450190):
    return hb.Scene(
        species=[hb.Species("s", hb.Sphere(0.5), 108)],
        start=hb.Crystal(hb.Fcc(), cells=(3, 3, 3), packing_fraction=packing_fraction),
        stages=[hb.MonteCarlo(hb.Nvt(), sweeps=200)],
        log=hb.Log(str(tmp_path / "fcc.mcap"), stats_every=100, frames_every=100),
    )


def test_a_crystal_free_energy_comes_back_as_the_commands_json(tmp_path):
    r = hb.free_energy(fcc_scene(tmp_path), points=4, sweeps=1000, progress=False)
    assert r["method"] == "frenkel_ladd"
    assert r["n"] == 108
    assert len(r["path"]) == 4
    # Polson et al.'s thermodynamic limit less the N = 108 shift, loosely.
    assert abs(r["excess_free_energy_per_particle"] - 5.86) < 0.05
    assert r["error"] > 0
    assert abs(r["packing_fraction"] - 0.545019) < 1e-5
    assert (tmp_path / "fcc.mcap").exists()


def test_springs_for_a_crystal_too_weak_are_refused(tmp_path):
    with pytest.raises(ValueError, match="too weak"):
        hb.free_energy(fcc_scene(tmp_path), points=4, sweeps=200, spring=5.0, progress=False)


def test_a_fluid_given_as_the_solid_is_refused(tmp_path):
    fluid = hb.Scene(
        box=(8.0, 8.0, 8.0),
        species=[hb.Species("s", hb.Sphere(0.5), 108)],
        stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10)],
        log=hb.Log(str(tmp_path / "fluid.mcap"), stats_every=10, frames_every=10),
    )
    other = hb.Scene.from_ron(fluid.to_ron().replace("fluid.mcap", "other.mcap"))
    with pytest.raises(ValueError, match="no lattice to tether"):
        hb.coexistence(fluid, other, progress=False)
    assert not (tmp_path / "fluid.mcap").exists()
    with pytest.raises(ValueError, match="both log to"):
        hb.coexistence(fluid, fluid, progress=False)
