//! A scene run from a program: the same path as `hardbody run`, with the
//! scene written in code and the log read back afterwards.
//!
//! `cargo run --release --example scene_from_code` (a few seconds); writes
//! `scene-from-code.mcap` in the current directory.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use hardbody::log::read::read_log;
use hardbody::run::{Silent, run_scene};
use hardbody::scene::Scene;

const SCENE: &str = r#"Scene(
    seed: 5,
    box: (10.0, 10.0, 10.0),
    species: [
        Species(name: "oblate", shape: Ellipsoid(a: 0.5, b: 0.5, c: 0.25), count: 150),
    ],
    stages: [
        Compress(packing_fraction: 0.40),
        MonteCarlo(ensemble: Nvt, sweeps: 1000),
        Dynamics(duration: 2.0, stats_every: 0.2, c2: true),
    ],
    log: Log(path: "scene-from-code.mcap", stats_every: 100, frames_every: 500),
)"#;

fn main() {
    let scene = Scene::parse(SCENE).unwrap_or_else(|e| panic!("{e}"));
    let path = Path::new(&scene.log.path);
    let summary = run_scene(&scene, SCENE, path, &mut Silent, &AtomicBool::new(false))
        .unwrap_or_else(|e| panic!("{e}"));
    for line in &summary.stages {
        println!("{line}");
    }
    let log = read_log(path, false).expect("the log just written");
    println!("time | collisions | betaP | S2 | C2");
    for (_, s) in log.stats.iter().filter(|(_, s)| s.stage == "dynamics") {
        println!(
            "{:.1} | {} | {:.3} | {:.3} | {:.3}",
            s.time.unwrap_or(0.0),
            s.collisions.unwrap_or(0),
            s.pressure.unwrap_or(f64::NAN),
            s.nematic_order.unwrap_or(f64::NAN),
            s.c2.unwrap_or(f64::NAN)
        );
    }
}
