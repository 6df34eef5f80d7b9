"""Scenes as Python objects: the shapes, species, stages and settings of a
RON scene, one class each, spelled as in RON. A `Scene` is checked by the
same validation as the command line's (in Rust) when it is made, and
refusals raise `SceneError` naming the field."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, fields
from typing import Any, List, Optional, Sequence, Tuple, Union

from . import _core

SceneError = _core.SceneError


# Enum variants of the RON scene: the class name is the RON name.
_VARIANTS: dict = {}


def _variant(cls):
    _VARIANTS[_ron_name(cls)] = cls
    return cls


def _ron_name(cls) -> str:
    """The variant's name in RON (a class may spell it otherwise in Python,
    where the RON name would shadow a builtin or a typing name)."""
    return getattr(cls, "_ron", cls.__name__)


def _encode(value: Any) -> Any:
    """The JSON serde reads for `value` (externally tagged enums)."""
    if isinstance(value, _Unit):
        return _ron_name(type(value))
    if isinstance(value, _Newtype):
        return {_ron_name(type(value)): _encode(value._inner())}
    if hasattr(value, "__dataclass_fields__"):
        body = {f.name: _encode(getattr(value, f.name)) for f in fields(value)}
        name = _ron_name(type(value))
        return {name: body} if _VARIANTS.get(name) is type(value) else body
    if isinstance(value, (list, tuple)):
        return [_encode(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if hasattr(value, "item") and callable(value.item):  # numpy scalars
        return value.item()
    return value


def _decode(value: Any) -> Any:
    """Python objects for the JSON of an enum value."""
    if isinstance(value, str) and value in _VARIANTS:
        return _VARIANTS[value]()
    if isinstance(value, dict) and len(value) == 1:
        (name, body), = value.items()
        cls = _VARIANTS.get(name)
        if cls is not None:
            if issubclass(cls, _Newtype):
                return cls(body)
            return cls(**{k: _decode(v) for k, v in body.items()})
    return value


class _Unit:
    """A variant without fields (`Lattice`, `Nvt`)."""

    def __eq__(self, other):
        return type(self) is type(other)

    def __hash__(self):
        return hash(type(self).__name__)

    def __repr__(self):
        return f"{type(self).__name__}()"


class _Newtype:
    """A variant with one unnamed value (`Resume("x.mcap")`)."""

    def _inner(self):
        raise NotImplementedError


# Shapes -------------------------------------------------------------------


@_variant
@dataclass
class Sphere:
    """A sphere of radius `radius`."""

    radius: float


@_variant
@dataclass
class Ellipsoid:
    """An ellipsoid with semi-axes a, b, c along body x, y, z."""

    a: float
    b: float
    c: float


@_variant
@dataclass
class Superellipsoid:
    """|x/a|^n + |y/b|^m + |z/c|^p = 1, with `exponents` (n, m, p), each >= 2."""

    a: float
    b: float
    c: float
    exponents: Tuple[float, float, float]


@_variant
@dataclass
class Cuboid:
    """A cuboid with half-lengths a, b, c along body x, y, z."""

    a: float
    b: float
    c: float


@_variant
@dataclass
class Spherocylinder:
    """A cylinder of `length` along body z capped by hemispheres of `radius`."""

    radius: float
    length: float


@_variant
@dataclass
class ConvexPolyhedron:
    """The convex hull of `vertices` (4 to 64 points (x, y, z)), which must
    hold the body origin; the body's centre is the hull's centroid."""

    vertices: List[Tuple[float, float, float]]


@_variant
@dataclass
class Spheropolyhedron:
    """The convex hull of `vertices` (as ConvexPolyhedron) swept by a ball of
    `radius` > 0: every point within `radius` of the hull (rounded cubes)."""

    vertices: List[Tuple[float, float, float]]
    radius: float


@_variant
@dataclass
class Tetrahedron:
    """The regular tetrahedron of edge `edge`, a convex polyhedron."""

    edge: float


@_variant
@dataclass
class Cube:
    """The cube of edge `edge` as a convex polyhedron (`Cuboid` is the same body, faster)."""

    edge: float


@_variant
@dataclass
class Octahedron:
    """The regular octahedron of edge `edge`, a convex polyhedron."""

    edge: float


@_variant
@dataclass
class Dodecahedron:
    """The regular dodecahedron of edge `edge`, a convex polyhedron."""

    edge: float


@_variant
@dataclass
class Icosahedron:
    """The regular icosahedron of edge `edge`, a convex polyhedron."""

    edge: float


@_variant
@dataclass
class TruncatedOctahedron:
    """The truncated octahedron of edge `edge`, a convex polyhedron."""

    edge: float


Shape = Union[
    Sphere, Ellipsoid, Superellipsoid, Cuboid, Spherocylinder, ConvexPolyhedron, Spheropolyhedron,
    Tetrahedron, Cube, Octahedron, Dodecahedron, Icosahedron, TruncatedOctahedron,
]


# Size distributions (polydisperse bodies) -----------------------------------


@_variant
@dataclass
class Gaussian:
    """Sizes normal with mean 1 and deviation `std` (< 1/3), cut at 1 ± 3 std."""

    std: float


@_variant
@dataclass
class LogNormal:
    """Sizes log-normal with mean 1 and standard deviation `std`."""

    std: float


@_variant
@dataclass
class Uniform:
    """Sizes uniform on [`min`, `max`], 0 < min <= max."""

    min: float
    max: float


@_variant
class SizeList(_Newtype):
    """One size per body (RON `List([...])`)."""

    _ron = "List"

    def __init__(self, sizes: Sequence[float]):
        self.sizes = [float(s) for s in sizes]

    def _inner(self):
        return self.sizes

    def __eq__(self, other):
        return isinstance(other, SizeList) and other.sizes == self.sizes

    def __repr__(self):
        return f"SizeList({self.sizes!r})"


SizeDistribution = Union[Gaussian, LogNormal, Uniform, SizeList]


@dataclass
class Species:
    """A kind of particle: `count` bodies of `shape`, named `name`;
    `mass` (dynamics), `rotation` (False freezes orientations) and
    `sizes`: a distribution of the bodies' scale factors (`Gaussian(0.1)`,
    ...; drawn from the scene's seed; every stage takes them for every
    shape)."""

    name: str
    shape: Shape
    count: int
    mass: float = 1.0
    rotation: bool = True
    sizes: Optional[SizeDistribution] = None


# Starts -------------------------------------------------------------------


@_variant
class Lattice(_Unit):
    """Particles on a simple lattice filling the box, random orientations."""


@_variant
class Random(_Unit):
    """Random sequential insertion, random orientations."""


@_variant
class Resume(_Newtype):
    """The last complete state of an earlier log."""

    def __init__(self, path: Union[str, os.PathLike]):
        self.path = os.fspath(path)

    def _inner(self):
        return self.path

    def __eq__(self, other):
        return isinstance(other, Resume) and other.path == self.path

    def __repr__(self):
        return f"Resume({self.path!r})"


@_variant
class Layered(_Newtype):
    """A lattice with the species in layers along `axis` ("x", "y" or "z")."""

    def __init__(self, axis: str):
        self.axis = _axis(axis)

    def _inner(self):
        return self.axis

    def __eq__(self, other):
        return isinstance(other, Layered) and other.axis == self.axis

    def __repr__(self):
        return f"Layered({self.axis!r})"


# Crystals ----------------------------------------------------------------


@dataclass
class Triclinic:
    """A tilted box: edges (Lx, Ly, Lz) and tilt factors (xy, xz, yz),
    HOOMD-blue's convention."""

    lengths: Tuple[float, float, float]
    tilts: Tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        self.lengths = tuple(float(x) for x in self.lengths)
        self.tilts = tuple(float(x) for x in self.tilts)


