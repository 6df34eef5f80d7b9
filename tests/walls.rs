//! Hard walls: Monte Carlo never lets a body touch one; event-driven
//! dynamics bounces bodies off them elastically (energy conserved, no body
//! ever crosses, checked independently at every frame), a single sphere
//! follows the exact reflected path, and the pressure on the walls of a
//! dilute gas is the ideal-gas value between walls L − 2r apart.

use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::space::PeriodicBox;
use hardbody::state::start::lattice;
use hardbody::state::{Particle, Species, System};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

fn species(name: &str, shape: &str) -> Species {
    Species {
        name: name.into(),
        shape: shape.parse().unwrap(),
        rotation: true,
    }
}

fn walled(l: f64, walls: [bool; 3]) -> PeriodicBox {
    PeriodicBox::new(Vector3::repeat(l))
        .unwrap()
        .with_walls(walls)
        .unwrap()
}

#[test]
fn monte_carlo_keeps_bodies_inside_the_walls() {
    let mut rng = Pcg64::seed_from_u64(3);
    let kinds = vec![
        species("rod", "Ellipsoid(a: 1.0, b: 0.4, c: 0.4)"),
        species("brick", "Cuboid(a: 0.6, b: 0.4, c: 0.3)"),
    ];
    let mut system = lattice(
        walled(9.0, [false, false, true]),
        kinds,
        &[40, 40],
        &mut rng,
    )
    .unwrap();
    let sizes = MoveSizes {
        translate: 0.4,
        rotate: 0.4,
        volume: 0.0,
        shear: 0.01,
    };
    let mut near_wall = 0;
    for _ in 0..400 {
        sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
        assert_eq!(system.first_wall_overlap(), None);
        near_wall += system
            .particles()
            .iter()
            .filter(|p| p.position.z.abs() > 3.5)
            .count();
    }
    assert_eq!(system.first_overlap_all_pairs(), None);
    // Bodies do reach the walls' neighbourhood (the walls are not just
    // never approached), and x, y stay periodic (bodies wrap there).
    assert!(near_wall > 100, "{near_wall}");
    // A body placed across a wall is refused.
    let mut particles = system.particles().to_vec();
    particles[0].position.z = 4.3;
    let err =
        System::new(*system.periodic_box(), system.species().to_vec(), particles).unwrap_err();
    assert_eq!(err, hardbody::state::StateError::WallOverlap(0));
}

#[test]
fn a_sphere_bounces_exactly() {
    // One sphere (and a far partner the dynamics needs) between walls in x.
    let b = walled(10.0, [true, false, false]);
    let ball = species("ball", "Sphere(radius: 0.5)");
    let particles = vec![
        Particle {
            position: Vector3::new(0.0, 0.0, 0.0),
            orientation: UnitQuaternion::identity(),
            species: 0,
        },
        Particle {
            position: Vector3::new(0.0, 4.0, 4.0),
            orientation: UnitQuaternion::identity(),
            species: 0,
        },
    ];
    let system = System::new(b, vec![ball], particles).unwrap();
    let mut md = Dynamics::from_state(
        &system,
        &DynamicsOptions::default(),
        &mut Pcg64::seed_from_u64(1),
    )
    .unwrap();
    let v = Vector3::new(1.3, 0.0, 0.0);
    md.set_velocities(&[(v, Vector3::zeros()), (Vector3::zeros(), Vector3::zeros())])
        .unwrap();
    // The centre moves between -4.5 and 4.5: period 2 x 9 / 1.3.
    let period = 18.0 / 1.3;
    md.run_until(3.25 * period).unwrap();
    let x = md.particles()[0].position.x;
    // After 3.25 periods: a quarter period on from the start, 4.5 out.
    assert!((x - 4.5).abs() < 1e-9, "{x}");
    md.run_until(3.5 * period).unwrap();
    let x = md.particles()[0].position.x;
    assert!(x.abs() < 1e-9, "{x}");
    assert!((md.velocities()[0].0.x + 1.3).abs() < 1e-12);
    assert!((md.kinetic_energy() - 0.5 * 1.3 * 1.3).abs() < 1e-12);
}

/// Runs a gas between walls on `walls` for at least `collisions`
/// collisions (pairs and walls), checking energy and every frame; returns
/// the dynamics.
fn closed_gas(shapes: &[&str], counts: &[usize], l: f64, walls: [bool; 3], time: f64) -> Dynamics {
    closed_gas_with(shapes, counts, l, walls, time, None)
}

