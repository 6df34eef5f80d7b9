//! Hard-sphere dynamics, time per collision: hardbody against Frank
//! Smallenburg's event-driven codes (github FSmallenburg/EDMD, MIT; "Efficient
//! event-driven simulations of hard spheres", Eur. Phys. J. E 45, 22 (2022)),
//! from the same simple-cubic start, one core, measured side by side in one
//! run, interleaved (ours, theirs, ours, theirs): hardbody with neighbour
//! lists against his single-event code (`Single`), hardbody with cells
//! against his cell code (`Cell`).
//!
//! Run with `taskset -c 0 cargo bench --bench edmd` from `benches/peers/`
//! (one core for both; `QUICK=1`: a short run; `REPEATS=N`, default 3;
//! `ONLY_OURS=1`: hardbody's list run alone (`ONLY_OURS=cells`: its cell
//! run), to profile or to time two
//! builds of it against each other, from a start written here; `N=32000`,
//! `PHI=0.45`: another count or packing fraction, from a start written
//! here the way `gen_sc.py` writes its own). His source is read from
//! `../shared/peers/smallenburg-edmd` beside the repository (or
//! `SMALLENBURG_EDMD`), copied under `target/`, patched with its
//! measurement patch (command-line run time, shell and input; the wall
//! clock on each output line; thermostat off) and built with its own
//! flags (`-Ofast -march=native`). Nothing of it is copied into this
//! repository. The start: its `gen_sc.py` (4000 spheres at φ = 0.5 on a
//! simple-cubic lattice with random vacancies). Both codes draw their own
//! Maxwell–Boltzmann velocities at kT = 1. Each side is timed from its
//! first output (t = 1) to the end, so that neither's set-up counts.
//! Each pair ends with the median of the per-repeat ratios and the ratio
//! of the two fastest runs (on a shared machine, those least slowed by
//! other work).

use std::path::{Path, PathBuf};
use std::process::Command;

use hardbody_peers::{run, smallenburg_source};
use std::time::Instant;

use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::geometry::{Shape, Sphere};
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, Species, System};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;

/// hardbody's neighbour shell with lists (σ/4, its best at φ = 0.5;
/// another with `OUR_SHELL`) and the peer's (1 + α = 1.5 σ, its default).
const OUR_SHELL: f64 = 0.25;
const THEIR_SHELL: &str = "1.5";

