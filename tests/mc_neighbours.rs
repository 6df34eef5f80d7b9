//! The neighbour structures the plan picks (range-wide cells, AABB cells)
//! never miss an overlap: trial placements in dense systems of spheres,
//! needles, plates and a 1:10 cuboid–sphere mixture agree with a test of
//! every other particle.

use hardbody::analysis::virial::random_rotation;
use hardbody::bench::mc::dense_start;
use hardbody::geometry::{Relative, Shape, overlap};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, Species, System};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn brute_force(
    system: &System,
    i: usize,
    position: &Vector3<f64>,
    q: &nalgebra::UnitQuaternion<f64>,
) -> bool {
    let pi = &system.particles()[i];
    let si = &system.species()[pi.species as usize].shape;
    system.particles().iter().enumerate().any(|(j, pj)| {
        if j == i {
            return false;
        }
        let d = system
            .periodic_box()
            .minimum_image(&(pj.position - position));
        overlap(
            si,
            &system.species()[pj.species as usize].shape,
            &Relative::new(&d, q, &pj.orientation),
        )
    })
}

/// Melts the start with a few sweeps (exercising the cell updates), then
/// compares random trial placements.
fn check(system: &System, expect_aabb: bool, seed: u64) {
    assert_eq!(system.uses_aabb_cells(), expect_aabb);
    check_placements(system, seed);
}

fn check_placements(system: &System, seed: u64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut system = system.clone();
    let sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.0,
        shear: 0.01,
    };
    for _ in 0..30 {
        sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
    }
    let system = &system;
    let l = system.periodic_box().lengths();
    let mut hits = 0;
    for _ in 0..4000 {
        let i = rng.gen_range(0..system.len());
        let p = Vector3::new(
            rng.r#gen::<f64>() - 0.5,
            rng.r#gen::<f64>() - 0.5,
            rng.r#gen::<f64>() - 0.5,
        )
        .component_mul(&l);
        let q = random_rotation(&mut rng);
        let fast = system.overlaps_at(i, &p, &q.to_rotation_matrix().into_inner());
        assert_eq!(
            fast,
            brute_force(system, i, &p, &q),
            "trial of particle {i} at {p:?}"
        );
        hits += fast as usize;
    }
    assert!(
        hits > 100 && hits < 3990,
        "{hits} overlaps in 4000 trials: not a discriminating test"
    );
}

#[test]
fn stencil_cells_for_spheres() {
    let s: Shape = "Sphere(radius: 0.5)".parse().unwrap();
    check(&dense_start(&s, 500, 0.2).unwrap(), false, 1);
}

/// Dense spheres: the plan gives them Verlet lists once the box has
/// stayed put a while, which answer trial moves near each sphere's
/// reference (the cells answer the rest): after sweeps that relist many
/// spheres, small trial displacements (the lists' regime) agree with a
/// test of every other particle.
#[test]
fn verlet_lists_for_dense_spheres() {
    let s: Shape = "Sphere(radius: 0.5)".parse().unwrap();
    let mut system = dense_start(&s, 500, 0.5).unwrap();
    assert_eq!(system.plan().sphere_skin, Some(0.5));
    let mut rng = Pcg64::seed_from_u64(9);
    let sizes = MoveSizes {
        translate: 0.15,
        rotate: 0.0,
        volume: 0.0,
        shear: 0.01,
    };
    assert!(!system.uses_sphere_lists(), "lists before any move");
    for _ in 0..200 {
        sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
    }
    assert!(system.uses_sphere_lists(), "no lists after 200 NVT sweeps");
    let identity = nalgebra::UnitQuaternion::identity();
    let mut hits = 0;
    for _ in 0..4000 {
        let i = rng.gen_range(0..system.len());
        let step = Vector3::from_fn(|_, _| rng.gen_range(-0.12..0.12));
        let p = system.particles()[i].position + step;
        let fast = system.overlaps_at(i, &p, &identity.to_rotation_matrix().into_inner());
        assert_eq!(
            fast,
            brute_force(&system, i, &p, &identity),
            "trial of {i} at {p:?}"
        );
        hits += fast as usize;
    }
    assert!(
        hits > 100 && hits < 3990,
        "{hits} overlaps in 4000 trials: not a discriminating test"
    );
}

#[test]
fn aabb_cells_for_needles_and_plates() {
    for (k, text) in [
        "Ellipsoid(a: 0.5, b: 0.5, c: 2.5)",
        "Cuboid(a: 1.0, b: 1.0, c: 0.2)",
    ]
    .iter()
    .enumerate()
    {
        let s: Shape = text.parse().unwrap();
        check(&dense_start(&s, 1400, 0.15).unwrap(), true, 2 + k as u64);
    }
}

