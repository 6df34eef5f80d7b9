//! `hardbody bench mc`: trial moves per second of NVT Monte Carlo on one
//! thread, for spheres, ellipsoids (a = 2.5, b = c = 0.5, the HOOMD
//! benchmark's shape), superellipsoids (p = 4) and cubes at φ = 0.5.
//!
//! Dense starts are built directly: spheres on fcc; ellipsoids on the same
//! fcc stretched along their long axis (an affine map keeps aligned
//! ellipsoids exactly as far apart as the spheres they came from); cubes and
//! superellipsoids aligned on a cubic lattice. Move sizes are tuned to 30 %
//! acceptance first, then frozen for the timed sweeps.

use super::markdown_table;
use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::geometry::Shape;
use crate::mc::moves::{Counts, Ensemble, MoveSizes, sweep};
use crate::mc::parallel::{MAX_CHUNK, ParallelSweeps};
use crate::mc::tuning::Tuner;
use crate::space::PeriodicBox;
use crate::state::{Particle, Species, StateError, System};

/// One row of the result.
#[derive(Debug, Clone, serde::Serialize)]
pub struct McRow {
    /// Shape, in the scene spelling.
    pub shape: String,
    /// Particles.
    pub n: usize,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// Median over repeats of trial moves per second.
    pub trial_moves_per_s: f64,
    /// Translation acceptance in the timed sweeps.
    pub acceptance_translate: f64,
    /// Threads used.
    pub threads: usize,
    /// How: `serial`, `slabs` (the parallel sweep, members sharing the
    /// system where they can), `replicas` (the same sweep with a replica
    /// per member, timed where `slabs` shares, for comparison), or
    /// `copies` (as many copies as threads, each swept serially on its
    /// own thread at once: what the machine gives that many threads that
    /// never wait for each other, the ceiling for the slabs).
    pub sweep: &'static str,
}

/// A dense start of `shape` at packing fraction `phi` with about `n` particles.
pub fn dense_start(shape: &Shape, n: usize, phi: f64) -> Result<System, StateError> {
    let v = shape.volume();
    let mut particles = Vec::new();
    let lengths;
    match shape {
        Shape::Sphere(_) | Shape::Ellipsoid(_) => {
            // fcc of unit-diameter spheres, then scaled by the semi-axes,
            // with fewer fcc cells along the longer axes so that the box
            // comes out near cubic (needles need a box twice their length
            // across, not only along).
            let scale = shape.obb_half_extents() * 2.0; // diameter 1 → 2a, 2b, 2c
            let mean = scale.product().cbrt();
            let m = (n as f64 / 4.0).cbrt();
            let cells = scale.map(|s| ((m * mean / s).round() as usize).max(1));
            let count = 4 * cells.product();
            // fcc constant in sphere units for this φ.
            let a = (4.0 * std::f64::consts::PI / 6.0 / phi).cbrt();
            lengths = cells.map(|c| c as f64 * a).component_mul(&scale);
            let basis = [
                [0.0, 0.0, 0.0],
                [0.5, 0.5, 0.0],
                [0.5, 0.0, 0.5],
                [0.0, 0.5, 0.5],
            ];
            for i in 0..count / 4 {
                let (x, y, z) = (
                    i % cells.x,
                    (i / cells.x) % cells.y,
                    i / (cells.x * cells.y),
                );
                for b in &basis {
                    let r = Vector3::new(x as f64 + b[0], y as f64 + b[1], z as f64 + b[2]) * a;
                    particles.push(r.component_mul(&scale) - lengths / 2.0);
                }
            }
        }
        Shape::Cuboid(_)
        | Shape::Superellipsoid(_)
        | Shape::Spherocylinder(_)
        | Shape::ConvexPolyhedron(_) => {
            let cells = (n as f64).cbrt().round() as usize;
            let h = shape.obb_half_extents() * 2.0;
            let spacing = (v / phi / h.product()).cbrt();
            lengths = h * spacing * cells as f64;
            for i in 0..cells.pow(3) {
                let (x, y, z) = (i % cells, (i / cells) % cells, i / (cells * cells));
                particles.push(
                    Vector3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5)
                        .component_mul(&(h * spacing))
                        - lengths / 2.0,
                );
            }
        }
    }
    let particles = particles
        .into_iter()
        .map(|position| Particle {
            position,
            orientation: UnitQuaternion::identity(),
            species: 0,
        })
        .collect();
    let species = vec![Species {
        name: shape.kind().into(),
        shape: *shape,
        rotation: true,
    }];
    let box_ = PeriodicBox::new(lengths).map_err(|_| StateError::Empty)?;
    System::new(box_, species, particles)
}

