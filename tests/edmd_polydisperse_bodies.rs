//! Polydisperse bodies that turn, in the event-driven dynamics and in
//! jamming by growth: bodies all at one size f are the species' shape
//! scaled by f (the same collisions to the bit); ellipsoids, cuboids,
//! tetrahedra and a mixture with spheres of drawn sizes keep energy and
//! momentum and stay apart at each body's own size by brute force; sizes
//! lower the collision-virial pressure of spherocylinders by the factor
//! Boublík's equation for mixtures gives; and polydisperse cubes grow
//! into an overlap-free packing.

mod common;

use common::polydisperse::{boublik_pressure, overlapping_pair};
use hardbody::edmd::jam::{JamEnd, JamOptions, jam};
use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::geometry::Shape;
use hardbody::mc::compress::{CompressOptions, compress};
use hardbody::mc::moves::MoveSizes;
use hardbody::space::PeriodicBox;
use hardbody::state::sizes::SizeDistribution;
use hardbody::state::start::random_insertion_sized;
use hardbody::state::{Species, System};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use statrs::statistics::Statistics;

const MOVES: MoveSizes = MoveSizes {
    translate: 0.08,
    rotate: 0.1,
    volume: 0.0,
    shear: 0.0,
};

fn species_of(shapes: &[&str]) -> Vec<Species> {
    shapes
        .iter()
        .enumerate()
        .map(|(k, text)| {
            let shape: Shape = text.parse().unwrap();
            Species {
                name: format!("s{k}"),
                rotation: !shape.is_sphere(),
                shape,
            }
        })
        .collect()
}

/// `counts` bodies of `shapes` at sizes drawn uniform in [0.7, 1.3]
/// (at size 1 for `sized_fluid`'s `base`), inserted at φ = 0.15 and
/// compressed by Monte Carlo to `phi`.
fn sized_fluid(shapes: &[&str], counts: &[usize], phi: f64, seed: u64) -> System {
    fluid(shapes, counts, phi, seed, true)
}

fn fluid(shapes: &[&str], counts: &[usize], phi: f64, seed: u64, sized: bool) -> System {
    let species = species_of(shapes);
    let mut rng = Pcg64::seed_from_u64(seed);
    let n: usize = counts.iter().sum();
    let sizes = if sized {
        SizeDistribution::Uniform { min: 0.7, max: 1.3 }
            .draw(n, &mut rng)
            .unwrap()
    } else {
        vec![1.0; n]
    };
    let of = counts
        .iter()
        .enumerate()
        .flat_map(|(k, &c)| std::iter::repeat_n(k, c));
    let volume: f64 = of
        .zip(&sizes)
        .map(|(k, f)| species[k].shape.volume() * f.powi(3))
        .sum();
    let box_ = PeriodicBox::new(Vector3::repeat((volume / 0.15).cbrt())).unwrap();
    let mut system = random_insertion_sized(
        box_,
        species,
        counts,
        sized.then_some(sizes),
        1_000_000,
        &mut rng,
    )
    .unwrap();
    compress(&mut system, MOVES, &CompressOptions::to(phi), &mut rng).unwrap();
    system
}

/// Ellipsoids (with their own inertia), cuboids and tetrahedra all at
/// size 1.25, and the same bodies of the species' shape scaled by 1.25:
/// the same 3 000 collisions at the same times to the bit, and the same
/// end state.
#[test]
fn bodies_all_at_one_size_are_the_shape_scaled() {
    for (text, true_inertia) in [
        ("Ellipsoid(a: 0.8, b: 0.5, c: 0.4)", true),
        ("Cuboid(a: 0.5, b: 0.4, c: 0.3)", false),
        (
            "ConvexPolyhedron(vertices: [(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0)])",
            false,
        ),
    ] {
        let shape: Shape = text.parse().unwrap();
        // A fluid of the shape at size 1, the whole of it then scaled by
        // 1.25.
        let base = fluid(&[text], &[125], 0.4, 7, false);
        let n = base.len();
        let box_ = PeriodicBox::new(base.periodic_box().lengths() * 1.25).unwrap();
        let particles: Vec<_> = (base.particles().iter())
            .map(|p| hardbody::state::Particle {
                position: p.position * 1.25,
                ..*p
            })
            .collect();
        let big = species_of(&[text])
            .into_iter()
            .map(|s| Species {
                shape: shape.scaled(1.25),
                ..s
            })
            .collect();
        let scaled = System::new(box_, big, particles.clone()).unwrap();
        let sized =
            System::with_sizes(box_, species_of(&[text]), particles, vec![1.25; n]).unwrap();
        let options = DynamicsOptions {
            neighbour_shell: Some(0.1),
            true_inertia,
            ..DynamicsOptions::default()
        };
        let mut rng = Pcg64::seed_from_u64(5);
        let velocities = Dynamics::from_state(&scaled, &options, &mut rng)
            .unwrap()
            .velocities();
        let trace = |system: &System| {
            let mut md = Dynamics::from_parts(system, &velocities, &options, 0.0, 0).unwrap();
            md.record_collisions(true);
            md.run_collisions(3_000).unwrap();
            (
                md.take_collisions(),
                md.to_system().unwrap().particles().to_vec(),
            )
        };
        let ((a, end_a), (b, end_b)) = (trace(&scaled), trace(&sized));
        assert_eq!(a.len(), 3_000, "{text}");
        let same = a
            .iter()
            .zip(&b)
            .take_while(|(x, y)| x.0.to_bits() == y.0.to_bits() && (x.1, x.2) == (y.1, y.2))
            .count();
        assert_eq!(same, a.len(), "{text}: parted after {same} collisions");
        assert_eq!(end_a, end_b, "{text}");
    }
}

