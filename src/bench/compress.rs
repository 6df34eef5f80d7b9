//! `hardbody bench compress`: seconds and sweeps of Monte Carlo compression
//! (one thread) from a dilute fluid to a target packing fraction.
//!
//! Three tables: the reference systems of the comparison with hoomd-mc
//! (4096 spheres, 1000 cubes, 1000 ellipsoids 2.5:0.5:0.5, to φ = 0.5);
//! the shapes of the MC suite to 0.55 / 0.60 (a cuboid–sphere mixture to
//! 0.45); and time per particle against N from 10³ to 10⁵ for spheres and
//! ellipsoids 2:1:1 to 0.5. Every start is the dilute lattice (random
//! orientations, φ ≤ 0.1) melted by 20 sweeps (a perfect lattice of
//! spheres shrinks to 0.52 without a move); every end state is checked to
//! be overlap-free through the neighbour structure, and by all pairs below
//! 5000 bodies.

use super::markdown_table;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::BenchError;
use super::plot::{Figure, Series, line_plot};
use crate::geometry::Shape;
use crate::log::file::OutputError;
use crate::mc::compress::{CompressOptions, compress};
use crate::mc::moves::{Ensemble, MoveSizes, sweep};
use crate::state::{Species, System};

/// One compression of the benchmark.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CompressRow {
    /// Which table: `reference`, `suite` or `scaling`.
    pub table: &'static str,
    /// Species, in the scene spelling.
    pub shape: String,
    /// Particles.
    pub n: usize,
    /// Packing fraction reached (the target).
    pub packing_fraction: f64,
    /// Sweeps it took.
    pub sweeps: u64,
    /// Wall-clock seconds it took.
    pub seconds: f64,
    /// Seconds per particle.
    pub seconds_per_particle: f64,
    /// Threads used.
    pub threads: usize,
}

/// n³ bodies of `shapes` (assigned in turn) on the dilute lattice, melted
/// by 20 sweeps: the start of every compression here and of the
/// comparison with hoomd-mc.
pub fn dilute_start(shapes: &[Shape], n: usize, seed: u64) -> Result<System, BenchError> {
    let species: Vec<Species> = shapes
        .iter()
        .map(|shape| Species {
            name: shape.kind().into(),
            shape: *shape,
            rotation: !shape.is_sphere(),
        })
        .collect();
    let kinds = species.len();
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut system =
        crate::state::start::dilute_lattice(n, species, |i| (i % kinds) as u16, &mut rng)?;
    let melt = MoveSizes {
        translate: 0.5,
        rotate: 0.5,
        volume: 0.0,
        shear: 0.01,
    };
    for _ in 0..20 {
        sweep(&mut system, &melt, &Ensemble::Nvt, &mut rng);
    }
    Ok(system)
}

/// Compresses `start` (a copy) to `target` and times it: the row of
/// `table`, its end state checked to be overlap-free.
pub fn timed(table: &'static str, start: &System, target: f64) -> Result<CompressRow, BenchError> {
    let mut system = start.clone();
    let mut rng = Pcg64::seed_from_u64(17);
    let sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.0,
        shear: 0.01,
    };
    let names: Vec<String> = (system.species().iter())
        .map(|s| s.shape.to_string())
        .collect();
    let name = names.join(" + ");
    let clock = Instant::now();
    let report = compress(&mut system, sizes, &CompressOptions::to(target), &mut rng)
        .map_err(|e| BenchError::from(e).of(&name))?;
    let seconds = clock.elapsed().as_secs_f64();
    let overlap = if system.len() < 5000 {
        system.first_overlap_all_pairs()
    } else {
        system.first_overlap()
    };
    if let Some((i, j)) = overlap {
        return Err(BenchError::Wrong {
            system: name,
            what: format!("bodies {i} and {j} overlap after compression"),
        });
    }
    Ok(CompressRow {
        table,
        shape: name,
        n: system.len(),
        packing_fraction: report.packing_fraction,
        sweeps: report.sweeps,
        seconds,
        seconds_per_particle: seconds / system.len() as f64,
        threads: 1,
    })
}