/// Times NVT sweeps of each shape, serial and (with more than one rayon
/// thread) parallel on slabs; `quick` uses N ≈ 1400 and fewer sweeps.
pub fn run(quick: bool) -> Result<Vec<McRow>, StateError> {
    let (n, sweeps, repeats) = if quick { (1400, 10, 3) } else { (4096, 100, 5) };
    let mut rows = Vec::new();
    for text in SHAPES {
        let shape: Shape = text.parse().expect("built-in shape");
        let (mut system, sizes) = tuned(&shape, n, 0.5, if quick { 20 } else { 60 })?;
        let threads = rayon::current_num_threads();
        // The parallel sweep on all of rayon's threads, same sizes, handed
        // over as a run does (up to MAX_CHUNK sweeps at once): the speed-up
        // is the ratio of the rows. Where members share the system, the
        // same sweeps on replicas. Then what independent copies get on as
        // many threads: on a shared machine, far from twice one thread,
        // and moving with the load on the host. Each repeat times every
        // way in turn, so that all see the same load.
        let mut rng = Pcg64::seed_from_u64(17);
        let mut parallel = ParallelSweeps::new();
        let mut replicas = ParallelSweeps::replicas_only();
        let shares = parallel.would_share(&system, threads);
        let mut copies: Vec<(System, Pcg64)> = (0..threads)
            .map(|k| (system.clone(), Pcg64::seed_from_u64(100 + k as u64)))
            .collect();
        let mut index = 0;
        let mut slab_sweeps = |sweeps: &mut ParallelSweeps, system: &mut System, count: usize| {
            let first = index;
            index += count as u64;
            let seeds = [17; MAX_CHUNK];
            sweeps.sweeps(system, &sizes, &Ensemble::Nvt, &seeds[..count], first)
        };
        let mut ways = vec![Way::new(How::Serial)];
        if threads > 1 {
            ways.push(Way::new(How::Slabs));
            if shares {
                ways.push(Way::new(How::Replicas));
            }
            ways.push(Way::new(How::Copies));
        }
        for _ in 0..repeats {
            for way in &mut ways {
                let start = Instant::now();
                way.counts += match way.how {
                    How::Serial => {
                        in_chunks(sweeps, |c| serial_sweeps(&mut system, &sizes, &mut rng, c))
                    }
                    How::Slabs => in_chunks(sweeps, |c| slab_sweeps(&mut parallel, &mut system, c)),
                    How::Replicas => {
                        in_chunks(sweeps, |c| slab_sweeps(&mut replicas, &mut system, c))
                    }
                    How::Copies => copies_sweeps(&mut copies, &sizes, sweeps),
                };
                let moves = copies_at_once(way.how, threads) * sweeps * system.len();
                way.rates.push(moves as f64 / start.elapsed().as_secs_f64());
            }
        }
        for mut way in ways {
            let checked: Vec<&System> = match way.how {
                How::Copies => copies.iter().map(|(copy, _)| copy).collect(),
                _ => vec![&system],
            };
            let used = if way.how == How::Serial { 1 } else { threads };
            rows.push(checked_row(
                text,
                &checked,
                &mut way.rates,
                &way.counts,
                (used, way.how.label()),
            )?);
        }
    }
    Ok(rows)
}

