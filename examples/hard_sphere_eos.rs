//! The hard-sphere equation of state with the Monte Carlo library: NPT at
//! a few pressures, the mean packing fraction against Carnahan–Starling.
//!
//! `cargo run --release --example hard_sphere_eos` (about 30 s)

use hardbody::mc::moves::{Counts, Ensemble, MoveSizes, sweep};
use hardbody::mc::tuning::Tuner;
use hardbody::space::PeriodicBox;
use hardbody::state::Species;
use hardbody::state::start::lattice;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

/// βPσ³ of Carnahan–Starling at packing fraction φ (σ = 1).
fn carnahan_starling(phi: f64) -> f64 {
    6.0 * phi / std::f64::consts::PI * (1.0 + phi + phi * phi - phi.powi(3)) / (1.0 - phi).powi(3)
}

fn main() {
    let sphere = Species {
        name: "sphere".into(),
        shape: "Sphere(radius: 0.5)".parse().expect("a valid shape"),
        rotation: false,
    };
    let mut rng = Pcg64::seed_from_u64(1);
    let start = PeriodicBox::new(Vector3::repeat(10.0)).expect("a valid box");
    let mut system = lattice(start, vec![sphere], &[256], &mut rng).expect("room for 256");
    let mut sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.0,
        volume: 0.01,
        shear: 0.01,
    };
    println!("| betaP sigma^3 | phi (MC) | phi (Carnahan-Starling) |");
    println!("|---|---|---|");
    for pressure in [1.0, 3.0, 6.0] {
        let ensemble = Ensemble::Npt {
            pressure,
            moves: hardbody::mc::box_moves::BoxMoves::Isotropic,
        };
        let tuner = Tuner {
            target: 0.3,
            max_translate: 2.0,
        };
        // Equilibrate with tuning, then sample with the sizes frozen.
        tuner.equilibrate(&mut system, &mut sizes, &ensemble, 6000, 50, &mut rng);
        let (mut sum, mut samples) = (0.0, 0);
        let mut counts = Counts::default();
        for s in 0..20000 {
            counts += sweep(&mut system, &sizes, &ensemble, &mut rng);
            if s % 10 == 0 {
                sum += system.packing_fraction();
                samples += 1;
            }
        }
        let phi = sum / samples as f64;
        // Invert Carnahan–Starling by bisection for the reference φ.
        let (mut lo, mut hi) = (0.0, 0.7);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if carnahan_starling(mid) < pressure {
                lo = mid
            } else {
                hi = mid
            }
        }
        println!("| {pressure} | {phi:.4} | {lo:.4} |");
    }
}
