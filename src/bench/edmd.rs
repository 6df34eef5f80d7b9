//! `hardbody bench edmd-tolerance`: what the accuracy knobs of the
//! event-driven dynamics buy and cost (De Michele's Fig. 9, extended).
//!
//! For prolate ellipsoids of aspect 2 and 5 (b = c = 0.5) compressed by
//! Monte Carlo to φ = 0.5, the same start and the same velocities are run
//! for the same number of collisions with the grazing threshold ε_d from
//! 1e-1 to 1e-8 and the Newton tolerance from 1e-6 to 1e-14, and each run is
//! set against a reference at the tightest setting (ε_d = 1e-8, Newton
//! 1e-14): time per collision; the largest difference in contact time over
//! the first 100 collisions (the same pairs, before chaos spreads the
//! trajectories apart); how many collisions the run follows the
//! reference's sequence; the energy drift per collision; and whether a
//! collision was missed (an overlap found at a frame, or the dynamics
//! stopping on an overlap).

use super::markdown_table;
use std::time::Instant;

use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::BenchError;
use crate::edmd::{Dynamics, DynamicsOptions, PredictorOptions};
use crate::geometry::Shape;
use crate::mc::compress::{CompressOptions, compress};
use crate::mc::moves::{Ensemble, MoveSizes};
use crate::mc::tuning::Tuner;
use crate::state::{Species, System};

/// One run of the suite.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ToleranceRow {
    /// Shape, in the scene spelling.
    pub shape: String,
    /// Long axis over short.
    pub aspect: f64,
    /// Bodies.
    pub n: usize,
    /// φ.
    pub packing_fraction: f64,
    /// ε_d, relative to the smaller body's smallest half-extent.
    pub grazing_threshold: f64,
    /// Newton–Raphson tolerance, relative to the smallest semi-axis.
    pub newton_tolerance: f64,
    /// Whether this is the reference run.
    pub reference: bool,
    /// Collisions run.
    pub collisions: u64,
    /// Wall time per collision: the median over ten stretches of the run.
    pub us_per_collision: f64,
    /// The fastest and slowest of those stretches.
    pub us_per_collision_range: (f64, f64),
    /// |E/E₀ − 1| at the end, per collision.
    pub energy_drift_per_collision: f64,
    /// Largest |t − t_ref| over the first 100 collisions of the same pairs.
    pub max_contact_time_error: f64,
    /// Collisions before the sequence departs from the reference's (a
    /// different pair, or a time more than 1e-6 away).
    pub departure_collisions: u64,
    /// A collision was missed: the overlap or error found, if any.
    pub missed: Option<String>,
}

/// The MC start: `n_side`³ ellipsoids of `aspect` compressed to `phi`,
/// then `sweeps` NVT sweeps.
fn start(
    aspect: f64,
    n_side: usize,
    phi: f64,
    sweeps: u64,
    seed: u64,
) -> Result<(Shape, System), BenchError> {
    let shape: Shape = format!("Ellipsoid(a: {}, b: 0.5, c: 0.5)", 0.5 * aspect).parse()?;
    let species = vec![Species {
        name: "ellipsoid".into(),
        shape,
        rotation: true,
    }];
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut system = crate::state::start::dilute_lattice(n_side, species, |_| 0, &mut rng)?;
    let mut sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.0,
        shear: 0.01,
    };
    let report = compress(&mut system, sizes, &CompressOptions::to(phi), &mut rng)?;
    sizes = report.sizes;
    let tuner = Tuner {
        target: 0.3,
        max_translate: 1.0,
    };
    tuner.equilibrate(
        &mut system,
        &mut sizes,
        &Ensemble::Nvt,
        sweeps,
        50,
        &mut rng,
    );
    Ok((shape, system))
}

struct Outcome {
    collisions: u64,
    seconds: f64,
    /// Time per collision over each tenth of the run (checks excluded).
    stretches: Vec<f64>,
    drift: f64,
    trace: Vec<(f64, u32, u32)>,
    missed: Option<String>,
}

