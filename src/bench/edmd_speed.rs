//! `hardbody bench edmd`: wall time per collision of the event-driven
//! dynamics on one core, for the systems issue 4 names, beside the figures
//! published for other codes.
//!
//! Each system starts from an overlap-free state (a lattice where aligned
//! bodies fit at the packing fraction, else a Monte Carlo compression), is
//! run for 10 collisions per body to forget it, and is then timed in
//! repeats of a fixed number of collisions; the table gives the median
//! (and the range) of the repeats.

use super::markdown_table;
use std::time::Instant;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::BenchError;
use crate::edmd::{Dynamics, DynamicsOptions};
use crate::geometry::Shape;
use crate::mc::compress::{CompressOptions, compress};
use crate::mc::moves::MoveSizes;
use crate::space::PeriodicBox;
use crate::state::{Species, System};

/// One system of the suite.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpeedRow {
    /// What is simulated.
    pub system: String,
    /// Shape, in the scene spelling.
    pub shape: String,
    /// Bodies.
    pub n: usize,
    /// φ.
    pub packing_fraction: f64,
    /// Bodies of revolution: the symmetry semi-axis over the others.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub aspect: Option<f64>,
    /// Superellipsoids: the exponent p of |z/c|ᵖ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exponent: Option<f64>,
    /// Neighbour structure of the dynamics.
    pub neighbours: String,
    /// The neighbour-list shell (None: cells).
    pub shell: Option<f64>,
    /// ε_d of the contact searches (eq. 39), in units of the smallest
    /// semi-axis.
    pub grazing_threshold: f64,
    /// Collisions per timed repeat.
    pub collisions_per_repeat: u64,
    /// Timed repeats.
    pub repeats: usize,
    /// Median over the repeats of the wall time per collision.
    pub median_us_per_collision: f64,
    /// Fastest repeat.
    pub min_us_per_collision: f64,
    /// Slowest repeat.
    pub max_us_per_collision: f64,
    /// Exact distance evaluations of the collision searches per collision
    /// (timed repeats).
    pub distances_per_collision: f64,
    /// Solver iterations (Newton steps; GJK/EPA and feature iterations for
    /// pairs with a cuboid) per exact distance evaluation.
    pub iterations_per_distance: f64,
    /// The target on one core.
    pub target_us_per_collision: f64,
    /// Published figures to compare with.
    pub reference: String,
}

/// How a system starts.
enum Start {
    /// Aligned on a lattice at the packing fraction.
    Lattice,
    /// Compressed by Monte Carlo from a dilute lattice.
    Compressed,
}

struct Setup {
    system: String,
    shape: String,
    n: usize,
    phi: f64,
    start: Start,
    collisions: u64,
    target: f64,
    reference: &'static str,
    /// Bodies of revolution: symmetry semi-axis over the other two.
    aspect: Option<f64>,
    /// Superellipsoids: the exponent p of |z/c|ᵖ.
    exponent: Option<f64>,
}

fn setups(quick: bool) -> Vec<Setup> {
    let scale = if quick { 10 } else { 1 };
    // Quick: smaller systems too (a smoke run; the compressions dominate).
    let n = |full: usize, small: usize| if quick { small } else { full };
    vec![
        Setup {
            system: "hard spheres".into(),
            shape: "Sphere(radius: 0.5)".into(),
            n: n(4000, 1000),
            phi: 0.5,
            start: Start::Lattice,
            collisions: 200_000 / scale,
            target: 1.0,
            reference: "Smallenburg's single-event code ~0.8 us here; De Michele 250 us",
            aspect: None,
            exponent: None,
        },
        Setup {
            system: "ellipsoids, aspect 2".into(),
            shape: PROLATE.into(),
            n: n(256, 64),
            phi: 0.5,
            start: Start::Compressed,
            collisions: 5000 / scale,
            target: 25.0,
            reference: "De Michele (Fig. 7, with NNL) 2.5 ms",
            aspect: None,
            exponent: None,
        },
        Setup {
            system: "ellipsoids, aspect 0.5".into(),
            shape: OBLATE.into(),
            n: n(256, 64),
            phi: 0.5,
            start: Start::Compressed,
            collisions: 5000 / scale,
            target: 25.0,
            reference: "De Michele (Fig. 7, with NNL) 2.5 ms",
            aspect: None,
            exponent: None,
        },
        Setup {
            system: "cubes".into(),
            shape: "Cuboid(a: 0.5, b: 0.5, c: 0.5)".into(),
            n: n(1000, 216),
            phi: 0.5,
            start: Start::Lattice,
            collisions: 5000 / scale,
            target: 30.0,
            reference: "a public GJK-based EDMD ~120 us here",
            aspect: None,
            exponent: None,
        },
        // The shapes of the polytope kernels: the same cubes given by
        // their corners (against the row above), regular tetrahedra, and
        // spherocylinders as long as they are wide.
        plain(
            "cubes of corners",
            "Cube(edge: 1.0)",
            n(1000, 216),
            0.5,
            Start::Lattice,
            5000 / scale,
        ),
        plain(
            "tetrahedra",
            "Tetrahedron(edge: 1.0)",
            n(1000, 216),
            0.45,
            Start::Compressed,
            5000 / scale,
        ),
        plain(
            "spherocylinders, L/D 1",
            "Spherocylinder(radius: 0.5, length: 1.0)",
            n(1000, 216),
            0.45,
            Start::Compressed,
            5000 / scale,
        ),
    ]
}

