//! Observables of the dynamics against exact free motion: bodies so small
//! that they never meet in the run fly and turn freely, across the periodic
//! boundaries many times, so the mean-squared displacement must be
//! ⟨|v|² t²⟩ and C₂(t) the mean of P₂(u(0)·R(ωt) u(0)), body by body.

use hardbody::analysis::order::{legendre_p2, molecular_axis};
use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::geometry::Shape;
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, Species, System};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn tiny_gas(shape: &str, seed: u64) -> System {
    let mut rng = Pcg64::seed_from_u64(seed);
    let len = 5.0;
    let particles = (0..64)
        .map(|i| Particle {
            position: Vector3::new((i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64) * 1.25
                - Vector3::repeat(2.5),
            orientation: UnitQuaternion::from_scaled_axis(Vector3::new(
                rng.r#gen::<f64>() * 3.0,
                rng.r#gen::<f64>() * 3.0,
                rng.r#gen::<f64>() * 3.0,
            )),
            species: 0,
        })
        .collect();
    let species = vec![Species {
        name: "tiny".into(),
        shape: shape.parse::<Shape>().unwrap(),
        rotation: true,
    }];
    System::new(
        PeriodicBox::new(Vector3::repeat(len)).unwrap(),
        species,
        particles,
    )
    .unwrap()
}

#[test]
fn msd_and_c2_follow_free_flight_across_the_boundaries() {
    let shape = "Ellipsoid(a: 0.002, b: 0.001, c: 0.001)";
    let system = tiny_gas(shape, 3);
    let mut rng = Pcg64::seed_from_u64(4);
    let mut md = Dynamics::from_state(&system, &DynamicsOptions::default(), &mut rng).unwrap();
    let start = md.particles();
    let motion = md.velocities();
    let axis = molecular_axis(&shape.parse().unwrap()).unwrap();
    for t in [0.5, 3.0, 20.0] {
        md.run_until(t).unwrap();
        assert_eq!(
            md.collisions(),
            0,
            "the tiny bodies met; the test needs a free gas"
        );
        let msd: f64 = motion
            .iter()
            .map(|(v, _)| v.norm_squared() * t * t)
            .sum::<f64>()
            / 64.0;
        let got = md.mean_squared_displacement();
        assert!(
            (got / msd - 1.0).abs() < 1e-9,
            "t = {t}: MSD {got} vs {msd}"
        );
        let c2: f64 = start
            .iter()
            .zip(&motion)
            .map(|(p, (_, w))| {
                let u0 = p.orientation * axis;
                let u = UnitQuaternion::from_scaled_axis(w * t) * u0;
                legendre_p2(u.dot(&u0))
            })
            .sum::<f64>()
            / 64.0;
        let got = md.orientational_correlation().unwrap();
        assert!((got - c2).abs() < 1e-9, "t = {t}: C2 {got} vs {c2}");
    }
    // Far past the box size: the bodies crossed the boundaries many times.
    let largest = motion.iter().map(|(v, _)| v.norm()).fold(0.0, f64::max);
    assert!(largest * 20.0 > 3.0 * 5.0);
    // A new reference restarts both.
    md.set_reference();
    assert!(md.mean_squared_displacement() < 1e-20);
    assert!((md.orientational_correlation().unwrap() - 1.0).abs() < 1e-12);
    let s = md.sample();
    assert!(s.nematic_order.is_some());
}

/// Spheres have no molecular axis: no nematic order, no C₂.
#[test]
fn spheres_have_no_orientational_observables() {
    let system = tiny_gas("Sphere(radius: 0.001)", 5);
    let mut rng = Pcg64::seed_from_u64(6);
    let mut md = Dynamics::from_state(&system, &DynamicsOptions::default(), &mut rng).unwrap();
    md.run_until(1.0).unwrap();
    assert_eq!(md.orientational_correlation(), None);
    assert_eq!(md.sample().nematic_order, None);
}
