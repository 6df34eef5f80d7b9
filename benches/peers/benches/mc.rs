//! Trial moves per second of hard-particle NVT Monte Carlo on one core:
//! hardbody's sweep against hoomd-mc 1.4 (the Glotzer lab's Rust HPMC) on
//! the same starting states, measured side by side in one run. Run with
//! `cargo bench --bench mc` from `benches/peers/` (`QUICK=1` for a short run).
//!
//! Systems (φ = 0.5, N ≈ 4096): spheres; ellipsoids a = 2.5, b = c = 0.5
//! (the shape of HOOMD's benchmark harness); cubes; cubes and tetrahedra
//! (φ = 0.3) as convex polyhedra of their corners; spherocylinders of
//! length 5 and radius 0.5 (L/D = 5, φ = 0.3, each code's closed form of
//! the segments' distance). Both codes start from
//! hardbody's dense lattice start, equilibrated by hardbody for 60 sweeps,
//! and each tunes its own move sizes to 30 % acceptance (hardbody draws
//! translations from a cube, hoomd-mc from a ball, so equal acceptance is
//! the fair comparison, not equal parameters). hardbody's sweep is N moves,
//! each a translation or (for bodies) a rotation with probability ½;
//! hoomd-mc's is a translation sweep then a rotation sweep. Trial moves per
//! second count every trial move of either kind. Each timed block is
//! followed by hoomd-mc's state checked for overlaps with hardbody's
//! all-pairs test, so that both did the same physics.

use std::time::Instant;

use hardbody::bench::mc::dense_start;
use hardbody::geometry::Shape;
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::mc::tuning::Tuner;
use hardbody::state::{Particle, System};
use hoomd_geometry::Convex;
use hoomd_geometry::shape::{Capsule, ConvexPolyhedron, Hypercuboid, Hyperellipsoid};
use hoomd_interaction::PairwiseCutoff;
use hoomd_interaction::pairwise::{HardShape, HardSphere};
use hoomd_mc::{Count, Rotate, Sweep, Translate, Trial, tune_by_scaling};
use hoomd_microstate::boundary::Periodic;
use hoomd_microstate::property::OrientedPoint;
use hoomd_microstate::{Body, Microstate};
use hoomd_simulation::macrostate::Isothermal;
use hoomd_spatial::VecCell;
use hoomd_vector::{Cartesian, Quaternion, Versor};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

const TARGET: f64 = 0.3;

fn pos(x: f64) -> hoomd_utility::valid::PositiveReal {
    x.try_into().unwrap()
}

fn cart(v: &Vector3<f64>) -> Cartesian<3> {
    Cartesian::from([v.x, v.y, v.z])
}