/// The start of a system: `n` bodies at packing fraction `phi`.
fn start(setup: &Setup, seed: u64) -> Result<System, BenchError> {
    let shape: Shape = setup.shape.parse()?;
    let species = vec![Species {
        name: setup.system.clone(),
        shape,
        rotation: !shape.is_sphere(),
    }];
    let mut rng = Pcg64::seed_from_u64(seed);
    let at = |phi: f64| -> Result<PeriodicBox, BenchError> {
        let side = (setup.n as f64 * shape.volume() / phi).cbrt();
        Ok(PeriodicBox::new(Vector3::repeat(side))?)
    };
    match setup.start {
        Start::Lattice => Ok(crate::state::start::lattice(
            at(setup.phi)?,
            species,
            &[setup.n],
            &mut rng,
        )?),
        Start::Compressed => {
            let mut system =
                crate::state::start::lattice(at(0.05)?, species, &[setup.n], &mut rng)?;
            let sizes = MoveSizes {
                translate: 0.3,
                rotate: 0.3,
                volume: 0.0,
                shear: 0.01,
            };
            compress(
                &mut system,
                sizes,
                &CompressOptions::to(setup.phi),
                &mut rng,
            )?;
            Ok(system)
        }
    }
}

/// Runs the suite (`quick`: smaller systems, a tenth of the collisions,
/// three repeats): each system with cells and with neighbour lists of three
/// shells at the default ε_d, and the ellipsoids also in the setting of the
/// paper's Fig. 7.
pub fn speed(quick: bool) -> Result<Vec<SpeedRow>, BenchError> {
    let repeats = if quick { 3 } else { 5 };
    let mut rows = Vec::new();
    for setup in setups(quick) {
        let system = start(&setup, 1)?;
        // Cells, then neighbour lists with shells of 0.05, 0.1 and 0.25 of
        // the bounding diameter.
        let diameter = 2.0 * system.species()[0].shape.bounding_radius();
        for shell in [None, Some(0.05), Some(0.1), Some(0.25)] {
            let shell = shell.map(|f| f * diameter);
            rows.push(time_system(&setup, &system, shell, repeats, quick)?);
        }
        if setup.system.starts_with("ellipsoids") {
            rows.extend(figure_7_setting(&setup, &system, repeats, quick)?);
        }
    }
    Ok(rows)
}

/// The setting of De Michele's Fig. 7 (Sec. 4.2), in the paper's unit of
/// length, the smallest semi-axis: ε_d = 1e-5, cells only and with
/// neighbour lists of shell Δ_NNL = 0.15.
fn figure_7_setting(
    setup: &Setup,
    system: &System,
    repeats: usize,
    quick: bool,
) -> Result<Vec<SpeedRow>, BenchError> {
    let unit = system.species()[0].shape.min_half_extent();
    let mut rows = Vec::with_capacity(2);
    for neighbour_shell in [None, Some(0.15 * unit)] {
        let mut options = DynamicsOptions {
            neighbour_shell,
            ..DynamicsOptions::default()
        };
        options.predictor.grazing_threshold = 1e-5;
        let mut row = time_with(setup, system, &options, repeats, quick)?;
        row.neighbours.push_str(" (Fig. 7: eps_d 1e-5, shell 0.15)");
        rows.push(row);
    }
    Ok(rows)
}

/// The system timed with cells, then with neighbour lists of `shell`.
fn cells_and_lists(
    setup: &Setup,
    system: &System,
    shell: f64,
    repeats: usize,
    quick: bool,
) -> Result<[SpeedRow; 2], BenchError> {
    Ok([
        time_system(setup, system, None, repeats, quick)?,
        time_system(setup, system, Some(shell), repeats, quick)?,
    ])
}

