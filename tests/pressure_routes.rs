//! Three routes to one equation of state, for every shape: the
//! scale-distribution pressure of NVT Monte Carlo, the collision virial of
//! the dynamics at the same density, and the density NPT Monte Carlo gives
//! at that pressure. Each route starts from a compressed state as a scene
//! would, is averaged by `analyze` (equilibration cut off, errors with the
//! statistical inefficiency) over independent replicas, and the routes
//! must agree within three combined errors.
//!
//! `cargo test --release --test pressure_routes -- --ignored --nocapture`
//! runs it and prints the table (docs/pressure-routes.md has it);
//! `HARDBODY_LONG=1` makes every stage five times longer. CI runs every
//! shape at the lower density with stages a quarter as long.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use hardbody::analysis::series::Estimate;
use hardbody::geometry::Shape;
use hardbody::log::averages::stage_averages;
use hardbody::log::read::read_log;
use hardbody::run::{Silent, run_scene};
use hardbody::scene::Scene;
use rayon::prelude::*;

const SHAPES: [(&str, &str); 6] = [
    ("sphere", "Sphere(radius: 0.5)"),
    ("ellipsoid 2:1", "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)"),
    ("ellipsoid 1:2", "Ellipsoid(a: 0.5, b: 1.0, c: 1.0)"),
    (
        "superellipsoid p = 4",
        "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
    ),
    ("cube", "Cuboid(a: 0.5, b: 0.5, c: 0.5)"),
    ("cuboid 1:1:2", "Cuboid(a: 0.5, b: 0.5, c: 1.0)"),
];

const DENSITIES: [f64; 2] = [0.30, 0.45];

const REPLICAS: u64 = 2;

/// How a run of the test is sized: bodies per system, and a factor on
/// every stage's length.
#[derive(Clone, Copy)]
struct Size {
    bodies: usize,
    scale: f64,
}

/// A box for `bodies` bodies of `shape` at φ = 0.15 (compressed from).
fn box_edge(shape: &str, bodies: usize) -> f64 {
    let volume = shape.parse::<Shape>().unwrap().volume();
    (bodies as f64 * volume / 0.15).cbrt()
}