/// Runs at least `collisions` collisions from `system` with `predictor`,
/// checking the state for overlaps in frames of 0.01 time units. (Frames
/// at fixed times, not right after a collision: a pair that has just
/// collided touches, to 1e-16 with tight settings, and the MC kernels
/// count touching as overlap.)
fn run(system: &System, predictor: PredictorOptions, collisions: u64) -> Outcome {
    let options = DynamicsOptions {
        predictor,
        ..DynamicsOptions::default()
    };
    let mut rng = Pcg64::seed_from_u64(99);
    let clock = Instant::now();
    let mut md = match Dynamics::from_state(system, &options, &mut rng) {
        Ok(md) => md,
        Err(e) => {
            return Outcome {
                collisions: 0,
                seconds: 0.0,
                stretches: Vec::new(),
                drift: 0.0,
                trace: Vec::new(),
                missed: Some(e.to_string()),
            };
        }
    };
    md.record_collisions(true);
    let e0 = md.kinetic_energy();
    let mut missed = None;
    let mut checking = 0.0;
    let mut stretches = Vec::new();
    let mut stretch = (0u64, 0.0f64);
    while md.collisions() < collisions {
        if let Err(e) = md.run_until(md.time() + 0.01) {
            missed = Some(e.to_string());
            break;
        }
        let check = Instant::now();
        if let Err(e) = md.to_system() {
            missed = Some(format!("at t = {}: {e}", md.time()));
            break;
        }
        checking += check.elapsed().as_secs_f64();
        if md.collisions() - stretch.0 >= collisions / 10 {
            let seconds = clock.elapsed().as_secs_f64() - checking;
            stretches.push((seconds - stretch.1) * 1e6 / (md.collisions() - stretch.0) as f64);
            stretch = (md.collisions(), seconds);
        }
    }
    Outcome {
        collisions: md.collisions(),
        seconds: clock.elapsed().as_secs_f64() - checking,
        stretches,
        drift: (md.kinetic_energy() / e0 - 1.0).abs(),
        trace: md.take_collisions(),
        missed,
    }
}

/// Runs the suite; `quick` for CI smoke (φ = 0.35, 1000 collisions, a
/// shorter equilibration, three settings of each knob).
pub fn tolerance(quick: bool) -> Result<Vec<ToleranceRow>, BenchError> {
    let (phi, collisions, n_side) = if quick {
        (0.35, 1_000, 6)
    } else {
        (0.5, 100_000, 6)
    };
    let grazing: &[f64] = if quick {
        &[1e-2, 1e-4]
    } else {
        &[1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
    };
    let newton: &[f64] = if quick {
        &[1e-8]
    } else {
        &[1e-6, 1e-8, 1e-10, 1e-12]
    };
    let (ref_grazing, ref_newton) = (1e-8, 1e-14);
    let mut rows = Vec::new();
    for aspect in [2.0, 5.0] {
        let (shape, system) = start(aspect, n_side, phi, if quick { 100 } else { 500 }, 7)?;
        let options = |g: f64, t: f64| {
            let mut p = PredictorOptions {
                grazing_threshold: g,
                ..PredictorOptions::default()
            };
            p.distance.newton.tolerance = t;
            p
        };
        let reference = run(&system, options(ref_grazing, ref_newton), collisions);
        if let Some(m) = &reference.missed {
            return Err(BenchError::Wrong {
                system: format!("aspect {aspect}"),
                what: format!("the reference run failed: {m}"),
            });
        }
        let default_newton = PredictorOptions::default().distance.newton.tolerance;
        let default_grazing = PredictorOptions::default().grazing_threshold;
        let settings = std::iter::once((ref_grazing, ref_newton))
            .chain(grazing.iter().map(|&g| (g, default_newton)))
            .chain(newton.iter().map(|&t| (default_grazing, t)));
        for (g, t) in settings {
            let is_reference = (g, t) == (ref_grazing, ref_newton);
            let o = if is_reference {
                Outcome {
                    collisions: reference.collisions,
                    seconds: reference.seconds,
                    stretches: reference.stretches.clone(),
                    drift: reference.drift,
                    trace: reference.trace.clone(),
                    missed: None,
                }
            } else {
                run(&system, options(g, t), collisions)
            };
            let departure = o
                .trace
                .iter()
                .zip(&reference.trace)
                .position(|(a, b)| a.1 != b.1 || a.2 != b.2 || (a.0 - b.0).abs() > 1e-6)
                .unwrap_or(o.trace.len().min(reference.trace.len()));
            let max_error = o
                .trace
                .iter()
                .zip(&reference.trace)
                .take(departure.min(100))
                .map(|(a, b)| (a.0 - b.0).abs())
                .fold(0.0, f64::max);
            rows.push(ToleranceRow {
                shape: shape.to_string(),
                aspect,
                n: system.len(),
                packing_fraction: phi,
                grazing_threshold: g,
                newton_tolerance: t,
                reference: is_reference,
                collisions: o.collisions,
                us_per_collision: if o.stretches.is_empty() {
                    o.seconds * 1e6 / o.collisions.max(1) as f64
                } else {
                    super::ocsi::median(&mut o.stretches.clone())
                },
                us_per_collision_range: o
                    .stretches
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(lo, hi), &t| {
                        (lo.min(t), hi.max(t))
                    }),
                energy_drift_per_collision: o.drift / o.collisions.max(1) as f64,
                max_contact_time_error: max_error,
                departure_collisions: departure as u64,
                missed: o.missed,
            });
        }
    }
    Ok(rows)
}

/// The loosest ε_d (largest) with no missed collision, per aspect.
pub fn loosest_safe_grazing(rows: &[ToleranceRow]) -> Vec<(f64, Option<f64>)> {
    let mut aspects: Vec<f64> = rows.iter().map(|r| r.aspect).collect();
    aspects.dedup();
    let default_newton = PredictorOptions::default().distance.newton.tolerance;
    aspects
        .into_iter()
        .map(|a| {
            let safe = rows
                .iter()
                .filter(|r| r.aspect == a && r.newton_tolerance == default_newton)
                .filter(|r| r.missed.is_none())
                .map(|r| r.grazing_threshold)
                .fold(None, |m: Option<f64>, g| Some(m.map_or(g, |m| m.max(g))));
            (a, safe)
        })
        .collect()
}

