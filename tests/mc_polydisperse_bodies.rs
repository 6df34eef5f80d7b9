//! Polydisperse bodies that turn, in Monte Carlo: bodies all at one size f
//! are the species' shape scaled by f (one Markov chain, to the bit); a
//! fluid of ellipsoids and cuboids of drawn sizes, moved and size-swapped,
//! stays free of overlap at each body's size by brute force; and the
//! pressure of polydisperse spherocylinders follows Boublík's equation
//! of state for mixtures of hard convex bodies.

mod common;

use common::polydisperse::{boublik_pressure, overlapping_pair};

use std::f64::consts::PI;

use hardbody::geometry::Shape;
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep, sweep_with_swaps};
use hardbody::mc::sdf::Sdf;
use hardbody::scene::Scene;
use hardbody::state::sizes::SizeDistribution;
use hardbody::state::{Species, System};
use rand::SeedableRng;
use rand_pcg::Pcg64;

const MOVES: MoveSizes = MoveSizes {
    translate: 0.08,
    rotate: 0.1,
    volume: 0.0,
    shear: 0.0,
};

fn species(shape: Shape) -> Vec<Species> {
    vec![Species {
        name: "body".into(),
        shape,
        rotation: true,
    }]
}

/// Ellipsoids all at size 1.25 run the chain of the ellipsoid scaled by
/// 1.25: the same moves accepted, the same end state and the same
/// scale-distribution pressure, to the bit.
#[test]
fn bodies_all_at_one_size_are_the_shape_scaled() {
    let shape: Shape = "Ellipsoid(a: 0.8, b: 0.5, c: 0.4)".parse().unwrap();
    let big = shape.scaled(1.25);
    let start = common::compressed_state(&["Ellipsoid(a: 1.0, b: 0.625, c: 0.5)"], 5, 0.4, 3);
    assert_eq!(start.species()[0].shape, big);
    let particles = start.particles().to_vec();
    let n = particles.len();
    let mut scaled = System::new(*start.periodic_box(), species(big), particles.clone()).unwrap();
    let mut sized = System::with_sizes(
        *start.periodic_box(),
        species(shape),
        particles,
        vec![1.25; n],
    )
    .unwrap();
    let (mut ra, mut rb) = (Pcg64::seed_from_u64(1), Pcg64::seed_from_u64(1));
    let (mut sdf_a, mut sdf_b) = (Sdf::new(0.02, 40), Sdf::new(0.02, 40));
    let mut accepted = 0;
    for _ in 0..200 {
        let a = sweep(&mut scaled, &MOVES, &Ensemble::Nvt, &mut ra);
        let b = sweep(&mut sized, &MOVES, &Ensemble::Nvt, &mut rb);
        assert_eq!(a.translate, b.translate);
        assert_eq!(a.rotate, b.rotate);
        accepted += a.translate.accepted;
        sdf_a.add(&scaled);
        sdf_b.add(&sized);
    }
    assert!(accepted > 1000, "{accepted}");
    assert_eq!(scaled.particles(), sized.particles());
    let (pa, pb) = (sdf_a.pressure().unwrap(), sdf_b.pressure().unwrap());
    assert_eq!(pa.to_bits(), pb.to_bits(), "{pa} {pb}");
    assert_eq!(sized.shape_of(0), big);
}