/// Runs `stages` on `bodies` bodies of `shape` and returns the averages
/// of stage `index`'s observable `name`.
fn route(
    tag: &str,
    (shape, bodies): (&str, usize),
    seed: u64,
    stages: &str,
    index: usize,
    name: &str,
) -> Estimate {
    let edge = box_edge(shape, bodies);
    let text = format!(
        r#"Scene(
    seed: {seed},
    box: ({edge}, {edge}, {edge}),
    species: [Species(name: "body", shape: {shape}, count: {bodies})],
    stages: [{stages}],
    log: Log(path: "unused.mcap", stats_every: 50, frames_every: 1000000),
)"#
    );
    let dir = std::env::temp_dir().join(format!("hardbody-routes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log: PathBuf = dir.join(format!("{tag}-{bodies}-{seed}.mcap"));
    let scene = Scene::parse(&text).unwrap_or_else(|e| panic!("{tag}: {e}"));
    run_scene(&scene, &text, &log, &mut Silent, &AtomicBool::new(false)).unwrap();
    let stats: Vec<_> = read_log(&log, false)
        .unwrap()
        .stats
        .into_iter()
        .map(|(_, s)| s)
        .collect();
    let _ = std::fs::remove_file(&log);
    let averages = stage_averages(&stats);
    let stage = averages.iter().find(|s| s.stage_index == index).unwrap();
    stage.observables[name].estimate
}

/// Mean over replicas, its error, and whether every replica
/// equilibrated.
fn over_replicas(estimates: &[Estimate]) -> (f64, f64, bool) {
    let a = hardbody::log::averages::over_replicas(estimates);
    (a.mean, a.error, a.equilibrated)
}

struct Row {
    name: &'static str,
    phi: f64,
    sdf: (f64, f64, bool),
    virial: (f64, f64, bool),
    npt_phi: (f64, f64, bool),
}

fn one_state_point(name: &'static str, shape: &str, phi: f64, size: Size) -> Row {
    let k = size.scale;
    let sweeps = |n: f64| (n * k).round() as u64;
    let body = (shape, size.bodies);
    let tag = format!("{}-{phi}", name.replace([' ', ':', '='], "_"));
    // Each route from a compressed state equilibrated by NVT sweeps that
    // are not measured: the lattice's aligned bodies lose their order
    // slowly (cuboids 1:1:2 at 0.45 drift for over 10⁴ sweeps).
    let start = format!(
        "Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: {})",
        sweeps(20000.0)
    );
    // NVT Monte Carlo, then dynamics, from the same state: spherical tops,
    // which leave the pressure (an equilibrium average) as it is, at less
    // cost than the bodies' own tensors.
    let nvt = format!(
        "{start}, MonteCarlo(ensemble: Nvt, sweeps: {}), Dynamics(duration: {}, stats_every: 0.25, true_inertia: false)",
        sweeps(6000.0),
        20.0 * k
    );
    let (sdf, virial): (Vec<_>, Vec<_>) = (0..REPLICAS)
        .map(|seed| {
            (
                route(&tag, body, 10 + seed, &nvt, 2, "pressure"),
                route(&tag, body, 10 + seed, &nvt, 3, "pressure"),
            )
        })
        .unzip();
    let (sdf, virial) = (over_replicas(&sdf), over_replicas(&virial));
    // NPT at the (more precise) collision-virial pressure, four times as
    // long as the other routes' stages: its density settles slowly from
    // the compressed start (5000 sweeps left ellipsoids 2:1 at φ = 0.30
    // short of equilibrium at some pressures), and its sweeps are cheap.
    let npt = format!(
        "{start}, MonteCarlo(ensemble: Npt(pressure: {}), sweeps: {})",
        virial.0,
        sweeps(80000.0)
    );
    let densities: Vec<_> = (0..REPLICAS)
        .map(|seed| route(&tag, body, 20 + seed, &npt, 2, "packing_fraction"))
        .collect();
    Row {
        name,
        phi,
        sdf,
        virial,
        npt_phi: over_replicas(&densities),
    }
}

/// 128 bodies (`HARDBODY_LONG=1`: every stage five times longer). 64
/// bodies fail it: at φ = 0.45 cubes and cuboids 1:1:2 do not equilibrate
/// in these lengths and the oblate ellipsoids' two pressures differ by
/// 3.5 errors (docs/pressure-routes.md).
#[test]
#[ignore = "about six minutes on two cores; the README says how to run it"]
fn three_pressure_routes_agree_for_every_shape() {
    let scale = if std::env::var_os("HARDBODY_LONG").is_some() {
        5.0
    } else {
        1.0
    };
    three_routes(Size { bodies: 128, scale }, &DENSITIES);
}

/// The CI-sized run: every shape at φ = 0.30, where 128 bodies
/// equilibrate fast, with every stage a quarter as long.
#[test]
fn three_pressure_routes_agree_for_every_shape_at_the_lower_density() {
    three_routes(
        Size {
            bodies: 128,
            scale: 0.25,
        },
        &DENSITIES[..1],
    );
}

fn three_routes(size: Size, densities: &[f64]) {
    let points: Vec<(&'static str, &'static str, f64)> = SHAPES
        .iter()
        .flat_map(|&(name, shape)| densities.iter().map(move |&phi| (name, shape, phi)))
        .collect();
    let rows: Vec<Row> = points
        .par_iter()
        .map(|&(name, shape, phi)| one_state_point(name, shape, phi, size))
        .collect();
    let mut table = vec![
        "| shape | φ | βP, SDF (NVT MC) | βP, collision virial (EDMD) | φ of NPT MC at the virial βP |".to_string(),
        "|---|---|---|---|---|".to_string(),
    ];
    let mut wrong = Vec::new();
    for r in &rows {
        let mark = |e: bool| if e { "" } else { " (not equilibrated)" };
        let line = format!(
            "| {} | {:.2} | {:.3} ± {:.3}{} | {:.3} ± {:.3}{} | {:.4} ± {:.4}{} |",
            r.name,
            r.phi,
            r.sdf.0,
            r.sdf.1,
            mark(r.sdf.2),
            r.virial.0,
            r.virial.1,
            mark(r.virial.2),
            r.npt_phi.0,
            r.npt_phi.1,
            mark(r.npt_phi.2)
        );
        if !(r.sdf.2 && r.virial.2 && r.npt_phi.2) {
            wrong.push(format!("{line}: a route did not equilibrate"));
        }
        let pressures_apart = (r.sdf.0 - r.virial.0).abs();
        let pressures_error = (r.sdf.1.powi(2) + r.virial.1.powi(2)).sqrt();
        if pressures_apart.is_nan() || pressures_apart > 3.0 * pressures_error {
            wrong.push(format!("{line}: the pressures differ"));
        }
        // The density error of NPT, and the virial pressure's error
        // carried into density (dφ/dβP from the EOS slope, bounded by
        // the ideal gas's φ/βP).
        let slope = r.phi / r.virial.0;
        let density_error = (r.npt_phi.1.powi(2) + (slope * r.virial.1).powi(2)).sqrt();
        let density_apart = (r.npt_phi.0 - r.phi).abs();
        if density_apart.is_nan() || density_apart > 3.0 * density_error {
            wrong.push(format!("{line}: the NPT density differs"));
        }
        table.push(line);
    }
    eprintln!("{} bodies:\n{}", size.bodies, table.join("\n"));
    assert!(
        wrong.is_empty(),
        "{}\n\n{}",
        wrong.join("\n"),
        table.join("\n")
    );
}