fn versor(q: &UnitQuaternion<f64>) -> Versor {
    Quaternion::from([q.w, q.i, q.j, q.k]).to_versor_unchecked()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn box_shape(system: &System) -> Hypercuboid<3> {
    let l = system.periodic_box().lengths();
    Hypercuboid {
        edge_lengths: [pos(l.x), pos(l.y), pos(l.z)],
    }
}

/// hardbody: tuned sweeps, `repeats` × `sweeps`, median moves/s.
fn ours(system: &mut System, repeats: usize, sweeps: usize) -> (f64, f64) {
    let mut rng = Pcg64::seed_from_u64(17);
    let mut sizes = MoveSizes {
        translate: 0.1,
        rotate: 0.1,
        volume: 0.0,
        shear: 0.01,
    };
    let tuner = Tuner {
        target: TARGET,
        max_translate: 1.0,
    };
    for _ in 0..60 {
        let c = sweep(system, &sizes, &Ensemble::Nvt, &mut rng);
        tuner.update(&mut sizes, &c);
    }
    let mut rates = Vec::new();
    let (mut tried, mut accepted) = (0u64, 0u64);
    for _ in 0..repeats {
        let start = Instant::now();
        for _ in 0..sweeps {
            let c = sweep(system, &sizes, &Ensemble::Nvt, &mut rng);
            tried += c.translate.tried + c.rotate.tried;
            accepted += c.translate.accepted + c.rotate.accepted;
        }
        rates.push((sweeps * system.len()) as f64 / start.elapsed().as_secs_f64());
    }
    assert!(system.first_overlap_all_pairs().is_none());
    (median(&mut rates), accepted as f64 / tried as f64)
}

/// The state a hoomd-mc microstate describes, as a hardbody system (checked
/// for overlaps by all pairs).
fn check_theirs(like: &System, particles: Vec<Particle>) {
    let back = System::new(
        *like.periodic_box(),
        like.species().to_vec(),
        particles.clone(),
    )
    .expect("hoomd-mc state is a valid hardbody state");
    assert!(
        back.first_overlap_all_pairs().is_none(),
        "hoomd-mc left an overlap"
    );
}

fn theirs_spheres(system: &System, repeats: usize, sweeps: usize) -> (f64, f64) {
    let range = 1.0;
    let mut micro = Microstate::builder()
        .boundary(Periodic::new(range, box_shape(system)).unwrap())
        .spatial_data(
            VecCell::<_, 3>::builder()
                .nominal_search_radius(pos(range))
                .build(),
        )
        .seed(17)
        .try_build()
        .unwrap();
    for p in system.particles() {
        micro
            .add_body(Body::point(cart(&p.position)))
            .expect("body in the box");
    }
    let hamiltonian = PairwiseCutoff(HardSphere { diameter: 1.0 });
    let macrostate = Isothermal { temperature: 1.0 };
    let mut translate = Sweep(Translate::with_maximum_distance(pos(0.1)));
    for _ in 0..60 {
        let c = translate.apply(&mut micro, &hamiltonian, &macrostate);
        tune_by_scaling(&mut translate.0, TARGET.try_into().unwrap(), &c);
        micro.increment_step();
    }
    let mut rates = Vec::new();
    let mut count = Count::default();
    for _ in 0..repeats {
        let start = Instant::now();
        for _ in 0..sweeps {
            if micro.step().is_multiple_of(300) {
                micro.sort_sites();
            }
            count += translate.apply(&mut micro, &hamiltonian, &macrostate);
            micro.increment_step();
        }
        rates.push((sweeps * system.len()) as f64 / start.elapsed().as_secs_f64());
    }
    let particles = micro
        .bodies()
        .iter()
        .map(|b| {
            let r = b.item.properties.position;
            Particle {
                position: Vector3::new(r[0], r[1], r[2]),
                orientation: UnitQuaternion::identity(),
                species: 0,
            }
        })
        .collect();
    check_theirs(system, particles);
    (median(&mut rates), count.acceptance_ratio().unwrap())
}

type Oriented = OrientedPoint<Cartesian<3>, Versor>;

fn theirs_oriented<G>(
    system: &System,
    shape: G,
    range: f64,
    repeats: usize,
    sweeps: usize,
) -> (f64, f64)
where
    G: Clone + Sync + Send,
    HardShape<G>: hoomd_interaction::SitePairEnergy<Oriented>,
    PairwiseCutoff<HardShape<G>>: hoomd_interaction::DeltaEnergyOne<
            Oriented,
            Oriented,
            VecCell<hoomd_microstate::SiteKey, 3>,
            Periodic<Hypercuboid<3>>,
        >,
{
    let mut micro = Microstate::builder()
        .boundary(Periodic::new(range, box_shape(system)).unwrap())
        .spatial_data(
            VecCell::<_, 3>::builder()
                .nominal_search_radius(pos(range))
                .build(),
        )
        .seed(17)
        .try_build()
        .unwrap();
    for p in system.particles() {
        let body = OrientedPoint {
            position: cart(&p.position),
            orientation: versor(&p.orientation),
        };
        micro
            .add_body(Body::single_site(body, Oriented::default()))
            .expect("body in the box");
    }
    let hamiltonian = PairwiseCutoff(HardShape(shape));
    let macrostate = Isothermal { temperature: 1.0 };
    let mut translate = Sweep(Translate::with_maximum_distance(pos(0.1)));
    let mut rotate = Sweep(Rotate::<Versor>::with_maximum_rotation(pos(0.1)));
    for _ in 0..60 {
        let c = translate.apply(&mut micro, &hamiltonian, &macrostate);
        tune_by_scaling(&mut translate.0, TARGET.try_into().unwrap(), &c);
        let c = rotate.apply(&mut micro, &hamiltonian, &macrostate);
        tune_by_scaling(&mut rotate.0, TARGET.try_into().unwrap(), &c);
        micro.increment_step();
    }
    let mut rates = Vec::new();
    let mut count = Count::default();
    for _ in 0..repeats {
        let start = Instant::now();
        for _ in 0..sweeps / 2 {
            if micro.step().is_multiple_of(300) {
                micro.sort_sites();
            }
            count += translate.apply(&mut micro, &hamiltonian, &macrostate);
            count += rotate.apply(&mut micro, &hamiltonian, &macrostate);
            micro.increment_step();
        }
        rates.push((sweeps / 2 * 2 * system.len()) as f64 / start.elapsed().as_secs_f64());
    }
    let particles = micro
        .bodies()
        .iter()
        .map(|b| {
            let r = b.item.properties.position;
            let q = b.item.properties.orientation.get();
            Particle {
                position: Vector3::new(r[0], r[1], r[2]),
                orientation: UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
                    q.scalar,
                    q.vector[0],
                    q.vector[1],
                    q.vector[2],
                )),
                species: 0,
            }
        })
        .collect();
    check_theirs(system, particles);
    (median(&mut rates), count.acceptance_ratio().unwrap())
}