/// Ellipsoids and cuboids of sizes uniform in [0.7, 1.3], compressed to
/// φ = 0.42 and moved with size swaps (NVT, then NPT): every state is
/// overlap-free at each body's own size by brute force, swaps are taken
/// and refused, the sizes stay the drawn set, and small bodies come
/// closer than the largest would let them.
#[test]
fn polydisperse_bodies_stay_apart_at_their_own_sizes() {
    for text in [
        "Ellipsoid(a: 0.8, b: 0.5, c: 0.4)",
        "Cuboid(a: 0.5, b: 0.4, c: 0.3)",
    ] {
        let shape: Shape = text.parse().unwrap();
        let mut rng = Pcg64::seed_from_u64(21);
        let n = 216;
        let mut drawn = SizeDistribution::Uniform { min: 0.7, max: 1.3 }
            .draw(n, &mut rng)
            .unwrap();
        let volume: f64 = drawn.iter().map(|f| shape.volume() * f.powi(3)).sum();
        let box_ =
            hardbody::space::PeriodicBox::new(nalgebra::Vector3::repeat((volume / 0.15).cbrt()))
                .unwrap();
        let mut system = hardbody::state::start::random_insertion_sized(
            box_,
            species(shape),
            &[n],
            Some(drawn.clone()),
            1_000_000,
            &mut rng,
        )
        .unwrap();
        hardbody::mc::compress::compress(
            &mut system,
            MOVES,
            &hardbody::mc::compress::CompressOptions::to(0.42),
            &mut rng,
        )
        .unwrap();
        assert!((system.packing_fraction() - 0.42).abs() < 1e-9);
        let (mut tried, mut taken) = (0, 0);
        let npt = Ensemble::Npt {
            pressure: 4.0,
            moves: hardbody::mc::box_moves::BoxMoves::Isotropic,
        };
        for (round, ensemble) in [Ensemble::Nvt, npt].iter().enumerate() {
            let moves = MoveSizes {
                volume: 0.002,
                ..MOVES
            };
            for _ in 0..60 {
                let swap = sweep_with_swaps(&mut system, &moves, ensemble, 1.0, &mut rng).swap;
                (tried, taken) = (tried + swap.tried, taken + swap.accepted);
            }
            assert_eq!(
                overlapping_pair(&system, 0.0),
                None,
                "{text}, round {round}"
            );
            assert_eq!(system.first_overlap_all_pairs(), None);
        }
        assert!(
            taken > 100 && taken < tried,
            "{text}: {taken} of {tried} swaps"
        );
        let mut now = system.sizes().unwrap().to_vec();
        now.sort_by(f64::total_cmp);
        drawn.sort_by(f64::total_cmp);
        assert_eq!(now, drawn);
    }
}

#[test]
fn boublik_of_spheres_is_carnahan_starling() {
    let (rho, sigma) = (0.7, 1.0);
    let sphere = (PI / 6.0, PI, 0.5);
    let y = rho * PI / 6.0 * sigma;
    let cs = rho * (1.0 + y + y * y - y.powi(3)) / (1.0 - y).powi(3);
    assert!((boublik_pressure(rho, &[sphere; 3]) - cs).abs() < 1e-12 * cs);
}

/// Spherocylinders of length 1 and diameter 1 at Gaussian sizes (std
/// 0.25) in their isotropic fluid at φ = 0.3: the scale-distribution
/// pressure is Boublík's within three errors and 3 %, and so is that of
/// equal rods run alike (how near the equation comes for one size); the
/// sizes move Boublík's pressure by far more than that, so a run that
/// ignored them would fail.
#[test]
fn polydisperse_spherocylinders_follow_boublik() {
    let phi: f64 = 0.3;
    let measure = |sizes: &str, seed: u64| {
        let scene_of = |replica: u64| {
            format!(
                r#"Scene(
    seed: {},
    box: (16.0, 16.0, 16.0),
    species: [Species(name: "rod", shape: Spherocylinder(radius: 0.5, length: 1.0), count: 216{sizes})],
    stages: [Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: 1000), MonteCarlo(ensemble: Nvt, sweeps: 10000)],
    log: Log(path: "unused.mcap", stats_every: 20, frames_every: 1000000),
)"#,
                seed + replica
            )
        };
        let [(p, e, ok)] = common::replica_averages("rods", scene_of, &[(2, "pressure")])[..]
        else {
            unreachable!()
        };
        assert!(ok, "not equilibrated");
        let scene = Scene::parse(&scene_of(0)).unwrap();
        let factors = scene.body_sizes().unwrap_or_else(|| vec![1.0; 216]);
        let bodies: Vec<(f64, f64, f64)> = factors
            .iter()
            .map(|f| {
                let (r, l) = (0.5 * f, 1.0 * f);
                (
                    PI * r * r * l + 4.0 / 3.0 * PI * r.powi(3),
                    2.0 * PI * r * l + 4.0 * PI * r * r,
                    l / 4.0 + r,
                )
            })
            .collect();
        let rho = phi * bodies.len() as f64 / bodies.iter().map(|b| b.0).sum::<f64>();
        let expected = boublik_pressure(rho, &bodies);
        assert!(
            (p - expected).abs() < 3.0 * e + 0.03 * expected,
            "sizes {sizes:?}: betaP {p} ± {e}, Boublik {expected}"
        );
        eprintln!("spherocylinders{sizes}: betaP {p:.4} ± {e:.4}, Boublik {expected:.4}");
        (p, expected)
    };
    let (p_equal, b_equal) = measure("", 40);
    let (p_sized, b_sized) = measure(", sizes: Gaussian(std: 0.25)", 50);
    // The sizes move the pressure as Boublík says they do, by more than
    // the tolerance: the equal rods' pressure would fail the sized test.
    assert!(
        (p_equal - b_sized).abs() > 0.1 * b_sized,
        "equal {p_equal} ({b_equal}), sized {p_sized} ({b_sized})"
    );
}
