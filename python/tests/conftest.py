"""Shared set-up of the Python package's tests: a small scene, run once."""

import os
import pathlib

import pytest

import hardbody as hb

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "data" / "scenes"


def small_scene(**log) -> hb.Scene:
    """48 rods and 16 spheres: compression, NPT, NVT, dynamics (a second)."""
    return hb.Scene(
        seed=5,
        box=(9.0, 9.0, 9.0),
        species=[
            hb.Species("rod", hb.Ellipsoid(0.8, 0.4, 0.4), 48),
            hb.Species("ball", hb.Sphere(0.4), 16),
        ],
        stages=[
            hb.Compress(packing_fraction=0.30),
            hb.MonteCarlo(hb.Npt(pressure=2.0), sweeps=100),
            hb.MonteCarlo(hb.Nvt(), sweeps=100),
            hb.Dynamics(duration=0.5, stats_every=0.1, frames_every=0.25),
        ],
        log=hb.Log(path="small.mcap", stats_every=20, frames_every=50, **log),
    )


@pytest.fixture
def scene():
    return small_scene()


@pytest.fixture(scope="session")
def small_log(tmp_path_factory):
    """The small scene run once; its log."""
    out = tmp_path_factory.mktemp("run") / "small.mcap"
    return hb.run(small_scene(), out=out, progress=False)


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path
