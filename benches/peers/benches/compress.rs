//! Seconds from a dilute fluid to a target packing fraction on one core:
//! hardbody's `Compress` against hoomd-mc 1.4's `QuickCompress` (the
//! Glotzer lab's Rust HPMC), from the same start, measured side by side in
//! one run, interleaved (ours, theirs, ours, theirs). Run with
//! `cargo bench --bench compress` from `benches/peers/` (`QUICK=1` for a
//! short run).
//!
//! The start: `hardbody::bench::compress::dilute_start`, the dilute lattice
//! (random orientations, φ ≤ 0.1) melted by 20 sweeps, so that neither
//! code starts from a lattice a box shrink can take as it is. hoomd-mc is driven as its documentation
//! advises: `QuickCompress` with the `OverlapPenalty` potential (through
//! `ApproximateShapeOverlap` for bodies), a translation sweep and for
//! bodies a rotation sweep per step, move sizes tuned to 30 % acceptance
//! every 10 steps, until `is_complete`. Each final state is checked for
//! overlaps with hardbody's all-pairs test.

use std::time::Instant;

use hardbody::bench::compress::{dilute_start, timed};
use hardbody::geometry::Shape;
use hardbody::state::{Particle, System};
use hoomd_geometry::Convex;
use hoomd_geometry::shape::{Hypercuboid, Hyperellipsoid};
use hoomd_interaction::PairwiseCutoff;
use hoomd_interaction::pairwise::{Anisotropic, ApproximateShapeOverlap, Isotropic};
use hoomd_interaction::univariate::{Expanded, OverlapPenalty};
use hoomd_mc::{QuickCompress, Rotate, Sweep, Translate, Trial, tune_by_scaling};
use hoomd_microstate::boundary::Periodic;
use hoomd_microstate::property::OrientedPoint;
use hoomd_microstate::{Body, Microstate};
use hoomd_simulation::macrostate::Isothermal;
use hoomd_spatial::VecCell;
use hoomd_vector::{Cartesian, Quaternion, Versor};
use nalgebra::{UnitQuaternion, Vector3};

const TARGET: f64 = 0.3;
/// Steps after which a run counts as not finished.
const MAX_STEPS: u64 = 200_000;

fn pos(x: f64) -> hoomd_utility::valid::PositiveReal {
    x.try_into().unwrap()
}

fn cart(v: &Vector3<f64>) -> Cartesian<3> {
    Cartesian::from([v.x, v.y, v.z])
}

fn versor(q: &UnitQuaternion<f64>) -> Versor {
    Quaternion::from([q.w, q.i, q.j, q.k]).to_versor_unchecked()
}

fn box_shape(system: &System) -> Hypercuboid<3> {
    let l = system.periodic_box().lengths();
    Hypercuboid {
        edge_lengths: [pos(l.x), pos(l.y), pos(l.z)],
    }
}

/// The volume of the box at `target`.
fn target_volume(start: &System, target: f64) -> f64 {
    start.periodic_box().volume() * start.packing_fraction() / target
}

/// The state a hoomd-mc microstate describes, checked by hardbody's
/// all-pairs test in the box hoomd-mc reached.
fn overlap_free(like: &System, lengths: Vector3<f64>, particles: Vec<Particle>) -> bool {
    let Ok(box_) = hardbody::space::PeriodicBox::new(lengths) else {
        return false;
    };
    System::new(box_, like.species().to_vec(), particles)
        .map(|s| s.first_overlap_all_pairs().is_none())
        .unwrap_or(false)
}

/// hoomd-mc, spheres of diameter 1: seconds and steps, or None if it did
/// not finish in [`MAX_STEPS`]; and whether the state is overlap-free.
fn theirs_spheres(start: &System, target: f64) -> (Option<(f64, u64)>, bool) {
    let mut micro = Microstate::builder()
        .boundary(Periodic::new(1.0, box_shape(start)).unwrap())
        .spatial_data(
            VecCell::<_, 3>::builder()
                .nominal_search_radius(pos(1.0))
                .build(),
        )
        .seed(17)
        .try_build()
        .unwrap();
    for p in start.particles() {
        micro.add_body(Body::point(cart(&p.position))).unwrap();
    }
    let hamiltonian = PairwiseCutoff(Isotropic {
        interaction: Expanded {
            delta: 1.0,
            f: OverlapPenalty::default(),
        },
        r_cut: 1.0,
    });
    let macrostate = Isothermal { temperature: 1.0 };
    let mut translate = Sweep(Translate::with_maximum_distance(pos(0.3)));
    let mut quick = QuickCompress::with_target_volume(pos(target_volume(start, target)));
    let clock = Instant::now();
    while !quick.is_complete() {
        if micro.step() >= MAX_STEPS {
            return (None, false);
        }
        quick.apply(&mut micro, &hamiltonian, |_| true);
        let c = translate.apply(&mut micro, &hamiltonian, &macrostate);
        if micro.step().is_multiple_of(10) {
            tune_by_scaling(&mut translate.0, TARGET.try_into().unwrap(), &c);
        }
        if micro.step().is_multiple_of(300) {
            micro.sort_sites();
        }
        micro.increment_step();
    }
    let seconds = clock.elapsed().as_secs_f64();
    let e = micro.boundary().shape().edge_lengths;
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
    let lengths = Vector3::new(e[0].get(), e[1].get(), e[2].get());
    (
        Some((seconds, micro.step())),
        overlap_free(start, lengths, particles),
    )
}

type Oriented = OrientedPoint<Cartesian<3>, Versor>;

