"""hardbody: dense packings and event-driven dynamics of hard ellipsoids,
superellipsoids, cuboids and spheres.

    import hardbody as hb
    scene = hb.Scene(box=(8, 8, 8),
                     species=[hb.Species("rod", hb.Ellipsoid(1.0, 0.5, 0.5), 64)],
                     stages=[hb.Compress(packing_fraction=0.4),
                             hb.MonteCarlo(hb.Nvt(), sweeps=2000),
                             hb.Dynamics(duration=10.0)])
    log = hb.run(scene, out="rods.mcap")
    log.frames[-1].positions      # numpy (N, 3)
    log.stats["pressure"]         # numpy, NaN where not measured

Arrays are numpy; quaternions are [w, x, y, z] from body to lab. The
README's "Python" section is the reference."""

from . import _core
from ._analyze import analyze
from ._core import LogError, RunError, SceneError
from ._free_energy import coexistence, free_energy
from ._log import Frame, RunLog, open_log
from ._run import resume, run
from ._simulation import Simulation
from ._scene import (
    Accuracy,
    Auto,
    Bcc,
    Cells,
    Crystal,
    Custom,
    Densest,
    Fcc,
    Hcp,
    Icosahedron,
    SimpleCubic,
    Triclinic,
    Compress,
    ConvexPolyhedron,
    Spheropolyhedron,
    Cube,
    Cuboid,
    Dodecahedron,
    Dynamics,
    Ellipsoid,
    Gaussian,
    Jam,
    Lattice,
    Layered,
    Lists,
    Log,
    LogNormal,
    MonteCarlo,
    Npt,
    Nvt,
    Octahedron,
    Random,
    Resume,
    Scene,
    SizeList,
    Species,
    Sphere,
    Spherocylinder,
    Superellipsoid,
    Tetrahedron,
    TruncatedOctahedron,
    Uniform,
)

__version__ = _core.__version__

__all__ = [
    "Accuracy", "Auto", "Bcc", "Cells", "Crystal", "Custom", "Densest", "Fcc", "Hcp",
    "SimpleCubic", "Triclinic", "Compress", "Cuboid", "Dynamics", "Ellipsoid", "Frame",
    "Jam", "Lattice", "Layered", "Lists", "Log", "LogError", "MonteCarlo", "Npt", "Nvt",
    "Random", "Resume", "RunError", "RunLog", "Scene", "SceneError", "Simulation", "Species", "Sphere", "Spherocylinder", "ConvexPolyhedron", "Spheropolyhedron",
    "Tetrahedron", "Cube", "Octahedron", "Dodecahedron", "Icosahedron", "TruncatedOctahedron",
    "Superellipsoid", "Gaussian", "LogNormal", "Uniform", "SizeList", "analyze", "coexistence", "free_energy", "open_log", "resume", "run",
]