@_variant
class Fcc(_Unit):
    """Face-centred cubic, the conventional cubic cell (4 sites)."""


@_variant
class Bcc(_Unit):
    """Body-centred cubic, the conventional cubic cell (2 sites)."""


@_variant
class Hcp(_Unit):
    """Hexagonal close packing, its orthorhombic cell (4 sites)."""


@_variant
class SimpleCubic(_Unit):
    """One site per cubic cell."""


@_variant
class Densest(_Unit):
    """The densest known lattice packing of the first species' shape."""


@_variant
@dataclass
class Custom:
    """Any lattice: three right-handed vectors, sites in fractional
    coordinates in [0, 1), optionally one quaternion (w, x, y, z) per site."""

    vectors: Sequence[Tuple[float, float, float]]
    basis: Sequence[Tuple[float, float, float]]
    orientations: Sequence[Tuple[float, float, float, float]] = ()

    def __post_init__(self):
        rows = lambda rs: [tuple(float(x) for x in r) for r in rs]  # noqa: E731
        self.vectors, self.basis = rows(self.vectors), rows(self.basis)
        self.orientations = rows(self.orientations)


@_variant
@dataclass
class Crystal:
    """A crystal start: `cells` unit cells of `lattice` scaled to
    `packing_fraction`; its supercell is the box (give no `box`)."""

    lattice: Any
    cells: Tuple[int, int, int]
    packing_fraction: float

    def __post_init__(self):
        self.cells = tuple(self.cells)


def _axis(axis: str) -> str:
    return axis.upper() if isinstance(axis, str) else axis


# Stages -------------------------------------------------------------------


@_variant
class Nvt(_Unit):
    """Constant volume."""