/// hoomd-mc, bodies of shape `shape` reaching at most `range`: as
/// [`theirs_spheres`].
fn theirs_bodies<G>(start: &System, target: f64, shape: G, range: f64) -> (Option<(f64, u64)>, bool)
where
    G: Clone + Sync + Send,
    Anisotropic<ApproximateShapeOverlap<OverlapPenalty, G>>:
        hoomd_interaction::SitePairEnergy<Oriented>,
    PairwiseCutoff<Anisotropic<ApproximateShapeOverlap<OverlapPenalty, G>>>:
        hoomd_interaction::DeltaEnergyOne<
                Oriented,
                Oriented,
                VecCell<hoomd_microstate::SiteKey, 3>,
                Periodic<Hypercuboid<3>>,
            > + hoomd_interaction::TotalEnergy<
                Microstate<
                    Oriented,
                    Oriented,
                    VecCell<hoomd_microstate::SiteKey, 3>,
                    Periodic<Hypercuboid<3>>,
                >,
            >,
{
    let mut micro = Microstate::builder()
        .boundary(Periodic::new(range, box_shape(start)).unwrap())
        .spatial_data(
            VecCell::<_, 3>::builder()
                .nominal_search_radius(pos(range))
                .build(),
        )
        .seed(17)
        .try_build()
        .unwrap();
    for p in start.particles() {
        let body = OrientedPoint {
            position: cart(&p.position),
            orientation: versor(&p.orientation),
        };
        micro
            .add_body(Body::single_site(body, Oriented::default()))
            .unwrap();
    }
    let hamiltonian = PairwiseCutoff(Anisotropic {
        interaction: ApproximateShapeOverlap::new(shape, OverlapPenalty::default(), pos(0.01)),
        r_cut: range,
    });
    let macrostate = Isothermal { temperature: 1.0 };
    let mut translate = Sweep(Translate::with_maximum_distance(pos(0.3)));
    let mut rotate = Sweep(Rotate::<Versor>::with_maximum_rotation(pos(0.3)));
    let mut quick = QuickCompress::with_target_volume(pos(target_volume(start, target)));
    let clock = Instant::now();
    while !quick.is_complete() {
        if micro.step() >= MAX_STEPS {
            return (None, false);
        }
        quick.apply(&mut micro, &hamiltonian, |_| true);
        let c = translate.apply(&mut micro, &hamiltonian, &macrostate);
        let r = rotate.apply(&mut micro, &hamiltonian, &macrostate);
        if micro.step().is_multiple_of(10) {
            tune_by_scaling(&mut translate.0, TARGET.try_into().unwrap(), &c);
            tune_by_scaling(&mut rotate.0, TARGET.try_into().unwrap(), &r);
        }
        if micro.step().is_multiple_of(300) {
            micro.sort_sites();
        }
        micro.increment_step();
    }
    let seconds = clock.elapsed().as_secs_f64();
    let e = micro.boundary().shape().edge_lengths;
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
    let lengths = Vector3::new(e[0].get(), e[1].get(), e[2].get());
    (
        Some((seconds, micro.step())),
        overlap_free(start, lengths, particles),
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let quick = std::env::var("QUICK").is_ok();
    let rounds = if quick { 1 } else { 2 };
    println!(
        "| system | N | φ | hardbody s (sweeps) | hoomd-mc 1.4 s (steps) | ratio | theirs overlap-free |"
    );
    println!("|---|---|---|---|---|---|---|");
    let cases: [(&str, &str, usize, f64); 3] = [
        ("spheres", "Sphere(radius: 0.5)", 16, 0.5),
        ("cubes", "Cuboid(a: 0.5, b: 0.5, c: 0.5)", 10, 0.5),
        (
            "ellipsoids 2.5:0.5:0.5",
            "Ellipsoid(a: 2.5, b: 0.5, c: 0.5)",
            10,
            0.5,
        ),
    ];
    for (name, spelling, n, target) in cases {
        let n = if quick { n * 3 / 4 } else { n };
        let shape: Shape = spelling.parse().unwrap();
        let start = dilute_start(&[shape], n, 3).unwrap();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let (mut a_sweeps, mut b_steps, mut b_valid) = (0, None, true);
        for _ in 0..rounds {
            let row = timed("reference", &start, target).unwrap();
            a.push(row.seconds);
            a_sweeps = row.sweeps;
            let (theirs, valid) = match &shape {
                Shape::Sphere(_) => theirs_spheres(&start, target),
                Shape::Cuboid(_) => theirs_bodies(
                    &start,
                    target,
                    Convex(Hypercuboid {
                        edge_lengths: [pos(1.0), pos(1.0), pos(1.0)],
                    }),
                    3f64.sqrt(),
                ),
                _ => theirs_bodies(
                    &start,
                    target,
                    Convex(Hyperellipsoid::with_semi_axes([
                        pos(2.5),
                        pos(0.5),
                        pos(0.5),
                    ])),
                    5.0,
                ),
            };
            b_valid &= valid;
            match theirs {
                Some((s, steps)) => {
                    b.push(s);
                    b_steps = Some(steps);
                }
                None => b_steps = None,
            }
        }
        let ours_s = median(a);
        match (b_steps, b.is_empty()) {
            (Some(steps), false) => {
                let theirs_s = median(b);
                println!(
                    "| {name} | {} | {target} | {ours_s:.2} ({a_sweeps}) | {theirs_s:.2} ({steps}) | {:.1} | {} |",
                    start.len(),
                    theirs_s / ours_s,
                    if b_valid { "yes" } else { "no" }
                );
            }
            _ => println!(
                "| {name} | {} | {target} | {ours_s:.2} ({a_sweeps}) | not done in {MAX_STEPS} steps | – | – |",
                start.len()
            ),
        }
    }
}
