//! Hard-sphere NPT Monte Carlo against the Carnahan–Starling equation of
//! state, the ideal-gas check of the ln V box move, and overlap-free states
//! checked by the independent all-pairs test.

use hardbody::analysis::eos::carnahan_starling_packing_fraction;
use std::f64::consts::PI;

use hardbody::geometry::Shape;
use hardbody::mc::box_moves::{BoxMoves, box_move};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::mc::tuning::Tuner;
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, Species, System};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use statrs::statistics::Statistics;

/// N = n³ spheres of diameter 1 on a simple cubic lattice at packing
/// fraction `phi` (mechanically unstable for hard spheres: it melts at once).
fn cubic_spheres(n: usize, phi: f64) -> System {
    let count = n * n * n;
    let len = (count as f64 * PI / 6.0 / phi).cbrt();
    let a = len / n as f64;
    let mut particles = Vec::with_capacity(count);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                particles.push(Particle {
                    position: Vector3::new(i as f64, j as f64, k as f64) * a
                        - Vector3::repeat(len / 2.0),
                    orientation: UnitQuaternion::identity(),
                    species: 0,
                });
            }
        }
    }
    let species = vec![Species {
        name: "sphere".into(),
        shape: "Sphere(radius: 0.5)".parse::<Shape>().unwrap(),
        rotation: false,
    }];
    System::new(
        PeriodicBox::new(Vector3::repeat(len)).unwrap(),
        species,
        particles,
    )
    .unwrap()
}

/// Means of consecutive blocks of `size` samples.
fn block_means(samples: &[f64], size: usize) -> Vec<f64> {
    samples.chunks_exact(size).map(|c| c.mean()).collect()
}

/// Mean and standard error of (nearly independent) block means.
fn mean_and_error(blocks: &[f64]) -> (f64, f64) {
    (
        blocks.iter().mean(),
        blocks.iter().std_dev() / (blocks.len() as f64).sqrt(),
    )
}

/// One replica: equilibrates with tuning, then samples φ every sweep with
/// frozen move sizes. The start is a melting cubic lattice a little below
/// the expected density (where it starts does not change where it ends).
fn npt_replica(beta_p: f64, seed: u64) -> (Vec<f64>, System) {
    let mut system = cubic_spheres(7, 0.9 * carnahan_starling_packing_fraction(beta_p)); // 343 spheres
    let mut rng = Pcg64::seed_from_u64(seed);
    let ensemble = Ensemble::Npt {
        pressure: beta_p,
        moves: BoxMoves::Isotropic,
    };
    let mut sizes = MoveSizes {
        translate: 0.2,
        rotate: 0.0,
        volume: 0.01,
        shear: 0.01,
    };
    let tuner = Tuner {
        target: 0.3,
        max_translate: 1.0,
    };
    tuner.equilibrate(&mut system, &mut sizes, &ensemble, 6000, 50, &mut rng);
    let mut samples = Vec::new();
    for _ in 0..25_000 {
        sweep(&mut system, &sizes, &ensemble, &mut rng);
        samples.push(system.packing_fraction());
    }
    (samples, system)
}

/// Four independent replicas per pressure. Density fluctuations of the
/// dense fluid decay over thousands of sweeps, so the error comes from
/// blocks of 5000 sweeps (20 in all), which are close to independent.
#[test]
fn hard_spheres_follow_carnahan_starling() {
    use rayon::prelude::*;
    let pressures = [1.0, 3.0, 6.0];
    let runs: Vec<(usize, Vec<f64>, System)> = (0..pressures.len() * 4)
        .into_par_iter()
        .map(|k| {
            let (samples, system) = npt_replica(pressures[k / 4], 40 + k as u64);
            (k / 4, samples, system)
        })
        .collect();
    for (p, &beta_p) in pressures.iter().enumerate() {
        let mut blocks = Vec::new();
        for (_, samples, system) in runs.iter().filter(|r| r.0 == p) {
            assert_eq!(
                system.first_overlap_all_pairs(),
                None,
                "overlap at the end of βP = {beta_p}"
            );
            blocks.extend(block_means(samples, 5000));
        }
        let (mean, se) = mean_and_error(&blocks);
        let cs = carnahan_starling_packing_fraction(beta_p);
        eprintln!("βP = {beta_p}: φ = {mean:.5} ± {se:.5}, Carnahan–Starling {cs:.5}");
        assert!(
            (mean - cs).abs() < 3.0 * se && (mean - cs).abs() < 0.005,
            "βP = {beta_p}: φ = {mean:.5} ± {se:.5}, Carnahan–Starling {cs:.5}"
        );
        assert!(se > 0.0 && se < 0.002, "βP = {beta_p}: standard error {se}");
    }
}

/// With overlaps switched off the ln V move samples p(V) ∝ V^N e^{−βPV} dV
/// (the extra V of the ln V measure included), whose mean is (N+1)/βP.
#[test]
fn ideal_gas_volume_moves_give_n_plus_one_over_p() {
    let mut system = cubic_spheres(3, 0.05); // 27 particles
    system.set_ideal(true);
    let beta_p = 0.5;
    let mut rng = Pcg64::seed_from_u64(5);
    let sizes = MoveSizes {
        translate: 0.5,
        rotate: 0.0,
        volume: 0.3,
        shear: 0.01,
    };
    let mut volumes = Vec::new();
    for _ in 0..200_000 {
        box_move(
            &mut system,
            beta_p,
            (sizes.volume, sizes.shear),
            BoxMoves::Isotropic,
            &mut rng,
        );
        volumes.push(system.periodic_box().volume());
    }
    let (mean, se) = mean_and_error(&block_means(&volumes[10_000..], 9_500));
    let exact = (system.len() as f64 + 1.0) / beta_p;
    eprintln!("ideal gas: ⟨V⟩ = {mean:.3} ± {se:.3}, (N+1)/βP = {exact}");
    assert!(
        (mean - exact).abs() < 3.0 * se,
        "⟨V⟩ = {mean} ± {se}, (N+1)/βP = {exact}"
    );
    assert!(se < 0.01 * exact);
}