@_variant
@dataclass
class Npt:
    """Constant pressure betaP (1/length^3); `box_moves` is "Isotropic"
    (the default), "Axes" (one edge at a time; `anisotropic=True` is the
    same) or "Triclinic" (edges and shears)."""

    pressure: float
    anisotropic: bool = False
    box_moves: Optional[str] = None


@_variant
@dataclass
class Compress:
    """Monte Carlo compression to a packing fraction (or to a pressure)."""

    packing_fraction: Optional[float] = None
    pressure: Optional[float] = None
    max_sweeps: Optional[int] = None
    until_jammed: bool = False


@_variant
@dataclass
class MonteCarlo:
    """Metropolis Monte Carlo: `sweeps` sweeps in `ensemble` (`Nvt()` or
    `Npt(pressure)`); move sizes tuned over `tune_sweeps`; the pressure
    tensor by the scale distribution in `/stats` with `pressure_tensor`;
    `swaps` size swaps per body per sweep (polydisperse species)."""

    ensemble: Union[Nvt, Npt]
    sweeps: int
    tune_sweeps: Optional[int] = None
    pressure_tensor: bool = False
    swaps: float = 0.0


@_variant
@dataclass
class Dynamics:
    """Event-driven molecular dynamics for `duration` time units at kT =
    `temperature`."""

    duration: float
    temperature: float = 1.0
    stats_every: Optional[float] = None
    frames_every: Optional[float] = None
    true_inertia: bool = True
    msd: bool = False
    c2: bool = False


@_variant
@dataclass
class Jam:
    """Event-driven growth to a jammed packing (to βPV/N = `pressure`), or
    to `packing_fraction`; the stages after it go on with the grown
    bodies."""

    growth_rate: Optional[float] = None
    pressure: Optional[float] = None
    packing_fraction: Optional[float] = None
    fluid_rate: Optional[float] = None


Stage = Union[Compress, MonteCarlo, Dynamics, Jam]


@dataclass
class Log:
    """Where the log goes (`path`) and how often: `stats_every` and
    `frames_every` sweeps in Monte Carlo stages."""

    path: str = "run.mcap"
    stats_every: int = 100
    frames_every: int = 1000


@_variant
class Auto(_Unit):
    """The neighbour structure the dynamics picks for the packing."""


@_variant
class Cells(_Unit):
    """Linked cells."""


@_variant
@dataclass
class Lists:
    """Neighbour lists with bounding spheres grown by `shell`."""

    shell: float


@dataclass
class Accuracy:
    """Accuracy knobs of the event-driven dynamics (docs/ACCURACY.md)."""

    grazing_threshold: Optional[float] = None
    contact_tolerance: Optional[float] = None
    newton_tolerance: Optional[float] = None
    neighbours: Union[Auto, Cells, Lists] = field(default_factory=Auto)


def _ensemble(value):
    if isinstance(value, str):
        if value.lower() == "nvt":
            return Nvt()
        raise SceneError(f"ensemble: {value!r} is not an ensemble (Nvt() or Npt(pressure))")
    return value


def _start(value):
    if isinstance(value, str):
        named = {"lattice": Lattice, "random": Random}.get(value.lower())
        if named is None:
            raise SceneError(
                f"start: {value!r} is not a start (\"lattice\", \"random\", Resume(path) or Layered(axis))"
            )
        return named()
    return value