/// The ways of sweeping that [`run`] times (see [`McRow::sweep`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum How {
    Serial,
    Slabs,
    Replicas,
    Copies,
}

impl How {
    /// The row's `sweep`.
    fn label(self) -> &'static str {
        match self {
            How::Serial => "serial",
            How::Slabs => "slabs",
            How::Replicas => "replicas",
            How::Copies => "copies",
        }
    }
}

/// Systems `how` sweeps at once on `threads` threads (copies: one per
/// thread).
fn copies_at_once(how: How, threads: usize) -> usize {
    if how == How::Copies { threads } else { 1 }
}

/// A way of sweeping that [`run`] times, in turn with the others, and what
/// it measured.
struct Way {
    how: How,
    rates: Vec<f64>,
    counts: Counts,
}

impl Way {
    fn new(how: How) -> Self {
        Self {
            how,
            rates: Vec::new(),
            counts: Counts::default(),
        }
    }
}

/// `sweeps` sweeps made by `step` at most [`MAX_CHUNK`] at a time, as a
/// run hands them over.
fn in_chunks(sweeps: usize, mut step: impl FnMut(usize) -> Counts) -> Counts {
    let mut counts = Counts::default();
    let mut left = sweeps;
    while left > 0 {
        let count = left.min(MAX_CHUNK);
        counts += step(count);
        left -= count;
    }
    counts
}

/// `sweeps` serial sweeps of each of `copies`, each on its own thread, at
/// once.
fn copies_sweeps(copies: &mut [(System, Pcg64)], sizes: &MoveSizes, sweeps: usize) -> Counts {
    std::thread::scope(|scope| {
        let running: Vec<_> = (copies.iter_mut())
            .map(|(copy, rng)| scope.spawn(move || serial_sweeps(copy, sizes, rng, sweeps)))
            .collect();
        (running.into_iter())
            .map(|c| c.join().expect("a copy's sweeps do not panic"))
            .fold(Counts::default(), |a, c| a + c)
    })
}

/// `count` serial NVT sweeps.
fn serial_sweeps(system: &mut System, sizes: &MoveSizes, rng: &mut Pcg64, count: usize) -> Counts {
    (0..count).fold(Counts::default(), |c, _| {
        c + sweep(system, sizes, &Ensemble::Nvt, rng)
    })
}

