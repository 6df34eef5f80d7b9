//! `hardbody bench effects`: what each optional effect costs, measured on
//! and off on the same system in one run (medians of alternating repeats).
//!
//! Dynamics (prolate ellipsoids 2:1, N = 256, φ = 0.3, time per collision):
//! rotation (frozen orientations against free rotation), true inertia
//! (each body's own tensor against the spherical top: symmetric tops for
//! the prolate ellipsoids, asymmetric tops for triaxial ellipsoids, bricks
//! and triaxial superellipsoids at the same φ), hard walls (closed along z
//! against periodic), neighbour lists (oriented boxes against cells), the
//! `/stats` sample every 10 collisions, and MSD with C₂ on top of it.
//! Monte Carlo (the same ellipsoids, time per trial move): rotation moves,
//! hard walls, and a box move per sweep (NPT against NVT).

use super::markdown_table;
use std::time::Instant;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::BenchError;
use crate::edmd::{Dynamics, DynamicsOptions};
use crate::geometry::Shape;
use crate::mc::moves::{Ensemble, MoveSizes, sweep};
use crate::space::PeriodicBox;
use crate::state::{Species, System};

/// One effect, off and on.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EffectRow {
    /// Dynamics or Monte Carlo.
    pub driver: String,
    /// What is switched.
    pub effect: String,
    /// Median cost with the effect off (µs per collision or per trial move).
    pub off_us: f64,
    /// Median cost with it on.
    pub on_us: f64,
    /// on / off.
    pub ratio: f64,
    /// Unit of the two costs.
    pub unit: String,
}

const SHAPE: &str = "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)";
/// Bodies with three different principal moments, for the true-inertia
/// rows: (name, shape).
const TRIAXIAL: [(&str, &str); 3] = [
    (
        "triaxial ellipsoids 1:0.6:0.3",
        "Ellipsoid(a: 1.0, b: 0.6, c: 0.3)",
    ),
    ("bricks 0.6:0.4:0.25", "Cuboid(a: 0.6, b: 0.4, c: 0.25)"),
    (
        "triaxial superellipsoids p = 4",
        "Superellipsoid(a: 1.0, b: 0.6, c: 0.4, exponents: (4.0, 4.0, 4.0))",
    ),
];
/// Packing fraction of the suite's systems (a lattice start with walls fits there).
const PHI: f64 = 0.3;

/// N ellipsoids on a lattice at φ = 0.3 (hard walls along z if `walls`),
/// relaxed by Monte Carlo; `rotation` says whether the species turns.
fn state(n: usize, walls: bool, rotation: bool) -> Result<System, BenchError> {
    state_of(SHAPE, n, walls, rotation)
}