class Scene:
    """What to simulate, in which stages, logged where: the RON scene
    (README, "Scenes") as Python objects.

    A `Crystal` start makes the box; otherwise `box` is the edges
    `(Lx, Ly, Lz)` or a `Triclinic(lengths, tilts)`.

    >>> scene = Scene(box=(8, 8, 8),
    ...               species=[Species("rod", Ellipsoid(1.0, 0.5, 0.5), 64)],
    ...               stages=[Compress(packing_fraction=0.4),
    ...                       MonteCarlo(Nvt(), sweeps=1000)])

    A scene is checked when it is made (and again when it runs); a
    refusal raises `SceneError` with the field (`species[0].count`)."""

    def __init__(
        self,
        box: Union[Sequence[float], Triclinic, None] = None,
        species: Sequence[Species] = (),
        stages: Sequence[Stage] = (),
        seed: int = 1,
        walls: Sequence[str] = (),
        start: Union[str, Lattice, Random, Resume, Layered] = "lattice",
        log: Optional[Log] = None,
        accuracy: Optional[Accuracy] = None,
    ):
        self.box = box if box is None or isinstance(box, Triclinic) else tuple(box)
        self.species = list(species)
        self.stages = list(stages)
        self.seed = seed
        self.walls = [_axis(w) for w in walls]
        self.start = _start(start)
        self.log = log if log is not None else Log()
        self.accuracy = accuracy
        self._text: Optional[str] = None
        self._text_json: Optional[str] = None
        self._path: Optional[str] = None
        self.check()

    # The JSON the Rust scene reads.
    def _json(self) -> str:
        for stage in self.stages:
            if isinstance(stage, MonteCarlo):
                stage.ensemble = _ensemble(stage.ensemble)
        body = {
            "seed": self.seed,
            "walls": [_axis(w) for w in self.walls],
            "species": _encode(self.species),
            "start": _encode(_start(self.start)),
            "stages": _encode(self.stages),
            "log": _encode(self.log),
        }
        if self.box is not None:
            body["box"] = _encode(self.box)
        if self.accuracy is not None:
            accuracy = {k: v for k, v in _encode(self.accuracy).items() if v is not None}
            body["accuracy"] = accuracy
        for field, value in _non_finite(body, ""):
            raise SceneError(f"{field}: must be a finite number, got {value}")
        try:
            return json.dumps(body, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise SceneError(f"the scene holds a value a scene cannot: {e}") from None

    def check(self) -> None:
        """Validates the scene as the command line does; raises
        `SceneError` naming the field."""
        _core.scene_from_json(self._json())

    def plan(self) -> dict:
        """The plan, as `hardbody check --json` prints it: species, pair
        kernels, effects, and per stage the neighbour structure its driver
        will be built with (a run records the same entry per stage in its
        log's `hardbody.stage` metadata). Raises `SceneError` as `check`."""
        return json.loads(_core.scene_plan(self._json()))

    @classmethod
    def _from_json(cls, text: str) -> "Scene":
        d = json.loads(text)
        scene = cls.__new__(cls)
        box = d.get("box")
        scene.box = Triclinic(**box) if isinstance(box, dict) else None if box is None else tuple(box)
        scene.species = [
            Species(
                s["name"], _decode(s["shape"]), s["count"], s["mass"], s["rotation"], _decode(s.get("sizes"))
            )
            for s in d["species"]
        ]
        scene.stages = [_decode(s) for s in d["stages"]]
        scene.seed = d["seed"]
        scene.walls = list(d["walls"])
        scene.start = _decode(d["start"])
        scene.log = Log(**d["log"])
        a = d["accuracy"]
        scene.accuracy = Accuracy(
            a["grazing_threshold"], a["contact_tolerance"], a["newton_tolerance"], _decode(a["neighbours"])
        )
        scene._text = None
        scene._text_json = None
        scene._path = None
        return scene

    @classmethod
    def from_ron(cls, text: str) -> "Scene":
        """Reads RON scene text (a scene file's contents); `SceneError`
        names the line and field of a refusal."""
        scene = cls._from_json(_core.scene_from_ron(text))
        scene._text = text
        scene._text_json = scene._json()
        return scene

    @classmethod
    def load(cls, path: Union[str, os.PathLike]) -> "Scene":
        """Reads the scene file at `path`."""
        path = os.fspath(path)
        with open(path, encoding="utf-8") as f:
            text = f.read()
        try:
            scene = cls.from_ron(text)
        except SceneError as e:
            error = SceneError(f"{path}: {e}")
            error.field, error.line = getattr(e, "field", None), getattr(e, "line", None)
            raise error from None
        scene._path = path
        return scene

    def to_ron(self) -> str:
        """The scene as RON text, as a scene file holds it. A scene read
        from RON and not changed since gives its own text back."""
        current = self._json()
        if self._text is not None and current == self._text_json:
            return self._text
        return _core.scene_to_ron(current)

    def __eq__(self, other):
        if not isinstance(other, Scene):
            return NotImplemented
        return _core.scene_from_json(self._json()) == _core.scene_from_json(other._json())

    def __repr__(self):
        return (
            f"Scene(box={self.box!r}, species={self.species!r}, stages={self.stages!r}, "
            f"seed={self.seed!r}, walls={self.walls!r}, start={self.start!r}, log={self.log!r})"
        )

    @property
    def particle_count(self) -> int:
        """Number of particles."""
        return sum(s.count for s in self.species)


def _non_finite(value: Any, path: str):
    """(field, value) of every NaN or infinity in the JSON body `value`,
    the field named as the scene file names it (`species[0].shape.radius`:
    an enum's variant is left out of the path)."""
    if isinstance(value, float) and not math.isfinite(value):
        yield path, value
    elif isinstance(value, dict):
        variant = len(value) == 1 and next(iter(value)) in _VARIANTS
        for key, inner in value.items():
            yield from _non_finite(inner, path if variant else f"{path}.{key}".lstrip("."))
    elif isinstance(value, (list, tuple)):
        for k, inner in enumerate(value):
            yield from _non_finite(inner, f"{path}[{k}]")
