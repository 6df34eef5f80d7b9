"""Scenes between Python and RON: round trips, and refusals raised as
`SceneError` naming the field."""

import json
import subprocess

import numpy as np
import pytest

import hardbody as hb
from conftest import SCENES, small_scene
from test_run import hardbody_cli


def test_a_scene_built_in_python_round_trips_through_ron(scene):
    text = scene.to_ron()
    again = hb.Scene.from_ron(text)
    assert again == scene
    assert again.to_ron() == text
    assert again.species[0].shape == hb.Ellipsoid(0.8, 0.4, 0.4)
    assert again.stages[1] == hb.MonteCarlo(hb.Npt(pressure=2.0), sweeps=100)
    assert isinstance(again.start, hb.Lattice)
    assert again.particle_count == 64


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.ron")), ids=lambda p: p.name)
def test_every_shipped_scene_loads_and_round_trips(path):
    scene = hb.Scene.load(path)
    # A scene read and not changed gives its own text back.
    assert scene.to_ron() == path.read_text()
    # Rebuilt from its Python objects, it is the same scene.
    rebuilt = hb.Scene(
        box=scene.box,
        species=scene.species,
        stages=scene.stages,
        seed=scene.seed,
        walls=scene.walls,
        start=scene.start,
        log=scene.log,
        accuracy=scene.accuracy,
    )
    assert rebuilt == scene
    assert hb.Scene.from_ron(rebuilt.to_ron()) == scene


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.ron")), ids=lambda p: p.name)
def test_the_plan_is_the_one_the_command_line_prints(path):
    plan = hb.Scene.load(path).plan()
    printed = subprocess.run([hardbody_cli(), "check", "--json", str(path)], capture_output=True, text=True)
    assert printed.returncode == 0, printed.stderr
    assert plan == json.loads(printed.stdout)
    assert [s["stage"] for s in plan["stages"]] == list(range(len(hb.Scene.load(path).stages)))


def test_every_shape_and_stage_kind_is_spelled_as_in_ron():
    scene = hb.Scene(
        box=(12, 12, 12),
        walls=["z"],
        species=[
            hb.Species("s", hb.Sphere(0.5), 4),
            hb.Species("e", hb.Ellipsoid(0.6, 0.5, 0.4), 4),
            hb.Species("p", hb.Superellipsoid(0.5, 0.5, 0.5, (4.0, 4.0, 2.0)), 4, mass=2.0),
            hb.Species("c", hb.Cuboid(0.5, 0.4, 0.3), 4, rotation=False),
        ],
        start=hb.Layered("x"),
        stages=[
            hb.Compress(packing_fraction=0.1, max_sweeps=5000),
            hb.MonteCarlo(hb.Npt(pressure=1.0, anisotropic=True), sweeps=10, tune_sweeps=5),
            hb.Dynamics(duration=1.0, temperature=2.0, frames_every=0.5, msd=True, c2=True),
        ],
        accuracy=hb.Accuracy(neighbours=hb.Lists(shell=0.3)),
    )
    text = scene.to_ron()
    for spelled in [
        "Superellipsoid(",
        "exponents: (4.0, 4.0, 2.0)",
        "Cuboid(",
        "Layered(X)",
        "walls: [\n        Z,",
        "Npt(",
        "anisotropic: true",
        "Lists(",
        "frames_every: 0.5",
    ]:
        assert spelled in text, spelled
    assert hb.Scene.from_ron(text) == scene