/// The shell the dynamics picks by itself for `system`.
fn auto_shell(system: &System) -> Result<f64, BenchError> {
    let polydisperse = system.sizes().is_some();
    crate::edmd::automatic_neighbour_shell(
        system.species(),
        system.packing_fraction(),
        polydisperse,
    )
    .ok_or_else(|| BenchError::Wrong {
        system: "this system".into(),
        what: "no automatic neighbour lists".into(),
    })
}

/// Times one system with one neighbour structure: 10 collisions per body
/// to forget the start, then `repeats` timed runs.
fn time_system(
    setup: &Setup,
    system: &System,
    neighbour_shell: Option<f64>,
    repeats: usize,
    quick: bool,
) -> Result<SpeedRow, BenchError> {
    let options = DynamicsOptions {
        neighbour_shell,
        ..DynamicsOptions::default()
    };
    time_with(setup, system, &options, repeats, quick)
}

/// Times one system run with `options`.
fn time_with(
    setup: &Setup,
    system: &System,
    options: &DynamicsOptions,
    repeats: usize,
    quick: bool,
) -> Result<SpeedRow, BenchError> {
    let neighbour_shell = options.neighbour_shell;
    let mut rng = Pcg64::seed_from_u64(2);
    let mut md = Dynamics::from_state(system, options, &mut rng)?;
    let fail = |e: crate::edmd::EdmdError| BenchError::from(e).of(&setup.system);
    md.run_collisions(10 * setup.n as u64 / if quick { 10 } else { 1 })
        .map_err(fail)?;
    let mut times = Vec::with_capacity(repeats);
    let work_before = md.solver_work();
    for _ in 0..repeats {
        let clock = Instant::now();
        md.run_collisions(setup.collisions).map_err(fail)?;
        times.push(clock.elapsed().as_secs_f64() * 1e6 / setup.collisions as f64);
    }
    // Checked a moment after the last collision, whose pair touches (to
    // rounding) at it and counts as overlapping in the MC test.
    let work = md.solver_work();
    let distances = (work.distances - work_before.distances) as f64;
    let iterations = (work.iterations - work_before.iterations) as f64;
    md.run_until(md.time() + 1e-3).map_err(fail)?;
    md.to_system().map_err(|e| BenchError::Wrong {
        system: setup.system.clone(),
        what: format!("overlap at the end: {e}"),
    })?;
    times.sort_by(f64::total_cmp);
    Ok(SpeedRow {
        system: setup.system.clone(),
        shape: setup.shape.clone(),
        aspect: setup.aspect,
        exponent: setup.exponent,
        n: setup.n,
        packing_fraction: setup.phi,
        neighbours: match neighbour_shell {
            None => "cells".into(),
            Some(shell) => format!("lists, shell {shell:.3}"),
        },
        shell: neighbour_shell,
        grazing_threshold: options.predictor.grazing_threshold,
        collisions_per_repeat: setup.collisions,
        repeats,
        median_us_per_collision: times[repeats / 2],
        min_us_per_collision: times[0],
        max_us_per_collision: times[repeats - 1],
        distances_per_collision: distances / (repeats as u64 * setup.collisions) as f64,
        iterations_per_distance: if distances > 0.0 {
            iterations / distances
        } else {
            0.0
        },
        target_us_per_collision: setup.target,
        reference: setup.reference.into(),
    })
}

const PROLATE: &str = "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)";
const OBLATE: &str = "Ellipsoid(a: 0.25, b: 0.5, c: 0.5)";
const CUBE: &str = "Cuboid(a: 0.5, b: 0.5, c: 0.5)";
const SUPERBALL: &str = "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))";

/// A system of the parameter suites (no target, no published figure).
fn plain(system: &str, shape: &str, n: usize, phi: f64, start: Start, collisions: u64) -> Setup {
    Setup {
        system: system.into(),
        shape: shape.into(),
        aspect: None,
        exponent: None,
        n,
        phi,
        start,
        collisions,
        target: f64::NAN,
        reference: "",
    }
}

