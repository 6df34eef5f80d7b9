"""Reads a GSD file exported by `hardbody export LOG --gsd OUT` with the
Python `gsd` package and checks it against the log's /state frames (read
with the standard `mcap` reader): frame count, box, positions, orientations
(w, x, y, z in both), type ids and names, and one type shape per species of
the kind HOOMD's schema names for it.

usage: python3 tests/python/read_gsd.py LOG.mcap OUT.gsd
"""
import json
import sys

import gsd.hoomd
import numpy
from mcap.reader import make_reader

KIND = {"Sphere": "Sphere", "Ellipsoid": "Ellipsoid", "Cuboid": "ConvexPolyhedron",
        "Superellipsoid": "Mesh"}


def main(log, out):
    with open(log, "rb") as f:
        states = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=["/state"])]
    trajectory = gsd.hoomd.open(out)
    assert len(trajectory) == len(states), (len(trajectory), len(states))
    for frame, state in zip(trajectory, states):
        n = len(state["positions"])
        assert frame.particles.N == n, (frame.particles.N, n)
        f32 = lambda x: numpy.array(x, dtype=numpy.float32)
        assert (frame.configuration.box[:3] == f32(state["box"])).all()
        assert (frame.particles.position == f32(state["positions"])).all()
        assert (frame.particles.orientation == f32(state["orientations"])).all()
        assert list(frame.particles.typeid) == state["species_of"]
        assert frame.particles.types == [s["name"] for s in state["species"]]
        shapes = frame.particles.type_shapes
        assert len(shapes) == len(state["species"])
        for shape, species in zip(shapes, state["species"]):
            kind = next(iter(species["shape"]))
            assert shape["type"] == KIND[kind], (shape, kind)
            if kind == "Ellipsoid":
                e = species["shape"][kind]
                assert (shape["a"], shape["b"], shape["c"]) == (e["a"], e["b"], e["c"])
            if kind == "Cuboid":
                assert len(shape["vertices"]) == 8
            if kind == "Mesh":
                assert len(shape["indices"]) > 0
        if state["velocities"] is not None:
            assert (frame.particles.velocity == f32(state["velocities"])).all()
    print(json.dumps({"frames": len(trajectory)}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