def test_a_spherocylinder_round_trips_and_is_refused_for_dynamics_with_an_ellipsoid():
    rods = [hb.Species("rod", hb.Spherocylinder(radius=0.5, length=2.0), 8)]
    scene = hb.Scene(box=(12, 12, 12), species=rods, stages=[hb.Dynamics(duration=1.0)])
    assert "Spherocylinder(" in scene.to_ron()
    assert hb.Scene.from_ron(scene.to_ron()) == scene
    assert scene.plan()["pairs"][0]["distance"].startswith("closed form")
    bricks = [hb.Species("brick", hb.Cuboid(0.5, 0.4, 0.3), 8)]
    hb.Scene(box=(12, 12, 12), species=rods + bricks, stages=[hb.Dynamics(duration=1.0)])
    with pytest.raises(hb.SceneError) as e:
        spheroids = [hb.Species("spheroid", hb.Ellipsoid(1.0, 0.5, 0.5), 8)]
        hb.Scene(box=(12, 12, 12), species=rods + spheroids, stages=[hb.Dynamics(duration=1.0)])
    assert e.value.field == "stages[0]"
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(box=(12, 12, 12), species=[hb.Species("rod", hb.Spherocylinder(0.5, 0.0), 8)], stages=[])
    assert "length must be" in str(e.value)


def test_a_convex_polyhedron_round_trips_and_bad_vertices_are_refused():
    tetra = hb.ConvexPolyhedron([(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)])
    scene = hb.Scene(box=(12, 12, 12), species=[hb.Species("t", tetra, 8)],
                     stages=[hb.MonteCarlo(ensemble=hb.Nvt(), sweeps=10)])
    assert "ConvexPolyhedron(" in scene.to_ron()
    assert hb.Scene.from_ron(scene.to_ron()) == scene
    assert scene.plan()["pairs"][0]["distance"] == "GJK/EPA"
    with pytest.raises(hb.SceneError) as e:
        flat = hb.ConvexPolyhedron([(1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0)])
        hb.Scene(box=(12, 12, 12), species=[hb.Species("f", flat, 8)], stages=[])
    assert "one plane" in str(e.value)
    hb.Scene(box=(12, 12, 12), species=[hb.Species("t", tetra, 8)], stages=[hb.Dynamics(duration=1.0)])
    with pytest.raises(hb.SceneError) as e:
        spheroids = [hb.Species("spheroid", hb.Ellipsoid(1.0, 0.5, 0.5), 8)]
        hb.Scene(box=(12, 12, 12), species=[hb.Species("t", tetra, 8)] + spheroids,
                 stages=[hb.Dynamics(duration=1.0)])
    assert e.value.field == "stages[0]"
    named = hb.Scene(box=(12, 12, 12), species=[hb.Species("o", hb.Octahedron(edge=1.0), 8)],
                     stages=[hb.MonteCarlo(ensemble=hb.Nvt(), sweeps=10)])
    assert "Octahedron(" in named.to_ron() and "vertices" not in named.to_ron()
    assert hb.Scene.from_ron(named.to_ron()) == named


def test_a_spheropolyhedron_round_trips_and_a_bad_radius_is_refused():
    corners = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
    rounded = hb.Spheropolyhedron(corners, 0.25)
    scene = hb.Scene(box=(12, 12, 12), species=[hb.Species("t", rounded, 8)],
                     stages=[hb.MonteCarlo(ensemble=hb.Nvt(), sweeps=10)])
    assert "Spheropolyhedron(" in scene.to_ron()
    assert hb.Scene.from_ron(scene.to_ron()) == scene
    assert "between the cores" in scene.plan()["pairs"][0]["distance"]
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(box=(12, 12, 12), species=[hb.Species("t", hb.Spheropolyhedron(corners, -0.1), 8)], stages=[])
    assert "radius must be" in str(e.value)
    hb.Scene(box=(12, 12, 12), species=[hb.Species("t", rounded, 8)], stages=[hb.Dynamics(duration=1.0)])
    with pytest.raises(hb.SceneError) as e:
        spheroids = [hb.Species("spheroid", hb.Ellipsoid(1.0, 0.5, 0.5), 8)]
        hb.Scene(box=(12, 12, 12), species=[hb.Species("t", rounded, 8)] + spheroids,
                 stages=[hb.Dynamics(duration=1.0)])
    assert e.value.field == "stages[0]" and "spheropolyhedron" in str(e.value)