/// Ellipsoids, cuboids, tetrahedra, and cuboids with spheres, each body
/// at its own size drawn uniform in [0.7, 1.3], at φ = 0.42 with lists
/// and at 0.3 with cells: kinetic energy and momentum kept to round-off
/// over 20 000 collisions, and every state handed on free of overlap at
/// each body's size by brute force (the sizes kept).
#[test]
fn polydisperse_bodies_conserve_and_stay_apart() {
    let tetrahedron = "ConvexPolyhedron(vertices: [(0.5, 0.5, 0.5), (0.5, -0.5, -0.5), (-0.5, 0.5, -0.5), (-0.5, -0.5, 0.5)])";
    for (shapes, counts, phi, shell) in [
        (
            &["Ellipsoid(a: 0.8, b: 0.5, c: 0.4)"][..],
            &[216][..],
            0.42,
            Some(0.05),
        ),
        (
            &["Cuboid(a: 0.5, b: 0.4, c: 0.3)"][..],
            &[216][..],
            0.3,
            None,
        ),
        (&[tetrahedron][..], &[125][..], 0.42, Some(0.05)),
        (
            &["Cuboid(a: 0.5, b: 0.5, c: 0.5)", "Sphere(radius: 0.4)"][..],
            &[100, 100][..],
            0.42,
            Some(0.05),
        ),
    ] {
        let system = sized_fluid(shapes, counts, phi, 11);
        let sizes = system.sizes().unwrap().to_vec();
        let options = DynamicsOptions {
            neighbour_shell: shell,
            ..DynamicsOptions::default()
        };
        let mut rng = Pcg64::seed_from_u64(13);
        let mut md = Dynamics::from_state(&system, &options, &mut rng).unwrap();
        let energy = md.kinetic_energy();
        for _ in 0..4 {
            if let Err(e) = md.run_collisions(5_000) {
                panic!("{shapes:?}: {e}");
            }
            let now = md.to_system().unwrap();
            assert_eq!(now.sizes(), Some(&sizes[..]));
            assert_eq!(
                overlapping_pair(&now, 1e-9),
                None,
                "{shapes:?} at {}",
                md.time()
            );
        }
        let drift = (md.kinetic_energy() - energy).abs() / energy;
        assert!(drift < 1e-10, "{shapes:?}: energy drift {drift:e}");
        assert!(md.momentum().norm() < 1e-9, "{shapes:?}: {}", md.momentum());
    }
}

/// βP from the collision virial of `system` with true inertia: 24 blocks
/// of t = 2 after t = 4, the mean and its error.
fn virial_pressure(system: &System, seed: u64) -> (f64, f64) {
    let options = DynamicsOptions {
        true_inertia: true,
        ..DynamicsOptions::default()
    };
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut md = Dynamics::from_state(system, &options, &mut rng).unwrap();
    md.run_until(4.0).unwrap();
    md.sample();
    let mut blocks = Vec::new();
    for k in 1..=24 {
        md.run_until(4.0 + 2.0 * k as f64).unwrap();
        blocks.push(md.sample().pressure.unwrap());
    }
    (
        blocks.iter().mean(),
        blocks.iter().std_dev() / (blocks.len() as f64).sqrt(),
    )
}

