//! Polydisperse hard spheres: a compressed fluid of drawn sizes, and the
//! Boublik–Mansoori–Carnahan–Starling–Leland pressure it should have.

use std::f64::consts::PI;

use hardbody::geometry::{DistanceOptions, Relative, distance, overlap};
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

/// βP of a mixture of hard convex bodies of volumes V, surfaces S and
/// mean radii of curvature R = M/4π at number density ρ, by Boublík's
/// equation (T. Boublík, J. Chem. Phys. 63, 4084 (1975)), with
/// y = ρ⟨V⟩: βP = ρ/(1 − y) + ρ²⟨R⟩⟨S⟩/(1 − y)² plus
/// ρ³⟨R²⟩⟨S⟩²(3 − y)/(9(1 − y)³). For spheres it is BMCSL, for one kind
/// Z = [1 + (3α − 2)y + (3α² − 3α + 1)y² − α²y³]/(1 − y)³ with α = RS/3V.
pub fn boublik_pressure(rho: f64, bodies: &[(f64, f64, f64)]) -> f64 {
    let n = bodies.len() as f64;
    let mean = |f: &dyn Fn(&(f64, f64, f64)) -> f64| bodies.iter().map(f).sum::<f64>() / n;
    let (v, s, r, r2) = (
        mean(&|b| b.0),
        mean(&|b| b.1),
        mean(&|b| b.2),
        mean(&|b| b.2 * b.2),
    );
    let y = rho * v;
    let e = 1.0 - y;
    rho / e + rho * rho * r * s / (e * e) + rho.powi(3) * r2 * s * s * (3.0 - y) / (9.0 * e.powi(3))
}

/// The first pair of `system` (with sizes) that overlaps at the bodies'
/// own sizes, by the pair kernel on every pair of shapes scaled here,
/// deeper than `depth` times the smaller body's smallest half-extent (a
/// state of the dynamics: the pair of a collision just made touches to
/// round-off either way).
pub fn overlapping_pair(system: &System, depth: f64) -> Option<(usize, usize)> {
    let sizes = system.sizes().unwrap();
    let p = system.particles();
    let shape = |i: usize| {
        system.species()[p[i].species as usize]
            .shape
            .scaled(sizes[i])
    };
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = system
                .periodic_box()
                .minimum_image(&(p[j].position - p[i].position));
            let rel = Relative::new(&d, &p[i].orientation, &p[j].orientation);
            let (a, b) = (shape(i), shape(j));
            if overlap(&a, &b, &rel) {
                let overlap_depth =
                    -distance(&a, &b, &rel, &DistanceOptions::default(), None).distance;
                if overlap_depth > depth * a.min_half_extent().min(b.min_half_extent()) {
                    return Some((i, j));
                }
            }
        }
    }
    None
}