fn shape(spelling: &str) -> Shape {
    spelling.parse().expect("built-in shape")
}

/// Runs the three tables; `quick` uses smaller systems and N only to 8000.
pub fn run(quick: bool) -> Result<Vec<CompressRow>, BenchError> {
    let mut rows = Vec::new();
    let sphere = shape("Sphere(radius: 0.5)");
    let cube = shape("Cuboid(a: 0.5, b: 0.5, c: 0.5)");
    let needle = shape("Ellipsoid(a: 2.5, b: 0.5, c: 0.5)");
    let prolate = shape("Ellipsoid(a: 1.0, b: 0.5, c: 0.5)");
    let (spheres, bodies) = if quick { (10, 7) } else { (16, 10) };
    for (s, n) in [(sphere, spheres), (cube, bodies), (needle, bodies)] {
        rows.push(timed("reference", &dilute_start(&[s], n, 3)?, 0.5)?);
    }
    let suite: [(&[&str], f64); 5] = [
        (&["Sphere(radius: 0.5)"], 0.55),
        (&["Ellipsoid(a: 1.0, b: 0.5, c: 0.5)"], 0.55),
        (&["Ellipsoid(a: 0.5, b: 1.0, c: 1.0)"], 0.55),
        (&["Cuboid(a: 0.5, b: 0.5, c: 0.5)"], 0.60),
        (
            &["Cuboid(a: 0.5, b: 1.0, c: 1.5)", "Sphere(radius: 0.4)"],
            0.45,
        ),
    ];
    let n = if quick { 5 } else { 10 };
    for (spellings, target) in suite {
        let shapes: Vec<Shape> = spellings.iter().map(|s| shape(s)).collect();
        rows.push(timed("suite", &dilute_start(&shapes, n, 5)?, target)?);
    }
    let sides: &[usize] = if quick { &[10, 20] } else { &[10, 20, 30, 46] };
    for s in [sphere, prolate] {
        for &n in sides {
            rows.push(timed("scaling", &dilute_start(&[s], n, 7)?, 0.5)?);
        }
    }
    Ok(rows)
}

/// Writes `compress-scaling.svg`: seconds per particle against N.
pub fn plot(rows: &[CompressRow], dir: &Path) -> Result<Vec<PathBuf>, super::plot::PlotError> {
    std::fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, &e))?;
    let mut series: Vec<Series> = Vec::new();
    for r in rows.iter().filter(|r| r.table == "scaling") {
        let point = (r.n as f64, r.seconds_per_particle * 1e6);
        match series.iter_mut().find(|s| s.name == r.shape) {
            Some(s) => s.points.push(point),
            None => series.push(Series {
                name: r.shape.clone(),
                points: vec![point],
            }),
        }
    }
    let path = dir.join("compress-scaling.svg");
    line_plot(
        &path,
        &Figure {
            title: "Compression to packing fraction 0.5 from a dilute fluid (one thread)",
            x_label: "particles N",
            y_label: "time per particle (microseconds)",
            log_x: true,
            log_y: false,
        },
        &series,
    )?;
    Ok(vec![path])
}

/// The suite's table in Markdown.
pub fn table(rows: &[CompressRow]) -> String {
    let columns = [
        "table",
        "shape",
        "N",
        "phi reached",
        "sweeps",
        "seconds",
        "microseconds per particle",
    ];
    markdown_table(
        &columns,
        rows.iter().map(|r| {
            vec![
                r.table.to_string(),
                r.shape.to_string(),
                r.n.to_string(),
                format!("{:.3}", r.packing_fraction),
                r.sweeps.to_string(),
                format!("{:.2}", r.seconds),
                format!("{:.1}", r.seconds_per_particle * 1e6),
            ]
        }),
    )
}