#[test]
fn per_species_cells_for_a_one_to_ten_mixture() {
    // Large cubes (edge 4) on a lattice with small spheres (diameter 0.4)
    // filling the gaps: a 1:10 size ratio.
    let species = vec![
        Species {
            name: "cube".into(),
            shape: "Cuboid(a: 2.0, b: 2.0, c: 2.0)".parse().unwrap(),
            rotation: true,
        },
        Species {
            name: "sphere".into(),
            shape: "Sphere(radius: 0.2)".parse().unwrap(),
            rotation: false,
        },
    ];
    let mut rng = Pcg64::seed_from_u64(5);
    let (n, spacing) = (4usize, 9.0);
    let len = n as f64 * spacing;
    let mut particles = Vec::new();
    for c in 0..n * n * n {
        let centre = Vector3::new((c % n) as f64, ((c / n) % n) as f64, (c / (n * n)) as f64)
            * spacing
            - Vector3::repeat(len / 2.0 - 0.5);
        particles.push(Particle {
            position: centre,
            orientation: random_rotation(&mut rng),
            species: 0,
        });
        // Spheres on a shell around each cube, outside its bounding sphere.
        for k in 0..40 {
            let dir = random_rotation(&mut rng) * Vector3::x();
            particles.push(Particle {
                position: centre + dir * (3.67 + 0.45 * (k % 2) as f64),
                orientation: nalgebra::UnitQuaternion::identity(),
                species: 1,
            });
        }
    }
    // Drop spheres that overlap each other.
    let mut kept: Vec<Particle> = Vec::new();
    for p in particles {
        if p.species == 1
            && kept
                .iter()
                .any(|q| q.species == 1 && (q.position - p.position).norm() < 0.4)
        {
            continue;
        }
        kept.push(p);
    }
    let system = System::new(
        PeriodicBox::new(Vector3::repeat(len)).unwrap(),
        species,
        kept,
    )
    .unwrap();
    assert!(system.uses_per_species_cells());
    check_placements(&system, 6);
}

/// A dense 1:10 mixture (big cubes of edge 4 at φ ≈ 0.2 among small
/// spheres of diameter 0.4 at φ ≈ 0.25): with one grid per species a small
/// sphere's trial move looks at a few dozen candidates, where cells sized
/// for the cubes would hand it hundreds of small spheres; and no overlap is
/// missed (trial placements against all pairs).
#[test]
fn per_species_cells_keep_a_dense_one_to_ten_mixture_cheap() {
    let species = vec![
        Species {
            name: "cube".into(),
            shape: "Cuboid(a: 2.0, b: 2.0, c: 2.0)".parse().unwrap(),
            rotation: true,
        },
        Species {
            name: "sphere".into(),
            shape: "Sphere(radius: 0.2)".parse().unwrap(),
            rotation: false,
        },
    ];
    let (n, spacing) = (3usize, 8.0);
    let len = n as f64 * spacing;
    let mut particles = Vec::new();
    for c in 0..n * n * n {
        particles.push(Particle {
            position: Vector3::new((c % n) as f64, ((c / n) % n) as f64, (c / (n * n)) as f64)
                * spacing
                - Vector3::repeat(len / 2.0 - 0.1),
            orientation: nalgebra::UnitQuaternion::identity(),
            species: 0,
        });
    }
    // Small spheres on a simple cubic lattice of spacing 0.45, outside the
    // cubes (edge 4, so |x| > 2.2 from a cube centre along some axis).
    let m = (len / 0.45) as usize;
    for c in 0..m * m * m {
        let r = Vector3::new((c % m) as f64, ((c / m) % m) as f64, (c / (m * m)) as f64) * 0.45
            - Vector3::repeat(len / 2.0 - 0.2);
        let clear = particles.iter().filter(|p| p.species == 0).all(|p| {
            let d = PeriodicBox::new(Vector3::repeat(len))
                .unwrap()
                .minimum_image(&(r - p.position));
            d.iter().any(|x| x.abs() > 2.25)
        });
        if clear {
            particles.push(Particle {
                position: r,
                orientation: nalgebra::UnitQuaternion::identity(),
                species: 1,
            });
        }
    }
    let system = System::new(
        PeriodicBox::new(Vector3::repeat(len)).unwrap(),
        species,
        particles,
    )
    .unwrap();
    assert!(system.uses_per_species_cells());
    assert!(system.len() > 100_000, "{} particles", system.len());
    let small: Vec<usize> = (0..system.len())
        .filter(|&i| system.particles()[i].species == 1)
        .step_by(997)
        .collect();
    let mean = small
        .iter()
        .map(|&i| system.candidates_of(i))
        .sum::<usize>() as f64
        / small.len() as f64;
    // A small sphere's own grid: 27 cells of width 0.4 (~0.5 spheres each
    // here); the cube grid: 27 cells of width 6.9 (~1 cube each).
    assert!(mean < 60.0, "{mean} candidates per small-sphere move");
    // Trial moves as Monte Carlo makes them (small displacements and
    // turns), against all pairs: some overlap, some do not.
    let mut rng = Pcg64::seed_from_u64(7);
    let (mut hits, trials) = (0, 1500);
    for _ in 0..trials {
        let i = rng.gen_range(0..system.len());
        let p = &system.particles()[i];
        let step = Vector3::new(
            rng.r#gen::<f64>() - 0.5,
            rng.r#gen::<f64>() - 0.5,
            rng.r#gen::<f64>() - 0.5,
        ) * 0.15;
        let position = system.periodic_box().wrap(&(p.position + step));
        let q = nalgebra::UnitQuaternion::from_scaled_axis(step) * p.orientation;
        let expected = brute_force(&system, i, &position, &q);
        let got = system.overlaps_at(i, &position, &q.to_rotation_matrix().into_inner());
        assert_eq!(got, expected, "particle {i} at {position:?}");
        hits += expected as usize;
    }
    assert!(
        hits > trials / 20 && hits < trials - trials / 20,
        "{hits} of {trials} overlap"
    );
}