/// 216 spherocylinders of length 1 and diameter 1 at sizes uniform in
/// [0.7, 1.3], with their own inertia, in their isotropic fluid at
/// φ = 0.3, against rods of one size with the same mean volume at the
/// same φ: the sizes lower the collision virial's βP by the factor
/// Boublík's equation of state for mixtures gives (0.957 for the sizes
/// drawn), within 1 % and three errors, and by more than five errors.
/// The ratio is compared, not each pressure: the equation itself reads
/// about 2 % above the dynamics and Monte Carlo for one size of these
/// rods at this φ.
#[test]
fn polydisperse_rods_lower_the_pressure_as_boublik_says() {
    let rod = "Spherocylinder(radius: 0.5, length: 1.0)";
    let system = sized_fluid(&[rod], &[216], 0.3, 17);
    let rods = |factors: &[f64]| -> Vec<(f64, f64, f64)> {
        factors
            .iter()
            .map(|f| {
                let (r, l) = (0.5 * f, 1.0 * f);
                (
                    std::f64::consts::PI * (r * r * l + 4.0 / 3.0 * r.powi(3)),
                    2.0 * std::f64::consts::PI * (r * l + 2.0 * r * r),
                    l / 4.0 + r,
                )
            })
            .collect()
    };
    let sizes = system.sizes().unwrap();
    let sized = rods(sizes);
    let rho = system.len() as f64 / system.periodic_box().volume();
    let expected = boublik_pressure(rho, &sized);
    let (p, e) = virial_pressure(&system, 19);
    let equal = common_size_fluid(rod, &system);
    let mean_size = sizes.iter().map(|f| f.powi(3)).mean().cbrt();
    let expected_equal = boublik_pressure(rho, &rods(&[mean_size]));
    let (p_equal, e_equal) = virial_pressure(&equal, 19);
    eprintln!(
        "polydisperse rods: betaP {p:.4} ± {e:.4}, Boublik {expected:.4}; one size {p_equal:.4} ± {e_equal:.4}, Boublik {expected_equal:.4}"
    );
    let (ratio, expected_ratio) = (p / p_equal, expected / expected_equal);
    let ratio_error = ratio * ((e / p).powi(2) + (e_equal / p_equal).powi(2)).sqrt();
    eprintln!("ratio {ratio:.4} ± {ratio_error:.4}, Boublik {expected_ratio:.4}");
    assert!(ratio_error < 0.01, "error {ratio_error} too large to judge");
    assert!(
        (ratio - expected_ratio).abs() < (3.0 * ratio_error).min(0.01),
        "sized over one size: {ratio} ± {ratio_error}, Boublik {expected_ratio}"
    );
    assert!(
        p_equal - p > 5.0 * (e * e + e_equal * e_equal).sqrt(),
        "one size {p_equal} ± {e_equal} not told apart from {p} ± {e}"
    );
}

/// Rods of one size with the mean volume of `system`'s, at its number
/// density: inserted and compressed to its φ.
fn common_size_fluid(rod: &str, system: &System) -> System {
    let shape: Shape = rod.parse().unwrap();
    let mean_cube = system.sizes().unwrap().iter().map(|f| f.powi(3)).mean();
    let species = vec![Species {
        name: "rod".into(),
        shape: shape.scaled(mean_cube.cbrt()),
        rotation: true,
    }];
    let mut rng = Pcg64::seed_from_u64(31);
    let n = system.len();
    let lengths = system.periodic_box().lengths() * (system.packing_fraction() / 0.15).cbrt();
    let mut state = random_insertion_sized(
        PeriodicBox::new(lengths).unwrap(),
        species,
        &[n],
        None,
        1_000_000,
        &mut rng,
    )
    .unwrap();
    compress(
        &mut state,
        MOVES,
        &CompressOptions::to(system.packing_fraction()),
        &mut rng,
    )
    .unwrap();
    state
}

/// 64 cubes at sizes uniform in [0.7, 1.3], grown from φ = 0.2 (at the
/// rate and to the pressure of the jam tests of bodies of one size):
/// jammed, the sizes kept, and free of overlap at each body's size by
/// brute force and by the contact network's exact distances.
#[test]
fn polydisperse_cubes_grow_into_an_overlap_free_packing() {
    let system = fluid(&["Cuboid(a: 0.5, b: 0.5, c: 0.5)"], &[64], 0.2, 37, true);
    let sizes = system.sizes().unwrap().to_vec();
    let mut rng = Pcg64::seed_from_u64(41);
    let options = JamOptions {
        growth_rate: 1e-2,
        pressure: 1e5,
        ..JamOptions::default()
    };
    let out = jam(
        &system,
        &options,
        &DynamicsOptions::default(),
        &mut rng,
        |_| true,
    )
    .unwrap();
    assert_eq!(out.end, JamEnd::Jammed, "{:?}", out.last_failure);
    assert!(out.last.unwrap().pressure >= 1e5);
    assert_eq!(out.system.sizes(), Some(&sizes[..]));
    assert_eq!(overlapping_pair(&out.system, 1e-9), None);
    let net = out.system.contact_network(1e-12);
    eprintln!(
        "polydisperse cubes: phi {:.4}, z {:.3}, {} rattlers",
        net.packing_fraction,
        net.backbone_contact_number,
        net.rattlers.len()
    );
    assert_eq!(net.overlaps, 0);
    assert!(net.packing_fraction > 0.5, "{}", net.packing_fraction);
}