/// [`closed_gas`] with neighbour lists of shell `shell` (None: cells).
fn closed_gas_with(
    shapes: &[&str],
    counts: &[usize],
    l: f64,
    walls: [bool; 3],
    time: f64,
    shell: Option<f64>,
) -> Dynamics {
    let mut rng = Pcg64::seed_from_u64(7);
    let kinds: Vec<Species> = shapes
        .iter()
        .enumerate()
        .map(|(k, s)| species(&format!("s{k}"), s))
        .collect();
    let system = lattice(walled(l, walls), kinds, counts, &mut rng).unwrap();
    let options = DynamicsOptions {
        neighbour_shell: shell,
        ..DynamicsOptions::default()
    };
    let mut md = Dynamics::from_state(&system, &options, &mut rng).unwrap();
    let e0 = md.kinetic_energy();
    let frames = 200;
    for f in 1..=frames {
        md.run_until(time * f as f64 / frames as f64)
            .unwrap_or_else(|e| panic!("{shapes:?}: {e}"));
        let s = md
            .to_system()
            .unwrap_or_else(|e| panic!("{shapes:?} frame {f}: {e}"));
        assert_eq!(s.first_wall_overlap(), None);
        let drift = (md.kinetic_energy() / e0 - 1.0).abs();
        assert!(drift < 1e-9, "{shapes:?}: energy drift {drift:e}");
    }
    assert_eq!(md.to_system().unwrap().first_overlap_all_pairs(), None);
    md
}

#[test]
fn turning_bodies_bounce_off_walls_conserving_energy() {
    for (shapes, counts) in [
        (&["Ellipsoid(a: 1.0, b: 0.5, c: 0.3)"][..], &[60][..]),
        (
            &["Cuboid(a: 0.7, b: 0.5, c: 0.3)", "Sphere(radius: 0.4)"][..],
            &[30, 30][..],
        ),
        (
            &["Superellipsoid(a: 0.8, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))"][..],
            &[30][..],
        ),
    ] {
        for shell in [None, Some(0.2)] {
            let md = closed_gas_with(shapes, counts, 8.0, [true, true, true], 20.0, shell);
            eprintln!(
                "{shapes:?}, shell {shell:?}: {} collisions in t = 20",
                md.collisions()
            );
            assert!(md.collisions() > 200, "{shapes:?}");
        }
    }
}

#[test]
fn wall_pressure_of_a_dilute_gas_is_the_ideal_one_between_the_walls() {
    // 20 spheres of radius 0.1 in a 10³ box closed on every side. Each
    // bounces between walls L − 2r apart, so the force on a wall is
    // Σ m vₖ² / (L − 2r) and the pressure on its area L² is
    // βP = N / ((L − 2r) L²) (the pair correction is ~3e-4). Kinetic
    // energy is 3N/2 kT: walls take momentum, so none of it is constrained.
    let (n, r, l) = (20.0, 0.1, 10.0);
    let mut md = closed_gas(&["Sphere(radius: 0.1)"], &[20], l, [true; 3], 10.0);
    assert_eq!(md.degrees_of_freedom(), 60.0);
    md.sample();
    md.run_until(md.time() + 4000.0).unwrap();
    let s = md.sample();
    let ideal = n / ((l - 2.0 * r) * l * l);
    let p = s.pressure.unwrap();
    eprintln!(
        "wall betaP {p:.5}, ideal {ideal:.5}, N/V {:.5}",
        n / l.powi(3)
    );
    assert!((p / ideal - 1.0).abs() < 0.015, "{p} vs {ideal}");
    // The collision virial is not the pressure between walls.
    assert_eq!(s.pressure_tensor, None);
    // The translational energy kept through wall and pair collisions
    // (from their impulses) is the spheres' energy.
    let kept = md.translational_kinetic_energy();
    assert!(
        (kept / md.kinetic_energy() - 1.0).abs() < 1e-10,
        "{kept} vs {}",
        md.kinetic_energy()
    );
}

#[test]
fn periodic_axes_keep_their_momentum_constraint() {
    // Walls in z only: momentum along x and y stays zero, so 3N − 2.
    let md = closed_gas(
        &["Sphere(radius: 0.3)"],
        &[40],
        8.0,
        [false, false, true],
        5.0,
    );
    assert_eq!(md.degrees_of_freedom(), 118.0);
    let p = md.momentum();
    assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12, "{p}");
}
