//! Hard cubes compressed from a dilute, randomly oriented start: at φ = 0.55
//! they order into a simple-cubic arrangement of aligned cubes (the local
//! cubatic order is far above the fluid's); at φ = 0.35 they stay
//! disordered.

use hardbody::analysis::order::local_cubic_order;
use hardbody::analysis::virial::random_rotation;
use hardbody::geometry::Shape;
use hardbody::mc::compress::{CompressOptions, compress};
use hardbody::mc::moves::{Counts, Ensemble, MoveSizes, sweep};
use hardbody::mc::tuning::Tuner;
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, Species, System};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

/// 216 unit cubes compressed to `phi` and equilibrated for `sweeps`;
/// returns the local cubatic order averaged over the last half.
fn cubes_at(phi: f64, sweeps: u64, seed: u64) -> f64 {
    let mut rng = Pcg64::seed_from_u64(seed);
    let n = 6;
    let spacing = 2.0;
    let len = spacing * n as f64;
    let particles = (0..n * n * n)
        .map(|i| Particle {
            position: Vector3::new((i % n) as f64, ((i / n) % n) as f64, (i / (n * n)) as f64)
                * spacing
                - Vector3::repeat(len / 2.0),
            orientation: random_rotation(&mut rng),
            species: 0,
        })
        .collect();
    let species = vec![Species {
        name: "cube".into(),
        shape: "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse::<Shape>().unwrap(),
        rotation: true,
    }];
    let mut system = System::new(
        PeriodicBox::new(Vector3::repeat(len)).unwrap(),
        species,
        particles,
    )
    .unwrap();
    let mut sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.0,
        shear: 0.01,
    };
    let report = compress(&mut system, sizes, &CompressOptions::to(phi), &mut rng).unwrap();
    sizes = report.sizes;
    let tuner = Tuner {
        target: 0.3,
        max_translate: 1.0,
    };
    let mut window = Counts::default();
    let mut orders = Vec::new();
    for s in 1..=sweeps {
        window += sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
        if s % 50 == 0 && s <= sweeps / 2 {
            tuner.update(&mut sizes, &window);
            window = Counts::default();
        }
        if s > sweeps / 2 && s % 100 == 0 {
            let pos: Vec<Vector3<f64>> = system.particles().iter().map(|p| p.position).collect();
            let rot: Vec<_> = system
                .particles()
                .iter()
                .map(|p| p.orientation.to_rotation_matrix().into_inner())
                .collect();
            orders.push(local_cubic_order(system.periodic_box(), &pos, &rot, 1.4).unwrap());
        }
    }
    assert_eq!(system.first_overlap_all_pairs(), None);
    orders.iter().sum::<f64>() / orders.len() as f64
}

#[test]
fn cubes_order_at_0_55_and_not_at_0_35() {
    use rayon::prelude::*;
    let r: Vec<f64> = [(0.55, 1u64), (0.35, 2u64)]
        .par_iter()
        .map(|&(phi, seed)| cubes_at(phi, 10_000, seed))
        .collect();
    let (dense, fluid) = (r[0], r[1]);
    eprintln!("local cubatic order: {dense:.3} at phi = 0.55, {fluid:.3} at phi = 0.35");
    assert!(dense > 0.6, "no simple-cubic order at 0.55: {dense}");
    assert!(fluid < 0.3, "ordered at 0.35: {fluid}");
    assert!(dense > fluid + 0.3);
}