/// Times `repeats` × `sweeps` sweeps made by `step` (which makes as many
/// as it is asked, at most [`MAX_CHUNK`] at a time) and checks the end
/// state by all pairs: the median rate as a row.
fn timed_row(
    shape: &str,
    system: &mut System,
    repeats: usize,
    sweeps: usize,
    (threads, how): (usize, &'static str),
    mut step: impl FnMut(&mut System, usize) -> Counts,
) -> Result<McRow, StateError> {
    let mut rates = Vec::new();
    let mut counts = Counts::default();
    for _ in 0..repeats {
        let start = Instant::now();
        counts += in_chunks(sweeps, |count| step(system, count));
        rates.push((sweeps * system.len()) as f64 / start.elapsed().as_secs_f64());
    }
    checked_row(shape, &[system], &mut rates, &counts, (threads, how))
}

/// The row of `rates` and `counts` measured on `systems` (alike but for
/// their moves), once no pair in any of them overlaps by all pairs.
fn checked_row(
    shape: &str,
    systems: &[&System],
    rates: &mut [f64],
    counts: &Counts,
    (threads, how): (usize, &'static str),
) -> Result<McRow, StateError> {
    for system in systems {
        if let Some((i, j)) = system.first_overlap_all_pairs() {
            return Err(StateError::Overlap(i, j));
        }
    }
    Ok(McRow {
        shape: shape.into(),
        n: systems[0].len(),
        packing_fraction: systems[0].packing_fraction(),
        trial_moves_per_s: super::ocsi::median(rates),
        acceptance_translate: counts.translate.rate(),
        threads,
        sweep: how,
    })
}

/// The shapes of the suite, in the scene spelling.
/// (The cube twice: by the separating axes, and as a convex polyhedron
/// through GJK.)
const SHAPES: [&str; 5] = [
    "Sphere(radius: 0.5)",
    "Ellipsoid(a: 0.5, b: 0.5, c: 2.5)",
    "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
    "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
    "Cube(edge: 1.0)",
];

/// A dense start of `shape` tuned to 30 % acceptance (`sweeps` sweeps),
/// with the frozen move sizes.
pub fn tuned(
    shape: &Shape,
    n: usize,
    phi: f64,
    sweeps: usize,
) -> Result<(System, MoveSizes), StateError> {
    let mut system = dense_start(shape, n, phi)?;
    let mut rng = Pcg64::seed_from_u64(17);
    let mut sizes = MoveSizes {
        translate: 0.1,
        rotate: 0.1,
        volume: 0.0,
        shear: 0.01,
    };
    let tuner = Tuner {
        target: 0.3,
        max_translate: 1.0,
    };
    for _ in 0..sweeps {
        let c = sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
        tuner.update(&mut sizes, &c);
    }
    Ok((system, sizes))
}

/// Trial moves per second on one thread against the packing fraction, per
/// shape (moves tuned to 30 % acceptance at each φ).
pub fn by_density(quick: bool) -> Result<Vec<McRow>, StateError> {
    let phis: &[f64] = if quick {
        &[0.3, 0.5]
    } else {
        &[0.2, 0.3, 0.4, 0.5, 0.55]
    };
    let (n, sweeps, repeats) = if quick { (500, 5, 3) } else { (4096, 50, 3) };
    let mut rows = Vec::new();
    for text in SHAPES {
        let shape: Shape = text.parse().expect("built-in shape");
        for &phi in phis {
            let (mut system, sizes) = tuned(&shape, n, phi, if quick { 10 } else { 40 })?;
            let mut rng = Pcg64::seed_from_u64(18);
            rows.push(timed_row(
                text,
                &mut system,
                repeats,
                sweeps,
                (1, "serial"),
                |s, count| serial_sweeps(s, &sizes, &mut rng, count),
            )?);
        }
    }
    Ok(rows)
}

/// Acceptance and speed at one move size.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AcceptanceRow {
    /// Shape, in the scene spelling.
    pub shape: String,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// Side of the translation cube, in units of the smallest thickness.
    pub translate: f64,
    /// Largest rotation angle (radians).
    pub rotate: f64,
    /// Fraction of translations accepted.
    pub acceptance_translate: f64,
    /// Fraction of rotations accepted (NaN for spheres).
    pub acceptance_rotate: f64,
    /// Trial moves per second, one thread.
    pub trial_moves_per_s: f64,
}

/// Acceptance against move size at φ = 0.5: translations from 1/50 to 1
/// thickness, rotations of the same number of radians (spheres do not
/// turn); what the tuner's 30 % target picks from.
pub fn by_move_size(quick: bool) -> Result<Vec<AcceptanceRow>, StateError> {
    let steps: &[f64] = if quick {
        &[0.05, 0.3]
    } else {
        &[0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0]
    };
    let (n, sweeps) = if quick { (500, 5) } else { (4096, 20) };
    let mut rows = Vec::new();
    for text in SHAPES {
        let shape: Shape = text.parse().expect("built-in shape");
        let thickness = 2.0 * shape.min_half_extent();
        let (base, _) = tuned(&shape, n, 0.5, if quick { 10 } else { 40 })?;
        for &step in steps {
            let mut system = base.clone();
            let sizes = MoveSizes {
                translate: step * thickness,
                rotate: step,
                volume: 0.0,
                shear: 0.01,
            };
            let mut rng = Pcg64::seed_from_u64(19);
            let mut counts = Counts::default();
            let start = Instant::now();
            for _ in 0..sweeps {
                counts += sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
            }
            let seconds = start.elapsed().as_secs_f64();
            rows.push(AcceptanceRow {
                shape: text.into(),
                packing_fraction: system.packing_fraction(),
                translate: step,
                rotate: step,
                acceptance_translate: counts.translate.rate(),
                acceptance_rotate: counts.rotate.rate(),
                trial_moves_per_s: (sweeps * system.len()) as f64 / seconds,
            });
        }
    }
    Ok(rows)
}

/// Plots of the MC suite: trial moves per second against φ, and
/// acceptance against move size.
pub fn plot(
    density: &[McRow],
    sizes: &[AcceptanceRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let name = |text: &str| text.split('(').next().unwrap_or(text).to_lowercase();
    let speed: Vec<Series> = SHAPES
        .iter()
        .map(|text| Series {
            name: name(text),
            points: density
                .iter()
                .filter(|r| r.shape == *text)
                .map(|r| (r.packing_fraction, r.trial_moves_per_s))
                .collect(),
        })
        .collect();
    let speed_path = dir.join("mc-moves-per-second.svg");
    line_plot(
        &speed_path,
        &Figure {
            title: "Monte Carlo trial moves per second against packing fraction (one thread, medians)",
            x_label: "packing fraction phi",
            y_label: "trial moves per second",
            log_x: false,
            log_y: true,
        },
        &speed,
    )?;
    let mut acceptance = Vec::new();
    for text in SHAPES {
        acceptance.push(Series {
            name: format!("{}, translations", name(text)),
            points: sizes
                .iter()
                .filter(|r| r.shape == text)
                .map(|r| (r.translate, r.acceptance_translate))
                .collect(),
        });
        if !text.starts_with("Sphere") {
            acceptance.push(Series {
                name: format!("{}, rotations", name(text)),
                points: sizes
                    .iter()
                    .filter(|r| r.shape == text)
                    .map(|r| (r.rotate, r.acceptance_rotate))
                    .collect(),
            });
        }
    }
    let acceptance_path = dir.join("mc-acceptance.svg");
    line_plot(
        &acceptance_path,
        &Figure {
            title: "Acceptance against move size at phi = 0.5",
            x_label: "move size (translation: cube side in thicknesses; rotation: radians)",
            y_label: "fraction of moves accepted",
            log_x: true,
            log_y: false,
        },
        &acceptance,
    )?;
    Ok(vec![speed_path, acceptance_path])
}

/// The suite's tables in Markdown: speed and density rows, then the
/// move-size rows.
pub fn table(moves: &[McRow], density: &[McRow], sizes: &[AcceptanceRow]) -> String {
    let speed_columns = [
        "shape",
        "N",
        "phi",
        "threads",
        "sweep",
        "trial moves/s (median)",
        "translate acceptance",
    ];
    let size_columns = [
        "shape",
        "phi",
        "translation (thicknesses)",
        "rotation (rad)",
        "translate acceptance",
        "rotate acceptance",
        "trial moves/s",
    ];
    let speed = markdown_table(
        &speed_columns,
        moves.iter().chain(density).map(|r| {
            vec![
                r.shape.to_string(),
                r.n.to_string(),
                format!("{:.3}", r.packing_fraction),
                r.threads.to_string(),
                r.sweep.to_string(),
                format!("{:.3e}", r.trial_moves_per_s),
                format!("{:.2}", r.acceptance_translate),
            ]
        }),
    );
    let acceptance = markdown_table(
        &size_columns,
        sizes.iter().map(|r| {
            vec![
                r.shape.to_string(),
                format!("{:.3}", r.packing_fraction),
                r.translate.to_string(),
                r.rotate.to_string(),
                format!("{:.3}", r.acceptance_translate),
                format!("{:.3}", r.acceptance_rotate),
                format!("{:.3e}", r.trial_moves_per_s),
            ]
        }),
    );
    format!("{speed}\n{acceptance}")
}