/// A plotted quantity: file-name part, axis label, its value in a row, and
/// a flag (for a knob: it is ε_d; for a measure: log scale).
type Axis = (&'static str, &'static str, fn(&ToleranceRow) -> f64, bool);

/// Plots of the tolerance suite (De Michele Fig. 9, extended): against
/// ε_d and against the Newton tolerance, per aspect, the time per
/// collision, the contact-time error on the same pairs, and how long the
/// run follows the reference's collision sequence.
pub fn plot(
    rows: &[ToleranceRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let default_newton = PredictorOptions::default().distance.newton.tolerance;
    let default_grazing = PredictorOptions::default().grazing_threshold;
    let mut aspects: Vec<f64> = rows.iter().map(|r| r.aspect).collect();
    aspects.dedup();
    let mut paths = Vec::new();
    let knobs: [Axis; 2] = [
        (
            "grazing",
            "grazing threshold eps_d (relative to the smallest semi-axis)",
            |r| r.grazing_threshold,
            true,
        ),
        (
            "newton",
            "Newton tolerance (relative to the smallest semi-axis)",
            |r| r.newton_tolerance,
            false,
        ),
    ];
    let measures: [Axis; 3] = [
        (
            "time",
            "time per collision (us)",
            |r| r.us_per_collision,
            true,
        ),
        (
            "error",
            "max contact-time error on the same pairs (time units)",
            |r| r.max_contact_time_error,
            true,
        ),
        (
            "departure",
            "collisions before the sequence departs from the reference",
            |r| r.departure_collisions as f64,
            false,
        ),
    ];
    for (knob, knob_label, x_of, varies_grazing) in knobs {
        for (measure, y_label, y_of, log_y) in measures {
            let series: Vec<Series> = aspects
                .iter()
                .map(|&a| {
                    let mut points: Vec<(f64, f64)> = rows
                        .iter()
                        .filter(|r| r.aspect == a && !r.reference)
                        .filter(|r| {
                            if varies_grazing {
                                r.newton_tolerance == default_newton
                            } else {
                                r.grazing_threshold == default_grazing
                            }
                        })
                        .map(|r| (x_of(r), y_of(r)))
                        .filter(|p| !log_y || p.1 > 0.0)
                        .collect();
                    points.sort_by(|p, q| p.0.total_cmp(&q.0));
                    points.dedup_by(|p, q| p.0 == q.0);
                    Series {
                        name: format!("ellipsoids, aspect {a}"),
                        points,
                    }
                })
                .collect();
            let path = dir.join(format!("edmd-tolerance-{knob}-{measure}.svg"));
            let title = format!(
                "{y_label} against the {knob} tolerance, phi = {}",
                rows.first().map_or(0.0, |r| r.packing_fraction)
            );
            line_plot(
                &path,
                &Figure {
                    title: &title,
                    x_label: knob_label,
                    y_label,
                    log_x: true,
                    log_y,
                },
                &series,
            )?;
            paths.push(path);
        }
    }
    Ok(paths)
}

/// The tolerance suite's table in Markdown, and the loosest safe ε_d per
/// aspect.
pub fn tolerance_table(rows: &[ToleranceRow]) -> String {
    let columns = [
        "aspect",
        "N",
        "phi",
        "eps_d",
        "Newton tol",
        "collisions",
        "us/collision, median of 10 stretches (range)",
        "energy drift/collision",
        "max contact-time error (first 100)",
        "follows reference for",
        "missed",
    ];
    let mut out = markdown_table(
        &columns,
        rows.iter().map(|r| {
            vec![
                r.aspect.to_string(),
                r.n.to_string(),
                r.packing_fraction.to_string(),
                format!("{:.0e}", r.grazing_threshold),
                format!("{:.0e}", r.newton_tolerance),
                r.collisions.to_string(),
                format!(
                    "{:.0} ({:.0}-{:.0})",
                    r.us_per_collision, r.us_per_collision_range.0, r.us_per_collision_range.1
                ),
                format!("{:.1e}", r.energy_drift_per_collision),
                format!("{:.1e}", r.max_contact_time_error),
                if r.reference {
                    "(reference)".to_string()
                } else {
                    format!("{} collisions", r.departure_collisions)
                },
                r.missed.as_deref().unwrap_or("none").to_string(),
            ]
        }),
    );
    for (aspect, eps) in loosest_safe_grazing(rows) {
        out += &format!(
            "aspect {aspect}: loosest eps_d with no missed collision: {}\n",
            eps.map(|e| format!("{e:.0e}"))
                .unwrap_or_else(|| "none".into())
        );
    }
    out
}