/// `hardbody bench edmd-shell` (De Michele Figs. 10–11): time per collision
/// against the neighbour shell Δ for hard spheres at φ = 0.3, 0.4, 0.5 and
/// prolate ellipsoids (2:1), and without `quick` cubes and superballs
/// (exponents 4), at φ = 0.5, with the cells time and for bodies the
/// automatic shell's beside each; the best Δ per system.
pub fn shell(quick: bool) -> Result<Vec<SpeedRow>, BenchError> {
    let repeats = if quick { 3 } else { 5 };
    let (n_spheres, sphere_collisions) = if quick {
        (1000, 20_000)
    } else {
        (4000, 200_000)
    };
    let mut setups: Vec<Setup> = [0.3, 0.4, 0.5]
        .into_iter()
        .map(|phi| {
            plain(
                "hard spheres",
                "Sphere(radius: 0.5)",
                n_spheres,
                phi,
                Start::Lattice,
                sphere_collisions,
            )
        })
        .collect();
    setups.push(plain(
        "ellipsoids, aspect 2",
        PROLATE,
        256,
        0.5,
        Start::Compressed,
        if quick { 500 } else { 5000 },
    ));
    if !quick {
        // Bodies whose pair searches cost most unlike an ellipsoid's: the
        // cheap separating axes of cubes, the dear supports of superballs.
        setups.push(plain("cubes", CUBE, 512, 0.5, Start::Compressed, 5000));
        setups.push(plain(
            "superballs, exponents 4",
            SUPERBALL,
            512,
            0.5,
            Start::Compressed,
            1000,
        ));
    }
    // Shells in units of the bounding diameter.
    let fractions: &[f64] = if quick {
        &[0.05, 0.2, 0.5]
    } else {
        &[0.0125, 0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.8]
    };
    let mut rows = Vec::new();
    for setup in &setups {
        let system = start(setup, 1)?;
        let diameter = 2.0 * system.species()[0].shape.bounding_radius();
        rows.push(time_system(setup, &system, None, repeats, quick)?);
        if !system.species()[0].shape.is_sphere() {
            let mut row = time_system(setup, &system, Some(auto_shell(&system)?), repeats, quick)?;
            row.neighbours.push_str(" (automatic)");
            rows.push(row);
        }
        for f in fractions {
            rows.push(time_system(
                setup,
                &system,
                Some(f * diameter),
                repeats,
                quick,
            )?);
        }
    }
    Ok(rows)
}

/// `hardbody bench edmd-density` (De Michele Fig. 7): time per collision
/// against φ for ellipsoids of aspect 2 and 0.5 (N = 256), cells and
/// neighbour lists (shell a twentieth of the bounding diameter), each φ
/// compressed by Monte Carlo from the previous one.
pub fn density(quick: bool) -> Result<Vec<SpeedRow>, BenchError> {
    let repeats = if quick { 3 } else { 5 };
    let phis: &[f64] = if quick {
        &[0.3, 0.45]
    } else {
        &[0.2, 0.3, 0.4, 0.45, 0.5]
    };
    let collisions = if quick { 300 } else { 5000 };
    let mut rows = Vec::new();
    for (name, shape) in [
        ("ellipsoids, aspect 2", PROLATE),
        ("ellipsoids, aspect 0.5", OBLATE),
    ] {
        let dilute = plain(name, shape, 256, 0.05, Start::Lattice, collisions);
        let mut system = start(&dilute, 1)?;
        let mut rng = Pcg64::seed_from_u64(3);
        let sizes = MoveSizes {
            translate: 0.3,
            rotate: 0.3,
            volume: 0.0,
            shear: 0.01,
        };
        let diameter = 2.0 * system.species()[0].shape.bounding_radius();
        for &phi in phis {
            compress(&mut system, sizes, &CompressOptions::to(phi), &mut rng)?;
            let setup = plain(name, shape, 256, phi, Start::Compressed, collisions);
            rows.extend(cells_and_lists(
                &setup,
                &system,
                0.05 * diameter,
                repeats,
                quick,
            )?);
        }
    }
    Ok(rows)
}

/// `hardbody bench edmd-elongation` (De Michele Fig. 8): time per
/// collision against the aspect ratio X = a/b of ellipsoids of revolution
/// (semi-axes 0.5·X, 0.5, 0.5) at φ = 0.3, 0.4, 0.5, with cells and with
/// oriented-box lists (the automatic shell, a tenth of the thickness).
/// Starts: aligned lattices at φ (near-cubic boxes large enough for the
/// minimum image, so N grows with the long axis) relaxed by 50 Monte Carlo
/// sweeps. Medians of the repeats; the ratio cells/lists is in the plot.
pub fn elongation(quick: bool) -> Result<Vec<SpeedRow>, BenchError> {
    let repeats = if quick { 3 } else { 5 };
    let aspects: &[f64] = if quick {
        &[0.5, 5.0]
    } else {
        &[0.1, 0.2, 0.5, 2.0, 5.0, 10.0]
    };
    let phis: &[f64] = if quick { &[0.4] } else { &[0.3, 0.4, 0.5] };
    let collisions = if quick { 300 } else { 3000 };
    let mut rows = Vec::new();
    for &phi in phis {
        for &aspect in aspects {
            let text = format!("Ellipsoid(a: {}, b: 0.5, c: 0.5)", 0.5 * aspect);
            let shape: Shape = text.parse()?;
            let system = aligned_state(&shape, phi, quick)?;
            let setup = Setup {
                system: format!("ellipsoids, aspect {aspect}"),
                shape: text,
                n: system.len(),
                phi,
                start: Start::Lattice,
                collisions,
                target: f64::NAN,
                reference: "",
                aspect: Some(aspect),
                exponent: None,
            };
            rows.extend(cells_and_lists(
                &setup,
                &system,
                auto_shell(&system)?,
                repeats,
                quick,
            )?);
        }
    }
    Ok(rows)
}