def test_refusals_name_the_field_as_the_command_line_does():
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(box=(8, 8, 8), species=[hb.Species("a", hb.Sphere(0.5), 0)], stages=[])
    assert e.value.field == "species[0].count"
    assert isinstance(e.value, ValueError)
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(box=(8, 8, 8), species=[hb.Species("a", hb.Ellipsoid(1.0, -0.5, 0.5), 3)], stages=[])
    assert "b must be" in str(e.value)
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(box=(8, 8, 8), species=[hb.Species("a", hb.Sphere("big"), 3)], stages=[])
    assert e.value.field == "species[0].shape.Sphere.radius"
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(
            box=(8, 8, 8),
            species=[hb.Species("a", hb.Sphere(0.5), 10)],
            stages=[hb.Compress(packing_fraction=0.9)],
        )
    assert "densest" in str(e.value)
    with pytest.raises(hb.SceneError) as e:
        hb.Scene(
            box=(8, 8, 8),
            species=[hb.Species("a", hb.Sphere(0.5), 10)],
            stages=[hb.Jam(growth_rate=0.01, fluid_rate=0.5)],
        )
    assert e.value.field == "stages[0].fluid_rate"
    jam = hb.Scene(
        box=(8, 8, 8),
        species=[hb.Species("a", hb.Sphere(0.5), 200)],
        stages=[hb.Jam(growth_rate=0.01, fluid_rate=0.05)],
    )
    assert "fluid_rate: Some(0.05)" in jam.to_ron() or "fluid_rate: 0.05" in jam.to_ron()
    with pytest.raises(hb.SceneError, match="must be a finite number"):
        hb.Scene(box=(8, 8, float("nan")), species=[hb.Species("a", hb.Sphere(0.5), 1)], stages=[])
    with pytest.raises(hb.SceneError):
        hb.Scene(box=(8, 8, 8), species=[hb.Species("a", hb.Sphere(0.5), 1)], stages=[], start="grid")


def test_ron_refusals_name_the_line():
    text = small_scene().to_ron().replace("count: 48", "count: 0")
    with pytest.raises(hb.SceneError) as e:
        hb.Scene.from_ron(text)
    assert e.value.field == "species[0].count"
    assert e.value.line is not None and f"line {e.value.line}" in str(e.value)
    assert "count: 0" in text.splitlines()[e.value.line - 1]
    with pytest.raises(hb.SceneError) as e:
        hb.Scene.from_ron(text.replace("count: 0", "count: 3, colour: 1"))
    assert "colour" in str(e.value) and e.value.line is not None


def test_a_scene_file_that_does_not_parse_names_the_file(tmp_path):
    path = tmp_path / "bad.ron"
    path.write_text("Scene(box: (1.0, 1.0))")
    with pytest.raises(hb.SceneError, match="bad.ron"):
        hb.Scene.load(path)
    with pytest.raises(FileNotFoundError):
        hb.Scene.load(tmp_path / "missing.ron")


def test_polydisperse_sizes_and_swaps_round_trip_run_and_read_back(tmp_path):
    sizes = [hb.Gaussian(0.1), hb.LogNormal(0.2), hb.Uniform(0.8, 1.2), hb.SizeList([1.0, 1.1, 0.9, 1.2])]
    for spread in sizes:
        scene = hb.Scene(
            box=(8, 8, 8),
            species=[hb.Species("s", hb.Sphere(0.5), 4, sizes=spread)],
            start=hb.Random(),
            stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10, swaps=0.5)],
        )
        text = scene.to_ron()
        assert "sizes:" in text and "swaps: 0.5" in text, text
        assert hb.Scene.from_ron(text) == scene
    with pytest.raises(hb.SceneError, match=r"species\[0\]\.sizes"):
        hb.Scene(box=(8, 8, 8), species=[hb.Species("s", hb.Sphere(0.5), 4, sizes=hb.Gaussian(0.4))],
                 stages=[hb.MonteCarlo(hb.Nvt(), sweeps=10)])
    scene = hb.Scene(
        seed=4,
        box=(9, 9, 9),
        species=[hb.Species("s", hb.Sphere(0.5), 200, sizes=hb.Gaussian(0.1))],
        start=hb.Random(),
        stages=[hb.Compress(packing_fraction=0.3), hb.MonteCarlo(hb.Nvt(), sweeps=200, swaps=0.25)],
        log=hb.Log(path=str(tmp_path / "poly.mcap"), stats_every=50, frames_every=100),
    )
    log = hb.run(scene, progress=False)
    first, last = log.frames[0], log.frames[-1]
    assert first.sizes.shape == (200,) and first.sizes.dtype == np.float64
    assert abs(first.sizes.mean() - 1.0) < 0.05 and 0.05 < first.sizes.std() < 0.15
    # Swaps exchange sizes among the bodies, never change them.
    assert np.array_equal(np.sort(last.sizes), np.sort(first.sizes))
    assert not np.array_equal(last.sizes, first.sizes)
    volume = (np.pi / 6 * last.sizes**3).sum() / np.prod(last.box)
    assert abs(volume - 0.3) < 1e-9
    assert np.allclose(last.to_gsd().particles.diameter, last.sizes, rtol=1e-6)


