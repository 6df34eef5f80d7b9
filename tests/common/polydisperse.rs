//! Polydisperse hard spheres: a compressed fluid of drawn sizes, and the
//! Boublik–Mansoori–Carnahan–Starling–Leland pressure it should have.

use std::f64::consts::PI;

use hardbody::mc::compress::{CompressOptions, compress};
use hardbody::mc::moves::MoveSizes;
use hardbody::space::PeriodicBox;
use hardbody::state::sizes::SizeDistribution;
use hardbody::state::start::random_insertion_sized;
use hardbody::state::{Species, System};
use nalgebra::Vector3;
use rand_pcg::Pcg64;

/// Spheres of diameter 1 at size 1, not turning.
pub fn spheres() -> Vec<Species> {
    vec![Species {
        name: "sphere".into(),
        shape: "Sphere(radius: 0.5)".parse().unwrap(),
        rotation: false,
    }]
}

/// `n` spheres (diameter 1 at size 1) of sizes drawn from `distribution`,
/// inserted at random at φ = 0.25 and compressed to `phi` with
/// translations of `step`: the system, the sizes drawn, and the moves.
pub fn compressed_fluid(
    n: usize,
    distribution: SizeDistribution,
    phi: f64,
    step: f64,
    rng: &mut Pcg64,
) -> (System, Vec<f64>, MoveSizes) {
    let sizes = distribution.draw(n, rng).unwrap();
    let mut system = inserted(&sizes, 0.25, rng);
    let moves = MoveSizes {
        translate: step,
        rotate: 0.0,
        volume: 0.0,
        shear: 0.01,
    };
    compress(&mut system, moves, &CompressOptions::to(phi), rng).unwrap();
    (system, sizes, moves)
}

/// Spheres of `sizes` inserted at random at packing fraction `phi` in a
/// cube.
pub fn inserted(sizes: &[f64], phi: f64, rng: &mut Pcg64) -> System {
    let volume: f64 = sizes.iter().map(|f| PI / 6.0 * f.powi(3)).sum();
    let box_ = PeriodicBox::new(Vector3::repeat((volume / phi).cbrt())).unwrap();
    let counts = [sizes.len()];
    random_insertion_sized(
        box_,
        spheres(),
        &counts,
        Some(sizes.to_vec()),
        1_000_000,
        rng,
    )
    .unwrap()
}

/// βP of additive hard spheres of diameters σᵢ at number density ρ by
/// Boublik–Mansoori–Carnahan–Starling–Leland (Mansoori, Carnahan,
/// Starling and Leland, J. Chem. Phys. 54, 1523 (1971); Boublík, J. Chem.
/// Phys. 53, 471 (1970)):
/// with ξₖ = (π/6) ρ ⟨σᵏ⟩,
/// βP = (6/π) [ξ₀/(1 − ξ₃) + 3ξ₁ξ₂/(1 − ξ₃)² + (3 − ξ₃) ξ₂³/(1 − ξ₃)³].
pub fn bmcsl_pressure(rho: f64, diameters: &[f64]) -> f64 {
    let n = diameters.len() as f64;
    let xi = |k: i32| PI / 6.0 * rho * diameters.iter().map(|s| s.powi(k)).sum::<f64>() / n;
    let (x0, x1, x2, x3) = (xi(0), xi(1), xi(2), xi(3));
    let e = 1.0 - x3;
    6.0 / PI * (x0 / e + 3.0 * x1 * x2 / (e * e) + (3.0 - x3) * x2.powi(3) / e.powi(3))
}
