//! The neighbour structures the plan picks (range-wide cells, AABB cells)
//! never miss an overlap: trial placements in dense systems of spheres,
//! needles, plates and a 1:10 cuboid–sphere mixture agree with a test of
//! every other particle.

use hardbody::analysis::virial::random_rotation;
use hardbody::bench::mc::dense_start;
use hardbody::geometry::{Relative, Shape, overlap};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::mc::{Particle, Species, System};
use hardbody::space::PeriodicBox;
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
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut system = system.clone();
    let sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.0,
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
fn aabb_cells_for_a_one_to_ten_mixture() {
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
    check(&system, true, 6);
}