def test_polydisperse_ellipsoids_run_monte_carlo_and_dynamics(tmp_path):
    rods = [hb.Species("e", hb.Ellipsoid(0.8, 0.5, 0.4), 100, sizes=hb.Uniform(0.8, 1.2))]
    scene = hb.Scene(
        seed=8,
        box=(12, 12, 12),
        species=rods,
        start=hb.Random(),
        stages=[
            hb.Compress(packing_fraction=0.3),
            hb.MonteCarlo(hb.Nvt(), sweeps=100, swaps=0.5),
            hb.Dynamics(duration=1.0, frames_every=0.5),
        ],
        log=hb.Log(path=str(tmp_path / "ellipsoids.mcap"), stats_every=50, frames_every=50),
    )
    log = hb.run(scene, progress=False)
    first = log.frames[0]
    swapped = [f for f in log.frames if f.stage == "monte_carlo"][-1]
    assert np.array_equal(np.sort(swapped.sizes), np.sort(first.sizes))
    assert not np.array_equal(swapped.sizes, first.sizes)
    volume = (4 / 3 * np.pi * 0.8 * 0.5 * 0.4 * swapped.sizes**3).sum() / np.prod(swapped.box)
    assert abs(volume - 0.3) < 1e-9
    # The dynamics moves each body at its own size: the sizes travel with
    # the bodies, and the bodies move.
    moving = [f for f in log.frames if f.stage == "dynamics"]
    assert moving
    for frame in moving:
        assert np.array_equal(frame.sizes, swapped.sizes)
    assert not np.allclose(moving[-1].positions, swapped.positions)


def test_polydisperse_spheres_run_dynamics_and_grow_with_their_sizes(tmp_path):
    scene = hb.Scene(
        seed=6,
        box=(8, 8, 8),
        species=[hb.Species("s", hb.Sphere(0.5), 150, sizes=hb.Uniform(0.8, 1.2))],
        start=hb.Random(),
        stages=[
            hb.Compress(packing_fraction=0.35),
            hb.Dynamics(duration=2.0, frames_every=1.0),
            hb.Jam(growth_rate=0.01, packing_fraction=0.55),
        ],
        log=hb.Log(path=str(tmp_path / "grow.mcap"), stats_every=50, frames_every=100),
    )
    log = hb.run(scene, progress=False)
    moving = [f for f in log.frames if f.stage == "dynamics"]
    grown = [f for f in log.frames if f.stage == "jam"]
    assert moving and grown
    drawn = log.frames[0].sizes
    for frame in moving + grown:
        # The dynamics and the growth keep every body's own size.
        assert np.array_equal(frame.sizes, drawn)
        assert frame.velocities is not None
    # The species grew; each body is its grown shape at its own size.
    last = grown[-1]
    radius = last.species[0].shape.radius * last.sizes
    assert last.species[0].shape.radius > 0.5
    phi = (4 / 3 * np.pi * radius**3).sum() / np.prod(last.box)
    assert abs(phi - 0.55) < 1e-9, phi
