"""hardbody from Python: prolate ellipsoids compressed, equilibrated at
constant pressure and run with event-driven dynamics; then their g(r) and
Q6 with freud and their mean-squared displacement with numpy, plotted with
matplotlib.

    pip install .                      # at the repository root
    pip install freud-analysis matplotlib
    python examples/python/tutorial.py --out tutorial

writes tutorial/rods.mcap (open it in Foxglove or Lichtblick),
tutorial/tutorial.png and tutorial/tutorial.json. About 20 s on one core;
--quick runs a small system in a few seconds.
"""

import argparse
import json
import pathlib

import freud
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hardbody as hb  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="tutorial", help="directory for the log, plot and summary")
    parser.add_argument("--quick", action="store_true", help="64 rods and short stages")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    # 1. The scene: 2:1 prolate ellipsoids (semi-axes 1, 0.5, 0.5) on a
    # dilute lattice, compressed by Monte Carlo to phi = 0.40, equilibrated
    # at betaP = 3, then followed by event-driven dynamics at kT = 1.
    count, sweeps, duration = (64, 2000, 5.0) if args.quick else (343, 20000, 20.0)
    scene = hb.Scene(
        seed=3,
        box=(16.0, 16.0, 16.0),
        species=[hb.Species("rod", hb.Ellipsoid(1.0, 0.5, 0.5), count)],
        stages=[
            hb.Compress(packing_fraction=0.40),
            hb.MonteCarlo(hb.Npt(pressure=3.0), sweeps=sweeps),
            hb.Dynamics(duration=duration, msd=True, stats_every=0.25, frames_every=0.25),
        ],
        log=hb.Log(stats_every=100, frames_every=1000),
    )
    print(scene.to_ron())

    # 2. Run it: a progress bar per stage; the log comes back opened.
    log = hb.run(scene, out=out / "rods.mcap")
    for line in log.summary["stages"]:
        print(line)

    # 3. The density at betaP = 3, with an error that accounts for
    # correlation, from the part of the NPT stage that had equilibrated.
    averages = hb.analyze(log)
    npt = next(s for s in averages["stages"] if s["stage_index"] == 1)
    phi = npt["observables"]["packing_fraction"]
    print(f"NPT at betaP = 3: phi = {phi['mean']:.4f} +- {phi['error']:.4f}")

    # 4. Structure of the last frame with freud: the box and the positions
    # go in as they are.
    last = log.frames[-1]
    box = last.freud_box()
    r_max = 0.45 * float(np.min(last.box))
    rdf = freud.density.RDF(bins=60, r_max=r_max).compute((box, last.positions))
    q6 = freud.order.Steinhardt(6).compute((box, last.positions), neighbors={"num_neighbors": 12})

    # 5. Mean-squared displacement from the dynamics frames with numpy:
    # frames 0.25 apart, displacements unwrapped by the minimum image.
    frames = [f for f in log.frames if f.stage_index == 2]
    times = np.array([f.time for f in frames])
    positions = np.stack([f.positions for f in frames])
    lengths = frames[0].box
    steps = np.diff(positions, axis=0)
    steps -= lengths * np.round(steps / lengths)
    displacement = np.concatenate([np.zeros((1, count, 3)), np.cumsum(steps, axis=0)])
    msd = np.mean(np.sum(displacement**2, axis=2), axis=1)
    # The same from the log's /stats (the dynamics tracks it exactly).
    in_dynamics = log.stats["stage_index"] == 2
    stats_time, stats_msd = log.stats["time"][in_dynamics], log.stats["msd"][in_dynamics]
    at_frames = np.interp(stats_time, times, msd)
    worst = float(np.max(np.abs(at_frames - stats_msd) / np.maximum(stats_msd, 1e-300)))
    print(f"MSD at t = {times[-1]:g}: {msd[-1]:.4f} (numpy) vs {stats_msd[-1]:.4f} (/stats)")

    figure, (a, b, c) = plt.subplots(1, 3, figsize=(13, 4))
    a.plot(rdf.bin_centers, rdf.rdf)
    a.set(xlabel="r", ylabel="g(r)", title="centres (freud)")
    b.hist(q6.particle_order, bins=20)
    b.set(xlabel="$q_6$", ylabel="bodies", title="Steinhardt $q_6$, 12 neighbours (freud)")
    c.plot(times, msd, "o", label="numpy, from frames")
    c.plot(stats_time, stats_msd, "-", label="/stats")
    c.set(xlabel="t", ylabel="MSD", title="mean-squared displacement")
    c.legend()
    figure.tight_layout()
    figure.savefig(out / "tutorial.png", dpi=100)

    summary = {
        "packing_fraction": phi["mean"],
        "packing_fraction_error": phi["error"],
        "q6_mean": float(np.mean(q6.particle_order)),
        "rdf_peak_r": float(rdf.bin_centers[np.argmax(rdf.rdf)]),
        "msd_final": float(msd[-1]),
        "msd_worst_relative_difference": worst,
        "frames": len(log.frames),
    }
    (out / "tutorial.json").write_text(json.dumps(summary, indent=2))
    print(f"wrote {out / 'tutorial.png'} and {out / 'tutorial.json'}")


if __name__ == "__main__":
    main()
