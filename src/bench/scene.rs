//! `hardbody bench scene`: what the scene path costs a system that needs
//! none of its options. Hard spheres at φ = 0.45 (N = 500), the same start
//! run for the same simulated time twice, side by side and alternating:
//! `direct`, the dynamics built from the system with the library
//! ([`Dynamics::from_state`], sphere pairs in closed form) and nothing else;
//! `scene`, the full `hardbody run` path (scene parsed and validated, plan,
//! start read from a log, stats every 1/100 and frames every 1/20 of the
//! run, the log written and renamed). Time per collision, medians.

use super::markdown_table;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::BenchError;
use crate::bench::mc::dense_start;
use crate::edmd::dynamics::{Dynamics, DynamicsOptions};
use crate::geometry::Shape;
use crate::log::read::read_log;
use crate::log::{LogWriter, StateRecord};
use crate::run::{Silent, run_scene};
use crate::scene::Scene;

/// One row of the result.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SceneRow {
    /// `direct` or `scene`.
    pub algorithm: String,
    /// Shape, in the scene spelling.
    pub shape: String,
    /// Particles.
    pub n: usize,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// Collisions per run (median).
    pub collisions: u64,
    /// Median over repeats of wall time per collision.
    pub us_per_collision: f64,
    /// This path's median over the direct path's, from the same run.
    pub ratio_to_direct: f64,
    /// Threads used.
    pub threads: usize,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Runs the comparison; `quick` for CI smoke (shorter runs, 3 repeats).
pub fn run(quick: bool) -> Result<Vec<SceneRow>, BenchError> {
    let (collisions, repeats) = if quick { (20_000, 3) } else { (300_000, 7) };
    let shape: Shape = "Sphere(radius: 0.5)".parse().expect("a valid shape");
    let phi = 0.45;
    let system = dense_start(&shape, 500, phi)?;
    let n = system.len();
    let dir = std::env::temp_dir().join(format!("hardbody-bench-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| crate::log::file::OutputError::io(&dir, &e))?;
    // The start as a log, for the scene's Resume.
    let start = dir.join("start.mcap");
    let mut log = LogWriter::create(&start, "", "", system.species())?;
    log.frame(
        0,
        &StateRecord::of_particles(system.periodic_box(), system.species(), system.particles()),
    )?;
    log.finish()?;
    // Simulated time for about `collisions` collisions, from a first run.
    // The neighbour lists the scene picks by itself.
    let options = DynamicsOptions {
        neighbour_shell: crate::edmd::automatic_neighbour_shell(
            system.species(),
            system.packing_fraction(),
            system.sizes().is_some(),
        ),
        ..DynamicsOptions::default()
    };
    let mut probe = Dynamics::from_state(&system, &options, &mut Pcg64::seed_from_u64(1))?;
    probe.run_collisions(collisions)?;
    let duration = probe.time();
    let l = system.periodic_box().lengths().x;
    let text = format!(
        "Scene(box: ({l}, {l}, {l}), species: [Species(name: {:?}, shape: {shape}, count: {n})], \
         start: Resume({:?}), stages: [Dynamics(duration: {duration})], log: Log(path: \"unused.mcap\"))",
        system.species()[0].name,
        start.display().to_string()
    );
    let mut direct = Vec::new();
    let mut scene_path = Vec::new();
    let mut counts = (Vec::new(), Vec::new());
    for r in 0..repeats {
        let seed = 100 + r as u64;
        let clock = Instant::now();
        let mut d = Dynamics::from_state(&system, &options, &mut Pcg64::seed_from_u64(seed))?;
        d.run_until(duration)?;
        let c = d.collisions();
        direct.push(clock.elapsed().as_secs_f64() * 1e6 / c as f64);
        counts.0.push(c as f64);

        let clock = Instant::now();
        let scene = Scene::parse(&text)?.with_seed(seed);
        let out = dir.join("scene.mcap");
        run_scene(&scene, &text, &out, &mut Silent, &AtomicBool::new(false))?;
        let elapsed = clock.elapsed().as_secs_f64();
        let log = read_log(&out, false)?;
        let c = log
            .stats
            .last()
            .and_then(|(_, s)| s.collisions)
            .ok_or_else(|| BenchError::Wrong {
                system: "the scene".into(),
                what: "logged no collisions".into(),
            })?;
        scene_path.push(elapsed * 1e6 / c as f64);
        counts.1.push(c as f64);
    }
    let _ = std::fs::remove_dir_all(&dir);
    let (d, s) = (median(direct), median(scene_path));
    let row = |algorithm: &str, us: f64, c: Vec<f64>| SceneRow {
        algorithm: algorithm.into(),
        shape: shape.to_string(),
        n,
        packing_fraction: phi,
        collisions: median(c) as u64,
        us_per_collision: us,
        ratio_to_direct: us / d,
        threads: 1,
    };
    Ok(vec![row("direct", d, counts.0), row("scene", s, counts.1)])
}

/// The suite's table in Markdown.
pub fn table(rows: &[SceneRow]) -> String {
    let columns = [
        "path",
        "shape",
        "N",
        "phi",
        "collisions",
        "us/collision (median)",
        "ratio to direct",
    ];
    markdown_table(
        &columns,
        rows.iter().map(|r| {
            vec![
                r.algorithm.to_string(),
                r.shape.to_string(),
                r.n.to_string(),
                format!("{:.2}", r.packing_fraction),
                r.collisions.to_string(),
                format!("{:.3}", r.us_per_collision),
                format!("{:.3}", r.ratio_to_direct),
            ]
        }),
    )
}
