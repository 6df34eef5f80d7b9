"""Reading a log's frames into numpy: hardbody.open_log against the
standard `mcap` Python reader with JSON decoding of /state, on the same
log, interleaved (A B A B), one core.

    pip install . mcap          # at the repository root
    taskset -c 0 python benches/python/read_frames.py [--frames 1000] [--particles 10000]

makes the log first (hard spheres at phi = 0.3, a frame every sweep) in
target/bench-read/ unless it is there, then times each reader three
times and prints the medians and their ratio. Figures go to
docs/benchmarks/.
"""

import argparse
import json
import os
import pathlib
import statistics
import time

import numpy as np

import hardbody as hb


def make_log(path: pathlib.Path, frames: int, particles: int) -> None:
    side = round(particles ** (1 / 3))
    count = side**3
    # Spheres of radius 0.5 at phi = 0.3 from a lattice.
    edge = (count * (4 / 3) * np.pi * 0.125 / 0.3) ** (1 / 3)
    scene = hb.Scene(
        box=(edge, edge, edge),
        species=[hb.Species("ball", hb.Sphere(0.5), count)],
        stages=[hb.MonteCarlo(hb.Nvt(), sweeps=frames - 1, tune_sweeps=0)],
        log=hb.Log(stats_every=10, frames_every=1),
    )
    hb.run(scene, out=path, progress=False)


def with_hardbody(path):
    log = hb.open_log(path)
    return np.stack([f.positions for f in log.frames]), np.stack([f.orientations for f in log.frames])


def with_mcap(path):
    from mcap.reader import make_reader

    positions, orientations = [], []
    with open(path, "rb") as f:
        for _, _, message in make_reader(f).iter_messages(topics=["/state"]):
            state = json.loads(message.data)
            positions.append(np.asarray(state["positions"], dtype=np.float64))
            orientations.append(np.asarray(state["orientations"], dtype=np.float64))
    return np.stack(positions), np.stack(orientations)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--particles", type=int, default=10000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    root = pathlib.Path(__file__).resolve().parents[2]
    directory = root / "target" / "bench-read"
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"spheres-{args.particles}-{args.frames}.mcap"
    if not path.exists():
        print(f"making {path} ...", flush=True)
        make_log(path, args.frames, args.particles)
    size = os.path.getsize(path)
    times = {"hardbody": [], "mcap+json": []}
    shapes = {}
    for _ in range(args.repeats):
        for name, read in [("hardbody", with_hardbody), ("mcap+json", with_mcap)]:
            start = time.perf_counter()
            p, q = read(path)
            times[name].append(time.perf_counter() - start)
            shapes[name] = (p.shape, q.shape, float(p.sum()), float(q.sum()))
    assert shapes["hardbody"] == shapes["mcap+json"], shapes
    frames, n, _ = shapes["hardbody"][0]
    print(f"{path.name}: {size / 1e6:.0f} MB, {frames} frames of {n} particles")
    for name, t in times.items():
        print(f"{name:>10}: median {statistics.median(t):.2f} s of {[round(x, 2) for x in t]}")
    ratio = statistics.median(times["mcap+json"]) / statistics.median(times["hardbody"])
    print(f"hardbody.open_log is {ratio:.1f}x faster than mcap + json.loads")


if __name__ == "__main__":
    main()
