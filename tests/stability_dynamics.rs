//! Stability of the event-driven dynamics in degenerate and extreme cases
//! (issue 7): zero relative velocity, bodies at rest in contact, speeds
//! 10⁶ apart in one system, simulated times up to 10⁶, and very elongated,
//! flat or sharp bodies. Every run checks, at every frame, that the state
//! is overlap-free by the MC kernels (independent of the prediction) and
//! that the energy is conserved; no run may stall.

mod common;

use common::compressed_state;
use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, Species, System};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

type V3 = Vector3<f64>;

fn species(shape: &str) -> Species {
    Species {
        name: shape.into(),
        shape: shape.parse().unwrap(),
        rotation: true,
    }
}

fn at(x: f64, y: f64, z: f64) -> Particle {
    Particle {
        position: V3::new(x, y, z),
        orientation: UnitQuaternion::identity(),
        species: 0,
    }
}

fn dynamics(system: &System, seed: u64) -> Dynamics {
    Dynamics::from_state(
        system,
        &DynamicsOptions::default(),
        &mut Pcg64::seed_from_u64(seed),
    )
    .unwrap()
}

/// Runs to `t_end` in `frames` frames, checking overlaps and energy.
fn run_checked(md: &mut Dynamics, t_end: f64, frames: usize, what: &str) {
    let e0 = md.kinetic_energy();
    let t0 = md.time();
    for f in 1..=frames {
        let t = t0 + (t_end - t0) * f as f64 / frames as f64;
        md.run_until(t).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(md.time(), t, "{what}: the clock lands on the time asked");
        md.to_system()
            .unwrap_or_else(|e| panic!("{what} at t = {t}: {e}"));
        let drift = (md.kinetic_energy() / e0 - 1.0).abs();
        assert!(drift < 1e-9, "{what}: energy drift {drift:e} at t = {t}");
    }
}

#[test]
fn zero_relative_velocity_never_collides_or_stalls() {
    // Two rods side by side 1e-9 apart, moving together, not turning.
    let b = PeriodicBox::new(V3::repeat(10.0)).unwrap();
    let gap = 1e-9;
    let particles = vec![at(0.0, 0.0, 0.0), at(0.0, 1.0 + gap, 0.0)];
    let system = System::new(
        b,
        vec![species("Ellipsoid(a: 2.0, b: 0.5, c: 0.5)")],
        particles,
    )
    .unwrap();
    let mut md = dynamics(&system, 1);
    let v = V3::new(0.7, 0.0, 0.3);
    md.set_velocities(&[(v, V3::zeros()), (v, V3::zeros())])
        .unwrap();
    run_checked(&mut md, 100.0, 50, "parallel rods");
    assert_eq!(md.collisions(), 0);
    let p = md.particles();
    let d = b.minimum_image(&(p[1].position - p[0].position));
    assert!((d - V3::new(0.0, 1.0 + gap, 0.0)).norm() < 1e-12, "{d}");
}