fn main() {
    let quick = std::env::var("QUICK").is_ok();
    let (n, repeats, sweeps) = if quick { (1400, 3, 10) } else { (4096, 5, 100) };
    println!(
        "| system | N | hardbody moves/s | hoomd-mc 1.4 moves/s | ratio | acceptance (ours / theirs) |"
    );
    println!("|---|---|---|---|---|---|");
    let report = |name: &str, n: usize, a: (f64, f64), b: (f64, f64)| {
        println!(
            "| {name} | {n} | {:.3e} | {:.3e} | {:.2} | {:.2} / {:.2} |",
            a.0,
            b.0,
            a.0 / b.0,
            a.1,
            b.1
        );
    };
    // Interleaved: ours, theirs, ours, theirs (three rounds), medians of all.
    let rounds = 2;

    let sphere: Shape = "Sphere(radius: 0.5)".parse().unwrap();
    let mut system = dense_start(&sphere, n, 0.5).unwrap();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        a.push(ours(&mut system, repeats, sweeps));
        b.push(theirs_spheres(&system, repeats, sweeps));
    }
    report("spheres", system.len(), pick(&mut a), pick(&mut b));

    let ellipsoid: Shape = "Ellipsoid(a: 2.5, b: 0.5, c: 0.5)".parse().unwrap();
    let mut system = dense_start(&ellipsoid, n, 0.5).unwrap();
    let g = Convex(Hyperellipsoid::with_semi_axes([
        pos(2.5),
        pos(0.5),
        pos(0.5),
    ]));
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        a.push(ours(&mut system, repeats, sweeps));
        b.push(theirs_oriented(&system, g.clone(), 5.0, repeats, sweeps));
    }
    report(
        "ellipsoids 2.5:0.5:0.5",
        system.len(),
        pick(&mut a),
        pick(&mut b),
    );

    let cube: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
    let mut system = dense_start(&cube, n, 0.5).unwrap();
    let g = Convex(Hypercuboid {
        edge_lengths: [pos(1.0), pos(1.0), pos(1.0)],
    });
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        a.push(ours(&mut system, repeats, sweeps));
        b.push(theirs_oriented(
            &system,
            g.clone(),
            3f64.sqrt(),
            repeats,
            sweeps,
        ));
    }
    report("cubes", system.len(), pick(&mut a), pick(&mut b));

    // Polyhedra: ours through GJK on the hull's corners, theirs
    // (XenoCollide) on the same corners.
    let corners = |points: &[[f64; 3]]| {
        let text: Vec<String> = (points.iter())
            .map(|p| format!("({}, {}, {})", p[0], p[1], p[2]))
            .collect();
        let ours: Shape = format!("ConvexPolyhedron(vertices: [{}])", text.join(", "))
            .parse()
            .unwrap();
        let theirs = Convex(
            ConvexPolyhedron::with_vertices(points.iter().map(|&p| p.into()).collect::<Vec<_>>())
                .unwrap(),
        );
        (ours, theirs)
    };
    let cube_corners: Vec<[f64; 3]> = (0..8)
        .map(|k| [0, 1, 2].map(|a| if k >> a & 1 == 1 { 0.5 } else { -0.5 }))
        .collect();
    let tetrahedron = [
        [0.5, 0.5, 0.5],
        [0.5, -0.5, -0.5],
        [-0.5, 0.5, -0.5],
        [-0.5, -0.5, 0.5],
    ];
    for (name, points, phi) in [
        ("cubes as polyhedra", &cube_corners[..], 0.5),
        ("tetrahedra", &tetrahedron[..], 0.3),
    ] {
        let (shape, g) = corners(points);
        let mut system = dense_start(&shape, n, phi).unwrap();
        let range = 2.0 * shape.bounding_radius();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            a.push(ours(&mut system, repeats, sweeps));
            b.push(theirs_oriented(&system, g.clone(), range, repeats, sweeps));
        }
        report(name, system.len(), pick(&mut a), pick(&mut b));
    }

    // Spherocylinders: both along the body z axis.
    let rod: Shape = "Spherocylinder(radius: 0.5, length: 5.0)".parse().unwrap();
    let mut system = dense_start(&rod, n, 0.3).unwrap();
    let g = Capsule {
        radius: pos(0.5),
        height: pos(5.0),
    };
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        a.push(ours(&mut system, repeats, sweeps));
        b.push(theirs_oriented(&system, g.clone(), 6.0, repeats, sweeps));
    }
    report(
        "spherocylinders L/D = 5",
        system.len(),
        pick(&mut a),
        pick(&mut b),
    );
}

/// The median rate of the rounds, with its acceptance.
fn pick(v: &mut [(f64, f64)]) -> (f64, f64) {
    v.sort_by(|x, y| x.0.total_cmp(&y.0));
    v[v.len() / 2]
}
