//! `hardbody bench edmd`: wall time per collision of the event-driven
//! dynamics on one core, for the systems issue 4 names, beside the figures
//! published for other codes.
//!
//! Each system starts from an overlap-free state (a lattice where aligned
//! bodies fit at the packing fraction, else a Monte Carlo compression), is
//! run for 10 collisions per body to forget it, and is then timed in
//! repeats of a fixed number of collisions; the table gives the median
//! (and the range) of the repeats.

use std::time::Instant;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::edmd::{Dynamics, DynamicsOptions};
use crate::geometry::Shape;
use crate::mc::compress::{CompressOptions, compress};
use crate::mc::moves::MoveSizes;
use crate::mc::{Species, System};
use crate::space::PeriodicBox;

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
    /// Neighbour structure of the dynamics.
    pub neighbours: String,
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
    system: &'static str,
    shape: &'static str,
    n: usize,
    phi: f64,
    start: Start,
    collisions: u64,
    target: f64,
    reference: &'static str,
}

fn setups(quick: bool) -> Vec<Setup> {
    let scale = if quick { 10 } else { 1 };
    vec![
        Setup {
            system: "hard spheres",
            shape: "Sphere(radius: 0.5)",
            n: 4000,
            phi: 0.5,
            start: Start::Lattice,
            collisions: 200_000 / scale,
            target: 1.0,
            reference: "Smallenburg's single-event code ~0.8 us here; De Michele 250 us",
        },
        Setup {
            system: "ellipsoids, aspect 2",
            shape: "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)",
            n: 256,
            phi: 0.5,
            start: Start::Compressed,
            collisions: 5000 / scale,
            target: 25.0,
            reference: "De Michele (Fig. 7, with NNL) 2.5 ms",
        },
        Setup {
            system: "ellipsoids, aspect 0.5",
            shape: "Ellipsoid(a: 0.25, b: 0.5, c: 0.5)",
            n: 256,
            phi: 0.5,
            start: Start::Compressed,
            collisions: 5000 / scale,
            target: 25.0,
            reference: "De Michele (Fig. 7, with NNL) 2.5 ms",
        },
        Setup {
            system: "cubes",
            shape: "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
            n: 1000,
            phi: 0.5,
            start: Start::Lattice,
            collisions: 5000 / scale,
            target: 30.0,
            reference: "a public GJK-based EDMD ~120 us here",
        },
    ]
}

/// The start of a system: `n` bodies at packing fraction `phi`.
fn start(setup: &Setup, seed: u64) -> Result<System, String> {
    let shape: Shape = setup.shape.parse().map_err(|e| format!("{e}"))?;
    let species = vec![Species {
        name: setup.system.into(),
        shape,
        rotation: !shape.is_sphere(),
    }];
    let mut rng = Pcg64::seed_from_u64(seed);
    let at = |phi: f64| -> Result<PeriodicBox, String> {
        let side = (setup.n as f64 * shape.volume() / phi).cbrt();
        PeriodicBox::new(Vector3::repeat(side)).map_err(|e| e.to_string())
    };
    match setup.start {
        Start::Lattice => crate::mc::start::lattice(at(setup.phi)?, species, &[setup.n], &mut rng)
            .map_err(|e| e.to_string()),
        Start::Compressed => {
            let mut system = crate::mc::start::lattice(at(0.05)?, species, &[setup.n], &mut rng)
                .map_err(|e| e.to_string())?;
            let sizes = MoveSizes {
                translate: 0.3,
                rotate: 0.3,
                volume: 0.0,
            };
            compress(
                &mut system,
                sizes,
                &CompressOptions::to(setup.phi),
                &mut rng,
            )
            .map_err(|e| e.to_string())?;
            Ok(system)
        }
    }
}

/// Runs the suite (`quick`: a tenth of the collisions, three repeats).
pub fn speed(quick: bool) -> Result<Vec<SpeedRow>, String> {
    let repeats = if quick { 3 } else { 5 };
    let mut rows = Vec::new();
    for setup in setups(quick) {
        let system = start(&setup, 1)?;
        // Cells, then neighbour lists with shells of 0.1, 0.25 and 0.5 of
        // the bounding diameter.
        let diameter = 2.0 * system.species()[0].shape.bounding_radius();
        for shell in [None, Some(0.1), Some(0.25), Some(0.5)] {
            let shell = shell.map(|f| f * diameter);
            rows.push(time_system(&setup, &system, shell, repeats, quick)?);
        }
    }
    Ok(rows)
}

/// Times one system with one neighbour structure: 10 collisions per body
/// to forget the start, then `repeats` timed runs.
fn time_system(
    setup: &Setup,
    system: &System,
    neighbour_shell: Option<f64>,
    repeats: usize,
    quick: bool,
) -> Result<SpeedRow, String> {
    let options = DynamicsOptions {
        neighbour_shell,
        ..DynamicsOptions::default()
    };
    let mut rng = Pcg64::seed_from_u64(2);
    let mut md = Dynamics::from_state(system, &options, &mut rng).map_err(|e| e.to_string())?;
    let fail = |e: crate::edmd::EdmdError| format!("{}: {e}", setup.system);
    md.run_collisions(10 * setup.n as u64 / if quick { 10 } else { 1 })
        .map_err(fail)?;
    let mut times = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let clock = Instant::now();
        md.run_collisions(setup.collisions).map_err(fail)?;
        times.push(clock.elapsed().as_secs_f64() * 1e6 / setup.collisions as f64);
    }
    // Checked a moment after the last collision, whose pair touches (to
    // rounding) at it and counts as overlapping in the MC test.
    md.run_until(md.time() + 1e-3).map_err(fail)?;
    md.to_system()
        .map_err(|e| format!("{}: overlap at the end: {e}", setup.system))?;
    times.sort_by(f64::total_cmp);
    Ok(SpeedRow {
        system: setup.system.into(),
        shape: setup.shape.into(),
        n: setup.n,
        packing_fraction: setup.phi,
        neighbours: match neighbour_shell {
            None => "cells".into(),
            Some(shell) => format!("lists, shell {shell:.3}"),
        },
        collisions_per_repeat: setup.collisions,
        repeats,
        median_us_per_collision: times[repeats / 2],
        min_us_per_collision: times[0],
        max_us_per_collision: times[repeats - 1],
        target_us_per_collision: setup.target,
        reference: setup.reference.into(),
    })
}