/// Two cubes resting face to face (1e-12 apart, faces exactly parallel)
/// in a gas of cubes. Regression (issue 7): when the gas hit them at
/// t = 2.1, elastic single-point impulses alternated between the corners
/// of the shared face without end (each set the cube turning about the
/// corner it acted at, and the next corner came in) until the stall guard
/// stopped the run ("5201 events at t = 2.0993878520982436 without time
/// advancing"). A flat contact now takes simultaneous impulses at the
/// corners of the shared region (`collision::collide_patch`).
#[test]
fn bodies_at_rest_in_contact_stay_put_among_moving_ones() {
    // Cubes face to face 1e-12 apart, at rest, in a gas of moving cubes.
    let mut rng = Pcg64::seed_from_u64(2);
    let cube = species("Cuboid(a: 0.5, b: 0.5, c: 0.5)");
    let b = PeriodicBox::new(V3::repeat(12.0)).unwrap();
    let mut particles = vec![at(0.0, 0.0, 0.0), at(1.0 + 1e-12, 0.0, 0.0)];
    // The gas on a lattice of spacing >= 2 (cube bounding diameter 1.73),
    // above the resting pair.
    for i in 0..40 {
        let (x, y, z) = ((i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64);
        particles.push(Particle {
            position: V3::new(-5.0 + 2.5 * x, -3.0 + 2.0 * y, 2.0 + 1.8 * z),
            orientation: common::random_rotation(&mut rng),
            species: 0,
        });
    }
    let system = System::new(b, vec![cube], particles).unwrap();
    let mut md = dynamics(&system, 3);
    let mut v = md.velocities();
    v[0] = (V3::zeros(), V3::zeros());
    v[1] = (V3::zeros(), V3::zeros());
    md.set_velocities(&v).unwrap();
    md.record_collisions(true);
    run_checked(&mut md, 20.0, 100, "cubes at rest in contact");
    assert!(md.collisions() > 100, "the gas moves: {}", md.collisions());
    // The resting pair was disturbed and met again, face to face.
    let pair = md
        .take_collisions()
        .iter()
        .filter(|&&(_, i, j)| (i, j) == (0, 1))
        .count();
    assert!(pair > 0, "the resting pair never collided");
    eprintln!("resting pair: {pair} collisions");
}

#[test]
fn speeds_a_million_apart_in_one_system() {
    let system = compressed_state(&["Ellipsoid(a: 0.8, b: 0.4, c: 0.4)"], 4, 0.3, 5);
    let mut md = dynamics(&system, 6);
    // Half the bodies a thousand times faster than typical, half a
    // thousand times slower: a ratio of 10⁶.
    let v: Vec<_> = md
        .velocities()
        .iter()
        .enumerate()
        .map(|(i, (v, w))| {
            let s = if i % 2 == 0 { 1e3 } else { 1e-3 };
            (v * s, w * s)
        })
        .collect();
    md.set_velocities(&v).unwrap();
    run_checked(&mut md, 0.02, 100, "speed ratio 1e6");
    assert!(md.collisions() > 1000, "{}", md.collisions());
}

#[test]
fn long_simulated_times_keep_their_precision() {
    // Two spheres that never meet (parallel paths), run to t = 10⁶ through
    // many rebases: each ends where free flight puts it, to 1e-9.
    let b = PeriodicBox::new(V3::new(7.0, 7.0, 7.0)).unwrap();
    let particles = vec![at(0.0, 0.0, 0.0), at(0.0, 3.0, 0.0)];
    let system = System::new(b, vec![species("Sphere(radius: 0.5)")], particles).unwrap();
    let mut md = dynamics(&system, 7);
    let v = V3::new(0.123_456_789, 0.0, 0.0);
    md.set_velocities(&[(v, V3::zeros()), (-v, V3::zeros())])
        .unwrap();
    run_checked(&mut md, 1e6, 1000, "long run");
    // x(t) = 0.123456789 t mod 7, wrapped into [-3.5, 3.5).
    let exact = |s: f64| {
        let x = (s * 0.123_456_789e6_f64).rem_euclid(7.0);
        if x >= 3.5 { x - 7.0 } else { x }
    };
    let p = md.particles();
    assert!(
        (p[0].position.x - exact(1.0)).abs() < 1e-9,
        "{} vs {}",
        p[0].position.x,
        exact(1.0)
    );
    assert!(
        (p[1].position.x - exact(-1.0)).abs() < 1e-9,
        "{} vs {}",
        p[1].position.x,
        exact(-1.0)
    );
    assert_eq!(md.time(), 1e6);
}

/// A short run of a fluid of `shape` compressed to `phi`.
fn extreme(shape: &str, n: usize, phi: f64, collisions: u64) {
    let system = compressed_state(&[shape], n, phi, 11);
    let mut md = dynamics(&system, 12);
    let e0 = md.kinetic_energy();
    let started = std::time::Instant::now();
    let mut frames = 0;
    while md.collisions() < collisions {
        let t = md.time() + 0.05;
        md.run_until(t).unwrap_or_else(|e| panic!("{shape}: {e}"));
        md.to_system()
            .unwrap_or_else(|e| panic!("{shape} at t = {t}: {e}"));
        let drift = (md.kinetic_energy() / e0 - 1.0).abs();
        assert!(drift < 1e-9, "{shape}: energy drift {drift:e}");
        frames += 1;
        assert!(frames < 100_000, "{shape}: no collisions");
    }
    eprintln!(
        "{shape} phi {phi}: {} collisions, {frames} frames, {:.0} us/collision",
        md.collisions(),
        started.elapsed().as_secs_f64() * 1e6 / md.collisions() as f64
    );
}

#[test]
fn needles_and_plates() {
    // Enough bodies that the box stays twice their length.
    extreme("Ellipsoid(a: 2.5, b: 0.25, c: 0.25)", 7, 0.15, 2000); // aspect 10
    extreme("Ellipsoid(a: 1.5, b: 0.3, c: 0.3)", 5, 0.2, 2000); // aspect 5
    extreme("Ellipsoid(a: 0.2, b: 1.0, c: 1.0)", 4, 0.2, 2000); // aspect 0.2
    extreme("Ellipsoid(a: 0.1, b: 1.0, c: 1.0)", 4, 0.15, 2000); // aspect 0.1
}

#[test]
fn long_and_flat_cuboids() {
    extreme("Cuboid(a: 2.0, b: 0.1, c: 0.1)", 7, 0.1, 2000); // 1:1:20
    extreme("Cuboid(a: 0.05, b: 1.0, c: 1.0)", 4, 0.1, 2000); // 1:20:20
}

#[test]
fn sharp_superellipsoids() {
    extreme(
        "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (8.0, 8.0, 8.0))",
        4,
        0.3,
        500,
    );
    extreme(
        "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (10.0, 10.0, 10.0))",
        4,
        0.3,
        500,
    );
}