/// With overlaps off, ln L moves of one edge at a time sample
/// p(ln Lx, ln Ly, ln Lz) ∝ V^{N+1} e^{−βPV} with every edge at least
/// twice the interaction range c₀ (the box's own bound), so
/// p(V) ∝ V^N e^{−βPV} (ln V − 3 ln c₀)² on V ≥ c₀³ (the area of the slice
/// of fixed ln V); its mean by quadrature is what the chain must give.
#[test]
fn ideal_gas_edge_moves_sample_the_edge_distribution() {
    let mut system = cubic_spheres(3, 0.05);
    system.set_ideal(true);
    let (beta_p, n) = (0.5, system.len() as f64);
    let floor = 2.0 * system.interaction_range();
    let mut rng = Pcg64::seed_from_u64(11);
    let mut volumes = Vec::new();
    for _ in 0..400_000 {
        box_move(&mut system, beta_p, (0.3, 0.0), BoxMoves::Axes, &mut rng);
        volumes.push(system.periodic_box().volume());
    }
    let (mean, se) = mean_and_error(&block_means(&volumes[20_000..], 19_000));
    // ∫ V p(V) dV / ∫ p(V) dV on a fine grid in ln V.
    let c = 3.0 * floor.ln();
    let log_weight = |u: f64| (n + 1.0) * u - beta_p * u.exp() + 2.0 * (u - c).ln();
    let grid: Vec<f64> = (1..200_000).map(|k| c + k as f64 * 1e-4).collect();
    let peak = grid.iter().map(|&u| log_weight(u)).fold(f64::MIN, f64::max);
    let (mut z, mut first) = (0.0, 0.0);
    for &u in &grid {
        let w = (log_weight(u) - peak).exp();
        z += w;
        first += w * u.exp();
    }
    let exact = first / z;
    eprintln!("ideal gas, edge moves: <V> = {mean:.3} ± {se:.3}, exact {exact:.3}");
    assert!(
        (mean - exact).abs() < 3.0 * se,
        "<V> = {mean} ± {se}, exact {exact}"
    );
    assert!(se < 0.01 * exact);
    // The isotropic answer, (N+1)/βP, is far off: the test can tell.
    assert!(((n + 1.0) / beta_p - exact).abs() > 10.0 * se);
}

/// With overlaps off and the edges held, shear moves with lattice
/// reduction sample the tilts uniformly over the reduced cell of tilts
/// (|t| ≤ 1/2 in a cube): ⟨t²⟩ = 1/12 for each, and no tilt leaves it.
#[test]
fn ideal_gas_shear_moves_sample_tilts_uniformly() {
    let mut system = cubic_spheres(3, 0.05);
    system.set_ideal(true);
    let mut rng = Pcg64::seed_from_u64(12);
    let mut squares = [Vec::new(), Vec::new(), Vec::new()];
    let mut sheared = 0;
    for _ in 0..300_000 {
        let outcome = box_move(&mut system, 1.0, (0.0, 0.4), BoxMoves::Triclinic, &mut rng);
        sheared += usize::from(outcome.shear && outcome.accepted);
        let t = system.periodic_box().tilts();
        for k in 0..3 {
            assert!(t[k].abs() <= 0.5 + 1e-12, "tilt {t}");
            squares[k].push(t[k] * t[k]);
        }
    }
    assert!(sheared > 100_000, "{sheared}");
    for (k, sq) in squares.iter().enumerate() {
        let (mean, se) = mean_and_error(&block_means(&sq[10_000..], 14_500));
        eprintln!(
            "tilt {k}: <t^2> = {mean:.5} ± {se:.5}, uniform 1/12 = {:.5}",
            1.0 / 12.0
        );
        assert!(
            (mean - 1.0 / 12.0).abs() < 3.0 * se && se < 0.003,
            "{k}: {mean} ± {se}"
        );
    }
}

/// NVT at φ = 0.3: the pressure from the scale distribution function agrees
/// with Carnahan–Starling, βPσ³ = ρσ³ (1 + η + η² − η³)/(1 − η)³.
#[test]
fn nvt_sdf_pressure_follows_carnahan_starling() {
    use hardbody::mc::sdf::Sdf;
    let phi = 0.3;
    let rho = 6.0 * phi / PI;
    let cs = rho * (1.0 + phi + phi * phi - phi.powi(3)) / (1.0 - phi).powi(3);
    let mut system = cubic_spheres(7, phi);
    let mut rng = Pcg64::seed_from_u64(77);
    let sizes = MoveSizes {
        translate: 0.5,
        rotate: 0.0,
        volume: 0.0,
        shear: 0.01,
    };
    for _ in 0..2000 {
        sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
    }
    // Independent estimates from 10 blocks of configurations.
    let mut estimates = Vec::new();
    for _ in 0..10 {
        let mut sdf = Sdf::new(0.02, 200);
        for _ in 0..100 {
            for _ in 0..10 {
                sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
            }
            sdf.add(&system);
        }
        estimates.push(sdf.pressure().unwrap());
    }
    let (mean, se) = mean_and_error(&estimates);
    eprintln!("NVT phi = 0.3: SDF betaP = {mean:.4} ± {se:.4}, Carnahan–Starling {cs:.4}");
    assert!(
        (mean - cs).abs() < 3.0 * se && (mean - cs).abs() < 0.02 * cs,
        "SDF βP = {mean} ± {se}, CS {cs}"
    );
}
