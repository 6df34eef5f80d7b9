//! Checkerboard parallel sweeps: the same trajectory for one thread and for
//! two; no overlaps for spheres, needles and a mixture; and the right
//! physics (hard-sphere NPT against Carnahan–Starling).

use hardbody::bench::mc::dense_start;
use hardbody::geometry::Shape;
use hardbody::mc::System;
use hardbody::mc::moves::{Counts, Ensemble, MoveSizes};
use hardbody::mc::parallel::parallel_sweep;
use hardbody::mc::tuning::Tuner;
use statrs::statistics::Statistics;

fn run(system: &mut System, sweeps: u64, threads: usize, seed: u64) -> Counts {
    let sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.005,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut counts = Counts::default();
        for s in 0..sweeps {
            counts += parallel_sweep(system, &sizes, &Ensemble::Nvt, seed, s);
        }
        counts
    })
}

#[test]
fn same_trajectory_for_any_thread_count() {
    for text in ["Sphere(radius: 0.5)", "Ellipsoid(a: 0.5, b: 0.5, c: 1.5)"] {
        let shape: Shape = text.parse().unwrap();
        let start = dense_start(&shape, 1400, 0.4).unwrap();
        let (mut one, mut two) = (start.clone(), start.clone());
        let c1 = run(&mut one, 30, 1, 7);
        let c2 = run(&mut two, 30, 2, 7);
        assert_eq!(c1, c2, "{text}: counts differ between 1 and 2 threads");
        assert_eq!(one.particles(), two.particles(), "{text}: states differ");
        assert!(c1.translate.accepted > 0 && c1.translate.accepted < c1.translate.tried);
        assert_eq!(one.first_overlap_all_pairs(), None, "{text}: overlap");
    }
}

#[test]
fn parallel_npt_hard_spheres_follow_carnahan_starling() {
    // βP = 3: Carnahan–Starling φ = 0.33239 (see mc_hard_spheres.rs).
    let cs = 0.33239;
    let shape: Shape = "Sphere(radius: 0.5)".parse().unwrap();
    // The trajectory does not depend on the thread count (test above); one
    // thread avoids the per-phase scheduling cost of tiny cells.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut blocks = Vec::new();
    for replica in 0..3u64 {
        let mut system = dense_start(&shape, 500, 0.9 * cs).unwrap();
        let ensemble = Ensemble::Npt {
            pressure: 3.0,
            anisotropic: false,
        };
        let mut sizes = MoveSizes {
            translate: 0.2,
            rotate: 0.0,
            volume: 0.01,
        };
        let tuner = Tuner {
            target: 0.3,
            max_translate: 1.0,
        };
        let mut window = Counts::default();
        let mut samples = Vec::new();
        pool.install(|| {
            for s in 0..20_000u64 {
                window += parallel_sweep(&mut system, &sizes, &ensemble, 100 + replica, s);
                if s < 5000 && s % 50 == 49 {
                    tuner.update(&mut sizes, &window);
                    window = Counts::default();
                }
                if s >= 5000 {
                    samples.push(system.packing_fraction());
                }
            }
        });
        assert_eq!(system.first_overlap_all_pairs(), None);
        blocks.extend(samples.chunks_exact(5000).map(|c| c.mean()));
    }
    let mean = blocks.iter().mean();
    let se = blocks.iter().std_dev() / (blocks.len() as f64).sqrt();
    eprintln!("parallel NPT βP = 3: φ = {mean:.5} ± {se:.5} (Carnahan–Starling {cs})");
    assert!(
        (mean - cs).abs() < 3.0 * se && (mean - cs).abs() < 0.005,
        "φ = {mean} ± {se}"
    );
}
