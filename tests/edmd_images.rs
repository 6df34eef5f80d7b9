//! Event-driven dynamics and periodic images: a tilted box that spans the
//! same lattice as an orthorhombic one gives the same trajectory, cells
//! and neighbour lists give the same collisions in a genuinely tilted box,
//! bodies there keep apart and keep their energy, and boxes only a few
//! cells wide, where a pair can touch in more than one image, miss no
//! collision.

mod common;

use common::{compressed_state, compressed_state_tilted};
use hardbody::edmd::{Dynamics, DynamicsOptions};
use hardbody::space::PeriodicBox;
use hardbody::state::{Particle, System};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

type V3 = Vector3<f64>;

/// `system`'s bodies, where they are, in `box_` (wrapped into it).
fn in_box(system: &System, box_: PeriodicBox) -> System {
    let particles: Vec<Particle> = system
        .particles()
        .iter()
        .map(|p| Particle {
            position: box_.wrap(&p.position),
            ..*p
        })
        .collect();
    System::new(box_, system.species().to_vec(), particles).unwrap()
}

/// The first `collisions` collisions (time, pair) from `system` with the
/// velocities of `seed`, on cells or neighbour lists (`shell`); the state
/// is checked overlap-free after them, and the kinetic energy conserved.
fn collisions(system: &System, shell: Option<f64>, seed: u64, count: u64) -> Vec<(f64, u32, u32)> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let options = DynamicsOptions {
        neighbour_shell: shell,
        ..DynamicsOptions::default()
    };
    let mut md = Dynamics::from_state(system, &options, &mut rng).unwrap();
    let e0 = md.kinetic_energy();
    md.record_collisions(true);
    md.run_collisions(count)
        .unwrap_or_else(|e| panic!("shell {shell:?}: {e}"));
    let t = md.time();
    md.run_until(t + 1e-9).unwrap();
    md.to_system()
        .unwrap_or_else(|e| panic!("shell {shell:?}: {e}"));
    let drift = (md.kinetic_energy() / e0 - 1.0).abs();
    assert!(drift < 1e-11, "shell {shell:?}: energy drift {drift:e}");
    md.take_collisions()
}

/// A box whose tilts are whole numbers (with equal edges) spans the lattice
/// of the orthorhombic box: the same periodic system, whose images the
/// dynamics finds through other cells (the tilted box's heights are
/// smaller, so its cells are fewer and differently cut), other crossings
/// and other shifts. From the same positions and velocities, both give
/// the same collisions, pair by pair, in times equal to rounding, until
/// rounding parts the trajectories (chaos amplifies a last-bit
/// difference by about e per collision per body).
#[test]
fn a_tilted_box_spanning_the_same_lattice_gives_the_same_collisions() {
    for (shapes, phi, seed, count, tilts) in [
        (
            &["Sphere(radius: 0.5)"][..],
            0.45,
            3,
            3000,
            V3::new(1.0, 0.0, 0.0),
        ),
        (
            &["Sphere(radius: 0.5)"][..],
            0.30,
            4,
            3000,
            V3::new(-1.0, 1.0, 1.0),
        ),
        (
            &["Ellipsoid(a: 0.8, b: 0.4, c: 0.4)"][..],
            0.45,
            5,
            600,
            V3::new(0.0, 1.0, -1.0),
        ),
        (
            &["Cuboid(a: 0.5, b: 0.5, c: 0.5)"][..],
            0.4,
            6,
            600,
            V3::new(1.0, 0.0, 1.0),
        ),
    ] {
        let upright = compressed_state(shapes, 6, phi, seed);
        let lengths = upright.periodic_box().lengths();
        let tilted = in_box(&upright, PeriodicBox::triclinic(lengths, tilts).unwrap());
        let a = collisions(&upright, None, seed + 10, count);
        let b = collisions(&tilted, None, seed + 10, count);
        let pairs = a
            .iter()
            .zip(&b)
            .take_while(|(x, y)| (x.1, x.2) == (y.1, y.2))
            .count();
        let worst = a
            .iter()
            .zip(&b)
            .take(count as usize / 2)
            .map(|(x, y)| (x.0 - y.0).abs() / x.0.max(1.0))
            .fold(0.0, f64::max);
        eprintln!(
            "{shapes:?} tilts {tilts:?}: the same pairs for {pairs} of {count} collisions, times within {worst:e} over the first half"
        );
        assert!(
            pairs >= count as usize / 2,
            "{shapes:?}: parted after {pairs}"
        );
        assert!(worst < 1e-9, "{shapes:?}: times differ by {worst:e}");
    }
}

/// In a genuinely tilted box (no orthorhombic cell spans its lattice),
/// neighbour lists change how pairs are found, not the trajectory: cells
/// and lists give the same collisions bit for bit, for spheres (closed
/// form, whose crossing searches one layer of cells) and for bodies
/// (searched), and the bodies stay apart.
#[test]
fn cells_and_lists_give_the_same_collisions_in_a_tilted_box() {
    for (shapes, phi, seed, count, shells) in [
        (&["Sphere(radius: 0.5)"][..], 0.45, 7, 50_000, [0.1, 0.4]),
        (&["Sphere(radius: 0.5)"][..], 0.05, 8, 10_000, [0.1, 0.4]),
        (
            &["Ellipsoid(a: 0.8, b: 0.4, c: 0.4)"][..],
            0.45,
            9,
            5000,
            [0.2, 0.5],
        ),
        (
            &["Cuboid(a: 0.5, b: 0.5, c: 0.5)", "Sphere(radius: 0.5)"][..],
            0.4,
            10,
            5000,
            [0.1, 0.3],
        ),
    ] {
        let system = tilted_fluid(shapes, phi, seed);
        let cells = collisions(&system, None, seed + 10, count);
        for shell in shells {
            let lists = collisions(&system, Some(shell), seed + 10, count);
            let same = cells.iter().zip(&lists).take_while(|(a, b)| a == b).count();
            eprintln!("{shapes:?} phi {phi}, shell {shell}: the same {same} collisions of {count}");
            assert_eq!(same, cells.len(), "{shapes:?}: parted after {same}");
        }
    }
}

/// A fluid of `shapes` at `phi` in a box tilted by (0.3, −0.2, 0.25).
fn tilted_fluid(shapes: &[&str], phi: f64, seed: u64) -> System {
    let system = compressed_state_tilted(shapes, 6, phi, seed, V3::new(0.3, -0.2, 0.25));
    assert!(system.periodic_box().is_tilted());
    system
}

/// In a box three cells wide (27 spheres at φ = 0.3, or 27 ellipsoids), a
/// pair in neighbouring cells can be more than half a box apart and touch
/// in the image beyond the nearest before either leaves its cell: every
/// such contact is found (a missed one ends the run with a contact
/// mismatch, and the final state is checked for overlaps), with cells and
/// with lists, orthorhombic and tilted.
#[test]
fn boxes_a_few_cells_wide_miss_no_collision() {
    for (shapes, phi, count, seeds) in [
        (&["Sphere(radius: 0.5)"][..], 0.3, 20_000, 6),
        (&["Sphere(radius: 0.5)"][..], 0.45, 20_000, 2),
        (&["Ellipsoid(a: 0.8, b: 0.4, c: 0.4)"][..], 0.3, 3000, 2),
    ] {
        for seed in 0..seeds {
            for tilts in [V3::zeros(), V3::new(0.2, 0.0, -0.1)] {
                let system = compressed_state_tilted(shapes, 3, phi, seed, tilts);
                for shell in [None, Some(0.1)] {
                    collisions(&system, shell, seed + 10, count);
                }
            }
        }
    }
}