/// An aligned lattice of `shape` at `phi` in a box at least twice the
/// interaction range across (at least 256 bodies; fewer when `quick`),
/// relaxed by Monte Carlo sweeps tuned to 30 % acceptance.
pub fn aligned_state(shape: &Shape, phi: f64, quick: bool) -> Result<System, BenchError> {
    // Bodies needed for an edge of twice the range, with room to spare.
    let edge = 4.0 * shape.bounding_radius() * 1.3;
    let mut n = ((edge.powi(3) * phi / shape.volume()) as usize).max(if quick { 100 } else { 256 });
    loop {
        match super::mc::tuned(shape, n, phi, if quick { 10 } else { 50 }) {
            Ok((system, _)) => return Ok(system),
            Err(crate::state::StateError::BoxTooSmall { .. }) if n < 200_000 => n += n / 2,
            Err(e) => return Err(e.into()),
        }
    }
}

/// `hardbody bench superellipsoid` (De Michele Fig. 13): time per
/// collision, distance evaluations per collision and solver iterations per
/// evaluation against the exponent p of superellipsoids
/// |x/a|² + |y/b|² + |z/c|ᵖ = 1 with b = c and elongation X₀ = a/b of 0.5
/// and 2 (the paper's N = 512 at φ = 0.256), cells and oriented-box lists.
pub fn superellipsoid(quick: bool) -> Result<Vec<SpeedRow>, BenchError> {
    let repeats = if quick { 3 } else { 5 };
    let exponents: &[f64] = if quick {
        &[2.0, 8.0]
    } else {
        &[2.0, 3.0, 4.0, 6.0, 8.0, 10.0]
    };
    let elongations: &[f64] = if quick { &[2.0] } else { &[0.5, 2.0] };
    let (n, collisions) = if quick { (64, 100) } else { (512, 500) };
    let mut rows = Vec::new();
    for &x0 in elongations {
        for &p in exponents {
            let text = format!(
                "Superellipsoid(a: {}, b: 0.5, c: 0.5, exponents: (2.0, 2.0, {p:.1}))",
                0.5 * x0
            );
            let mut setup = plain(
                &format!("superellipsoids X0 {x0}, p {p}"),
                &text,
                n,
                0.256,
                Start::Lattice,
                collisions,
            );
            setup.aspect = Some(x0);
            setup.exponent = Some(p);
            let system = start(&setup, 1)?;
            rows.extend(cells_and_lists(
                &setup,
                &system,
                auto_shell(&system)?,
                repeats,
                quick,
            )?);
        }
    }
    Ok(rows)
}

/// The rows of a time-per-collision suite as a Markdown table.
pub fn table(rows: &[SpeedRow]) -> String {
    let columns = [
        "system",
        "N",
        "phi",
        "neighbours",
        "us/collision, median (range)",
        "distances/collision",
        "iterations/distance",
        "target",
        "published",
    ];
    markdown_table(
        &columns,
        rows.iter().map(|r| {
            vec![
                r.system.to_string(),
                r.n.to_string(),
                r.packing_fraction.to_string(),
                r.neighbours.to_string(),
                format!(
                    "{:.2} ({:.2}-{:.2}) over {} x {} collisions",
                    r.median_us_per_collision,
                    r.min_us_per_collision,
                    r.max_us_per_collision,
                    r.repeats,
                    r.collisions_per_repeat
                ),
                format!("{:.1}", r.distances_per_collision),
                format!("{:.2}", r.iterations_per_distance),
                if r.target_us_per_collision.is_finite() {
                    format!("<= {}", r.target_us_per_collision)
                } else {
                    "-".into()
                },
                if r.reference.is_empty() {
                    "-".into()
                } else {
                    r.reference.to_string()
                },
            ]
        }),
    )
}