/// [`state`] of bodies of `shape`.
fn state_of(shape: &str, n: usize, walls: bool, rotation: bool) -> Result<System, BenchError> {
    let shape: Shape = shape.parse()?;
    let species = vec![Species {
        name: "body".into(),
        shape,
        rotation,
    }];
    let side = (n as f64 * shape.volume() / PHI).cbrt();
    let box_ = PeriodicBox::new(Vector3::repeat(side))?.with_walls([false, false, walls])?;
    let mut rng = Pcg64::seed_from_u64(9);
    let mut system = crate::state::start::lattice(box_, species, &[n], &mut rng)?;
    let sizes = MoveSizes {
        translate: 0.1,
        rotate: 0.1,
        volume: 0.0,
        shear: 0.01,
    };
    for _ in 0..20 {
        sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
    }
    Ok(system)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A dynamics run prepared for timing: built from `system`, warmed up.
struct Timed {
    md: Dynamics,
    /// Sample every this many collisions (0: never), with MSD and C₂.
    sample_every: u64,
    observables: bool,
}

impl Timed {
    fn new(
        system: &System,
        options: &DynamicsOptions,
        sample_every: u64,
        observables: bool,
        warm: u64,
    ) -> Result<Self, BenchError> {
        let mut rng = Pcg64::seed_from_u64(4);
        let mut md = Dynamics::from_state(system, options, &mut rng)?;
        md.run_collisions(warm)?;
        Ok(Self {
            md,
            sample_every,
            observables,
        })
    }

    /// Wall time per collision over `collisions` more collisions.
    fn time(&mut self, collisions: u64) -> Result<f64, BenchError> {
        let clock = Instant::now();
        if self.sample_every == 0 {
            self.md.run_collisions(collisions)?;
        } else {
            let mut done = 0;
            let mut sink = 0.0;
            while done < collisions {
                self.md.run_collisions(self.sample_every)?;
                done += self.sample_every;
                let s = self.md.sample();
                sink += s.temperature;
                if self.observables {
                    sink += self.md.mean_squared_displacement();
                    sink += self.md.orientational_correlation().unwrap_or(0.0);
                }
            }
            std::hint::black_box(sink);
        }
        Ok(clock.elapsed().as_secs_f64() * 1e6 / collisions as f64)
    }
}

/// Times `off` and `on` alternately, `repeats` times each.
fn alternate(
    off: &mut dyn FnMut() -> Result<f64, BenchError>,
    on: &mut dyn FnMut() -> Result<f64, BenchError>,
    repeats: usize,
) -> Result<(f64, f64), BenchError> {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..repeats {
        a.push(off()?);
        b.push(on()?);
    }
    Ok((median(&mut a), median(&mut b)))
}

fn row(driver: &str, effect: &str, (off, on): (f64, f64), unit: &str) -> EffectRow {
    EffectRow {
        driver: driver.into(),
        effect: effect.into(),
        off_us: off,
        on_us: on,
        ratio: on / off,
        unit: unit.into(),
    }
}

/// Runs the suite (`quick`: fewer bodies, collisions and moves).
pub fn run(quick: bool) -> Result<Vec<EffectRow>, BenchError> {
    let (n, collisions, repeats, warm) = if quick {
        (64, 300, 3, 300)
    } else {
        (256, 4000, 5, 2560)
    };
    let periodic = state(n, false, true)?;
    let frozen = state(n, false, false)?;
    let walled = state(n, true, true)?;
    let shell = Some(0.1);
    let cells = DynamicsOptions::default();
    let lists = DynamicsOptions {
        neighbour_shell: shell,
        ..DynamicsOptions::default()
    };
    let per_collision = "us per collision";
    let mut rows = Vec::new();
    let pair = |name: &str,
                off: (&System, &DynamicsOptions, u64, bool),
                on: (&System, &DynamicsOptions, u64, bool)|
     -> Result<EffectRow, BenchError> {
        let mut a = Timed::new(off.0, off.1, off.2, off.3, warm)?;
        let mut b = Timed::new(on.0, on.1, on.2, on.3, warm)?;
        let times = alternate(
            &mut || a.time(collisions),
            &mut || b.time(collisions),
            repeats,
        )?;
        Ok(row("dynamics", name, times, per_collision))
    };
    rows.push(pair(
        "rotation (frozen -> free)",
        (&frozen, &cells, 0, false),
        (&periodic, &cells, 0, false),
    )?);
    let tops = DynamicsOptions {
        true_inertia: true,
        ..DynamicsOptions::default()
    };
    rows.push(pair(
        "true inertia, prolate ellipsoids (spherical -> symmetric tops)",
        (&periodic, &cells, 0, false),
        (&periodic, &tops, 0, false),
    )?);
    for (name, shape) in TRIAXIAL {
        let system = state_of(shape, n, false, true)?;
        rows.push(pair(
            &format!("true inertia, {name} (spherical -> asymmetric tops)"),
            (&system, &cells, 0, false),
            (&system, &tops, 0, false),
        )?);
    }
    rows.push(pair(
        "hard walls along z (periodic -> walls)",
        (&periodic, &cells, 0, false),
        (&walled, &cells, 0, false),
    )?);
    rows.push(pair(
        "neighbour lists (cells -> oriented boxes, shell 0.1)",
        (&periodic, &cells, 0, false),
        (&periodic, &lists, 0, false),
    )?);
    rows.push(pair(
        "stats sample every 10 collisions",
        (&periodic, &cells, 0, false),
        (&periodic, &cells, 10, false),
    )?);
    rows.push(pair(
        "MSD and C2 with every sample",
        (&periodic, &cells, 10, false),
        (&periodic, &cells, 10, true),
    )?);

    // Monte Carlo: µs per trial move.
    let sweeps = if quick { 5 } else { 40 };
    let per_move = "us per trial move";
    let sizes = MoveSizes {
        translate: 0.1,
        rotate: 0.1,
        volume: 0.01,
        shear: 0.01,
    };
    let mc_time = |system: &mut System, ensemble: &Ensemble, seed: u64| {
        let mut rng = Pcg64::seed_from_u64(seed);
        let clock = Instant::now();
        let mut moves = 0u64;
        for _ in 0..sweeps {
            let c = sweep(system, &sizes, ensemble, &mut rng);
            moves += c.translate.tried + c.rotate.tried + c.volume.tried;
        }
        Ok(clock.elapsed().as_secs_f64() * 1e6 / moves as f64)
    };
    let mc_pair = |name: &str,
                   (mut a, ea): (System, Ensemble),
                   (mut b, eb): (System, Ensemble)|
     -> Result<EffectRow, BenchError> {
        let mut seed = 0;
        let times = alternate(
            &mut || {
                seed += 1;
                mc_time(&mut a, &ea, seed)
            },
            &mut || mc_time(&mut b, &eb, 1000),
            repeats,
        )?;
        Ok(row("Monte Carlo", name, times, per_move))
    };
    rows.push(mc_pair(
        "rotation moves (frozen -> turning)",
        (frozen.clone(), Ensemble::Nvt),
        (periodic.clone(), Ensemble::Nvt),
    )?);
    rows.push(mc_pair(
        "hard walls along z (periodic -> walls)",
        (periodic.clone(), Ensemble::Nvt),
        (walled.clone(), Ensemble::Nvt),
    )?);
    rows.push(mc_pair(
        "a box move per sweep (NVT -> NPT, beta P = 5)",
        (periodic.clone(), Ensemble::Nvt),
        (
            periodic.clone(),
            Ensemble::Npt {
                pressure: 5.0,
                moves: crate::mc::box_moves::BoxMoves::Isotropic,
            },
        ),
    )?);
    Ok(rows)
}

/// The suite's plot: on/off cost ratio per effect (1 = free).
pub fn plot(
    rows: &[EffectRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    let bars: Vec<(String, f64)> = rows
        .iter()
        .map(|r| (format!("{}: {}", r.driver, r.effect), r.ratio))
        .collect();
    let path = dir.join("effects.svg");
    super::plot::bar_plot(
        &path,
        "What each optional effect costs (prolate ellipsoids, N = 256, phi = 0.3; medians)",
        "time with the effect on / time with it off",
        &bars,
        1.0,
    )?;
    Ok(vec![path])
}

/// The suite's table in Markdown.
pub fn table(rows: &[EffectRow]) -> String {
    markdown_table(
        &["driver", "effect", "off", "on", "on / off", "unit"],
        rows.iter().map(|r| {
            vec![
                r.driver.to_string(),
                r.effect.to_string(),
                format!("{:.3}", r.off_us),
                format!("{:.3}", r.on_us),
                format!("{:.2}", r.ratio),
                r.unit.to_string(),
            ]
        }),
    )
}