/// The peer's codes, patched and built under `target/`; the folder.
fn build_peer() -> PathBuf {
    let source = smallenburg_source();
    assert!(
        source.join("Single/mdSingle.c").exists(),
        "Smallenburg's EDMD source not found at {} (set SMALLENBURG_EDMD)",
        source.display()
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/smallenburg-edmd");
    let _ = std::fs::remove_dir_all(&dir);
    run(Command::new("cp").arg("-r").arg(&source).arg(&dir));
    run(Command::new("patch")
        .args(["-p0", "-i", "smallenburg_measurement.patch"])
        .current_dir(&dir));
    for code in ["Single", "Cell"] {
        run(Command::new("make").current_dir(dir.join(code)));
    }
    dir
}

/// Time per collision (µs) from the peer's output lines
/// `Wall: w Simtime: t, Collisions: c, ...`: from t = 1 to the last.
fn their_time_per_collision(output: &str) -> (f64, u64) {
    let points: Vec<(f64, u64)> = output
        .lines()
        .filter_map(|line| {
            let mut words = line.strip_prefix("Wall: ")?.split_whitespace();
            let wall = words.next()?.parse().ok()?;
            let time: f64 = line
                .split("Simtime: ")
                .nth(1)?
                .split(',')
                .next()?
                .parse()
                .ok()?;
            let collisions = line.split("Collisions: ").nth(1)?.split(',').next()?;
            (time >= 1.0 - 1e-9).then_some((wall, collisions.trim().parse().ok()?))
        })
        .collect();
    let (first, last) = (points.first().unwrap(), points.last().unwrap());
    let collisions = last.1 - first.1;
    ((last.0 - first.0) * 1e6 / collisions as f64, collisions)
}

/// A start in the peer's format as its `gen_sc.py` makes them, for any
/// `n` and `phi`: `n` spheres of diameter 1 on randomly chosen sites of
/// the smallest simple-cubic lattice with room for them, in the cube
/// that they fill to `phi`.
fn write_simple_cubic(path: &Path, n: usize, phi: f64, seed: u64) {
    use rand::seq::SliceRandom;
    let edge = (n as f64 * std::f64::consts::PI / 6.0 / phi).cbrt();
    let sites_per_edge = (1..).find(|a: &usize| a.pow(3) >= n).unwrap();
    let spacing = edge / sites_per_edge as f64;
    assert!(spacing > 1.0, "phi = {phi} leaves no room on a lattice");
    let mut sites: Vec<usize> = (0..sites_per_edge.pow(3)).collect();
    sites.shuffle(&mut rand_pcg::Pcg64::seed_from_u64(seed));
    let mut text = format!("{n}\n{edge:.12} {edge:.12} {edge:.12}\n");
    for &site in &sites[..n] {
        let a = sites_per_edge;
        let (i, j, k) = (site % a, (site / a) % a, site / (a * a));
        let at = |x: usize| (x as f64 + 0.5) * spacing;
        text += &format!("a {:.12} {:.12} {:.12} 0.5\n", at(i), at(j), at(k));
    }
    std::fs::write(path, text).unwrap();
}

/// The start the peer reads, as a hardbody system.
fn read_sph(path: &Path) -> System {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let n: usize = lines.next().unwrap().trim().parse().unwrap();
    let l: Vec<f64> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    let box_ = PeriodicBox::new(Vector3::new(l[0], l[1], l[2])).unwrap();
    let particles: Vec<Particle> = lines
        .take(n)
        .map(|line| {
            let f: Vec<f64> = line
                .split_whitespace()
                .skip(1)
                .map(|x| x.parse().unwrap())
                .collect();
            let centred = Vector3::new(f[0], f[1], f[2]) - Vector3::new(l[0], l[1], l[2]) / 2.0;
            Particle {
                position: box_.minimum_image(&centred),
                orientation: UnitQuaternion::identity(),
                species: 0,
            }
        })
        .collect();
    let species = vec![Species {
        name: "sphere".into(),
        shape: Shape::Sphere(Sphere::new(0.5).unwrap()),
        rotation: false,
    }];
    System::new(box_, species, particles).unwrap()
}

/// hardbody's time per collision (µs) from t = 1 to `duration`.
fn our_time_per_collision(
    system: &System,
    shell: Option<f64>,
    duration: f64,
    seed: u64,
) -> (f64, u64) {
    let options = DynamicsOptions {
        neighbour_shell: shell,
        ..DynamicsOptions::default()
    };
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut dynamics = Dynamics::from_state(system, &options, &mut rng).unwrap();
    dynamics.run_until(1.0).unwrap();
    let first = dynamics.collisions();
    let started = Instant::now();
    dynamics.run_until(duration).unwrap();
    let collisions = dynamics.collisions() - first;
    (
        started.elapsed().as_secs_f64() * 1e6 / collisions as f64,
        collisions,
    )
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

fn main() {
    let quick = std::env::var_os("QUICK").is_some();
    let repeats: usize = std::env::var("REPEATS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let duration = if quick { 10.0 } else { 75.0 };
    let only_ours = std::env::var_os("ONLY_OURS").is_some();
    // Alone, hardbody starts from a start written here (the peer is not
    // built, so that repeated runs time nothing else).
    let peer = if only_ours {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/edmd-alone");
        std::fs::create_dir_all(&dir).unwrap();
        dir
    } else {
        build_peer()
    };
    let init = peer.join("init.sph");
    let our_shell: f64 = std::env::var("OUR_SHELL")
        .ok()
        .map_or(OUR_SHELL, |s| s.parse().expect("OUR_SHELL: a length"));
    let n: Option<usize> = std::env::var("N")
        .ok()
        .map(|n| n.parse().expect("N: a count"));
    let phi: Option<f64> = std::env::var("PHI")
        .ok()
        .map(|p| p.parse().expect("PHI: a packing fraction"));
    if n.is_none() && phi.is_none() && !only_ours {
        run(Command::new("python3")
            .args(["gen_sc.py", "1", "init.sph"])
            .current_dir(&peer));
    } else {
        write_simple_cubic(&init, n.unwrap_or(4000), phi.unwrap_or(0.5), 1);
    }
    let system = read_sph(&init);
    println!(
        "hard spheres N = {}, phi = {:.4}, t = 1 to {duration}, one core, {repeats} interleaved repeats",
        system.len(),
        system.packing_fraction()
    );
    println!(
        "| pair | repeat | hardbody us/collision | peer us/collision | ratio | collisions (ours, theirs) |"
    );
    println!("|---|---|---|---|---|---|");
    if only_ours {
        // For a profiler: hardbody's list run alone (`ONLY_OURS=cells`: its
        // cell run).
        let cells = std::env::var("ONLY_OURS").is_ok_and(|v| v == "cells");
        let (shell, name) = if cells {
            (None, "cells")
        } else {
            (Some(our_shell), "lists")
        };
        let (ours, collisions) = our_time_per_collision(&system, shell, duration, 1);
        println!("hardbody alone, {name}: {ours:.3} us/collision over {collisions} collisions");
        return;
    }
    for (name, shell, code) in [
        ("lists / Single", Some(our_shell), "Single"),
        ("cells / Cell", None, "Cell"),
    ] {
        let mut ratios = Vec::new();
        // The fastest run of each: on a shared machine, the one least
        // slowed by other work.
        let (mut our_fastest, mut their_fastest) = (f64::INFINITY, f64::INFINITY);
        for repeat in 0..repeats {
            let (ours, our_collisions) =
                our_time_per_collision(&system, shell, duration, repeat as u64 + 1);
            let output = run(Command::new("./md")
                .args([&duration.to_string(), THEIR_SHELL])
                .arg(&init)
                .current_dir(peer.join(code)));
            let (theirs, their_collisions) = their_time_per_collision(&output);
            ratios.push(ours / theirs);
            our_fastest = our_fastest.min(ours);
            their_fastest = their_fastest.min(theirs);
            println!(
                "| {name} | {repeat} | {ours:.3} | {theirs:.3} | {:.3} | {our_collisions}, {their_collisions} |",
                ours / theirs
            );
        }
        println!(
            "{name}: median ratio hardbody / peer {:.3}; fastest against fastest {:.3}",
            median(ratios),
            our_fastest / their_fastest
        );
    }
}
