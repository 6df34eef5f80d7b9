//! The collision-virial pressure of the event-driven dynamics against the
//! scale-distribution-function pressure of Metropolis MC at the same
//! density, for prolate ellipsoids and cubes: two independent estimators
//! (one from impulses, one from overlap-free rescalings). A collision rule
//! with a wrong contact point or normal still conserves energy and momentum,
//! but not this.

mod common;

use common::compressed_state;
use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::mc::sdf::Sdf;
use hardbody::mc::tuning::Tuner;
use hardbody::state::System;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use statrs::statistics::Statistics;

/// βP from MC in NVT by the SDF: mean and standard error over blocks.
fn mc_sdf_pressure(mut system: System, seed: u64) -> (f64, f64) {
    let mut rng = Pcg64::seed_from_u64(seed);
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
    tuner.equilibrate(&mut system, &mut sizes, &Ensemble::Nvt, 3000, 50, &mut rng);
    let mut blocks = Vec::new();
    for _ in 0..16 {
        let mut sdf = Sdf::new(0.02, 200);
        for _ in 0..60 {
            for _ in 0..5 {
                sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
            }
            sdf.add(&system);
        }
        blocks.push(sdf.pressure().unwrap());
    }
    (
        blocks.iter().mean(),
        blocks.iter().std_dev() / (blocks.len() as f64).sqrt(),
    )
}

/// βP from the dynamics' collision virial: mean and standard error over
/// blocks of `per_block` collisions.
fn edmd_pressure(system: &System, seed: u64, per_block: u64) -> (f64, f64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut md = Dynamics::from_state(system, &DynamicsOptions::default(), &mut rng).unwrap();
    md.run_collisions(5 * per_block).unwrap();
    md.sample();
    let mut blocks = Vec::new();
    for _ in 0..16 {
        md.run_collisions(per_block).unwrap();
        blocks.push(md.sample().pressure.unwrap());
    }
    md.to_system().expect("no overlap at the end");
    (
        blocks.iter().mean(),
        blocks.iter().std_dev() / (blocks.len() as f64).sqrt(),
    )
}

#[test]
fn collision_virial_matches_the_sdf_pressure() {
    let cases = [
        ("Ellipsoid(a: 1.0, b: 0.5, c: 0.5)", 0.40, 1u64),
        ("Cuboid(a: 0.5, b: 0.5, c: 0.5)", 0.40, 2u64),
    ];
    let results: Vec<((f64, f64), (f64, f64))> = cases
        .par_iter()
        .map(|&(shape, phi, seed)| {
            let system = compressed_state(&[shape], 6, phi, seed);
            let md = edmd_pressure(&system, seed + 10, 2000);
            let mc = mc_sdf_pressure(system, seed + 20);
            (md, mc)
        })
        .collect();
    for ((shape, phi, _), ((md, md_se), (mc, mc_se))) in cases.iter().zip(&results) {
        eprintln!(
            "{shape} phi {phi}: EDMD betaP = {md:.4} ± {md_se:.4}, MC SDF {mc:.4} ± {mc_se:.4} ({:+.2} %)",
            100.0 * (md / mc - 1.0)
        );
    }
    for ((shape, _, _), &((md, md_se), (mc, mc_se))) in cases.iter().zip(&results) {
        let se = (md_se * md_se + mc_se * mc_se).sqrt();
        assert!(
            (md - mc).abs() < 3.0 * se && (md - mc).abs() < 0.03 * mc,
            "{shape}: EDMD {md} ± {md_se} vs MC {mc} ± {mc_se}"
        );
    }
}
