//! Hard convex polyhedra in Monte Carlo: a dense fluid of tetrahedra
//! stays overlap-free by an independent separating-axis test, and a cube
//! given by its eight corners has the equation of state of the cuboid of
//! the same size (the scale-distribution pressure in NVT, and the density
//! NPT settles at under that pressure); spheropolyhedra of a vanishing
//! core are hard spheres, and rounded cubes settle in NPT at the density
//! their NVT pressure was measured at.

mod common;

use common::compressed_state;
use hardbody::geometry::{Polyhedron, Shape};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

type V3 = Vector3<f64>;

const TETRAHEDRON: &str = "ConvexPolyhedron(vertices: [(0.5, 0.5, 0.5), (0.5, -0.5, -0.5), \
                           (-0.5, 0.5, -0.5), (-0.5, -0.5, 0.5)])";

/// Whether two polyhedra (hulls turned by `ra`, `rb` and placed at 0 and
/// `d`) overlap, by the separating axes of convex polyhedra: the face
/// normals of each and the cross products of their edges; touching counts
/// as overlap.
fn sat_overlap(
    p: &Polyhedron,
    ra: &Matrix3<f64>,
    q: &Polyhedron,
    rb: &Matrix3<f64>,
    d: &V3,
) -> bool {
    let a: Vec<V3> = p.vertices().iter().map(|v| ra * v).collect();
    let b: Vec<V3> = q.vertices().iter().map(|v| rb * v + d).collect();
    let edges = |h: &Polyhedron, r: &Matrix3<f64>| -> Vec<V3> {
        (h.edges().iter())
            .map(|&(i, j)| r * (h.vertices()[j] - h.vertices()[i]))
            .collect()
    };
    let mut axes: Vec<V3> = (p.faces().iter().map(|f| ra * f.normal))
        .chain(q.faces().iter().map(|f| rb * f.normal))
        .collect();
    for e in edges(p, ra) {
        for g in edges(q, rb) {
            if let Some(n) = e.cross(&g).try_normalize(1e-12) {
                axes.push(n);
            }
        }
    }
    let range = |points: &[V3], n: &V3| {
        (points.iter().map(|v| v.dot(n))).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        })
    };
    !axes.iter().any(|n| {
        let ((a0, a1), (b0, b1)) = (range(&a, n), range(&b, n));
        a1 < b0 || b1 < a0
    })
}

#[test]
fn a_dense_fluid_of_tetrahedra_stays_overlap_free() {
    let mut system = compressed_state(&[TETRAHEDRON], 6, 0.45, 3);
    let mut rng = Pcg64::seed_from_u64(4);
    let sizes = MoveSizes {
        translate: 0.05,
        rotate: 0.1,
        volume: 0.0,
        shear: 0.0,
    };
    let mut accepted = hardbody::mc::moves::Counts::default();
    for _ in 0..300 {
        accepted += sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
    }
    assert!(accepted.translate.rate() > 0.05, "{accepted:?}");
    assert!(accepted.rotate.rate() > 0.05, "{accepted:?}");
    let Shape::ConvexPolyhedron(tetra) = system.species()[0].shape else {
        unreachable!("one species of tetrahedra")
    };
    let hull = tetra.hull();
    // The oracle and the library's overlap agree on random pairs (those
    // within 1e-9 of touching aside), overlapping and apart alike.
    let mut u = Pcg64::seed_from_u64(9);
    let mut agreed = [0; 2];
    for _ in 0..3000 {
        use rand::Rng;
        let turn = |u: &mut Pcg64| {
            nalgebra::UnitQuaternion::from_euler_angles(
                u.r#gen::<f64>() * 6.3,
                u.r#gen::<f64>() * 6.3,
                u.r#gen::<f64>() * 6.3,
            )
        };
        let (qa, qb) = (turn(&mut u), turn(&mut u));
        let d = V3::from_fn(|_, _| (u.r#gen::<f64>() - 0.5) * 2.0);
        let rel = hardbody::geometry::Relative::new(&d, &qa, &qb);
        let shape = &system.species()[0].shape;
        let gap = hardbody::geometry::distance(shape, shape, &rel, &Default::default(), None);
        if gap.distance.abs() < 1e-9 {
            continue;
        }
        let (ra, rb) = (
            qa.to_rotation_matrix().into_inner(),
            qb.to_rotation_matrix().into_inner(),
        );
        let oracle = sat_overlap(hull, &ra, hull, &rb, &d);
        assert_eq!(
            oracle,
            hardbody::geometry::overlap(shape, shape, &rel),
            "at {d}"
        );
        agreed[usize::from(oracle)] += 1;
    }
    assert!(agreed[0] > 300 && agreed[1] > 300, "{agreed:?}");
    let (box_, particles) = (system.periodic_box(), system.particles());
    let mut near = 0;
    for (i, a) in particles.iter().enumerate() {
        for b in &particles[i + 1..] {
            let d = box_.minimum_image(&(b.position - a.position));
            if d.norm() > 2.0 * hull.circumradius() {
                continue;
            }
            near += 1;
            let (ra, rb) = (
                a.orientation.to_rotation_matrix().into_inner(),
                b.orientation.to_rotation_matrix().into_inner(),
            );
            assert!(
                !sat_overlap(hull, &ra, hull, &rb, &d),
                "bodies overlap at {d}"
            );
        }
    }
    assert!(near > 500, "{near} pairs within reach");
}

/// The averages of `wanted` (stage index, observable) over two replicas of
/// 125 bodies of `shape` run through `stages`: mean, error, whether both
/// equilibrated.
fn averages(
    shape: &str,
    seed: u64,
    stages: &str,
    wanted: &[(usize, &str)],
) -> Vec<(f64, f64, bool)> {
    averages_every(shape, seed, stages, wanted, 50)
}

/// [`averages`] with the observables measured every `every` sweeps.
fn averages_every(
    shape: &str,
    seed: u64,
    stages: &str,
    wanted: &[(usize, &str)],
    every: usize,
) -> Vec<(f64, f64, bool)> {
    let scene = |replica: u64| {
        format!(
            r#"Scene(
    seed: {},
    box: (12.0, 12.0, 12.0),
    species: [Species(name: "cube", shape: {shape}, count: 125)],
    stages: [{stages}],
    log: Log(path: "unused.mcap", stats_every: {every}, frames_every: 1000000),
)"#,
            seed + replica
        )
    };
    common::replica_averages("polyhedra", scene, wanted)
}

/// A unit cube as a `ConvexPolyhedron` of its corners and as a `Cuboid`:
/// the same scale-distribution pressure in NVT at φ = 0.45 within three
/// combined errors, and NPT at the cuboid's pressure settles at the same
/// density for both. (With the same seeds, as here, the two runs are one
/// Markov chain as long as GJK and the separating axes decide every trial
/// alike: the averages then agree to the bit.)
#[test]
fn a_cube_of_corners_has_the_cuboids_equation_of_state() {
    let corners = "ConvexPolyhedron(vertices: [(0.5, 0.5, 0.5), (0.5, 0.5, -0.5), \
                   (0.5, -0.5, 0.5), (0.5, -0.5, -0.5), (-0.5, 0.5, 0.5), (-0.5, 0.5, -0.5), \
                   (-0.5, -0.5, 0.5), (-0.5, -0.5, -0.5)])";
    let cuboid = "Cuboid(a: 0.5, b: 0.5, c: 0.5)";
    let phi = 0.45;
    let nvt = format!(
        "Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: 2000), \
         MonteCarlo(ensemble: Nvt, sweeps: 8000)"
    );
    let [(p_cube, e_cube, ok_cube)] = averages(cuboid, 60, &nvt, &[(2, "pressure")])[..] else {
        unreachable!()
    };
    let [(p_poly, e_poly, ok_poly)] = averages(corners, 60, &nvt, &[(2, "pressure")])[..] else {
        unreachable!()
    };
    assert!(ok_cube && ok_poly, "not equilibrated");
    assert!(
        (p_cube - p_poly).abs() < 3.0 * e_cube.hypot(e_poly),
        "cuboid {p_cube} ± {e_cube}, polyhedron {p_poly} ± {e_poly}"
    );
    let npt = format!(
        "Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Npt(pressure: {p_cube}), sweeps: 8000)"
    );
    let [(phi_cube, f_cube, _)] = averages(cuboid, 80, &npt, &[(1, "packing_fraction")])[..] else {
        unreachable!()
    };
    let [(phi_poly, f_poly, _)] = averages(corners, 80, &npt, &[(1, "packing_fraction")])[..]
    else {
        unreachable!()
    };
    assert!(
        (phi_cube - phi_poly).abs() < 3.0 * f_cube.hypot(f_poly),
        "at betaP {p_cube}: cuboid phi {phi_cube} ± {f_cube}, polyhedron {phi_poly} ± {f_poly}"
    );
    eprintln!(
        "betaP: cuboid {p_cube:.4} ± {e_cube:.4}, polyhedron {p_poly:.4} ± {e_poly:.4}; \
         NPT phi: {phi_cube:.4} ± {f_cube:.4}, {phi_poly:.4} ± {f_poly:.4}"
    );
}

/// A spheropolyhedron whose core is a speck (a tetrahedron of edge
/// 2√2 × 10⁻⁴) swept by a ball of radius ½ is a hard sphere of diameter 1
/// to within 10⁻⁴: its scale-distribution pressure at φ = 0.35 is the
/// sphere kernel's on the same scene within three combined errors, and
/// Carnahan–Starling's within three errors and 1 % (N = 125).
#[test]
fn a_spheropolyhedron_of_a_vanishing_core_is_a_hard_sphere() {
    let speck = "Spheropolyhedron(vertices: [(1e-4, 1e-4, 1e-4), (1e-4, -1e-4, -1e-4), \
                 (-1e-4, 1e-4, -1e-4), (-1e-4, -1e-4, 1e-4)], radius: 0.5)";
    let sphere = "Sphere(radius: 0.5)";
    let phi: f64 = 0.35;
    let nvt = format!(
        "Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: 1000), \
         MonteCarlo(ensemble: Nvt, sweeps: 16000)"
    );
    let [(p_speck, e_speck, ok_speck)] =
        averages_every(speck, 70, &nvt, &[(2, "pressure")], 20)[..]
    else {
        unreachable!()
    };
    let [(p_sphere, e_sphere, ok_sphere)] =
        averages_every(sphere, 70, &nvt, &[(2, "pressure")], 20)[..]
    else {
        unreachable!()
    };
    assert!(ok_speck && ok_sphere, "not equilibrated");
    assert!(
        (p_speck - p_sphere).abs() < 3.0 * e_speck.hypot(e_sphere),
        "spheropolyhedron {p_speck} ± {e_speck}, sphere {p_sphere} ± {e_sphere}"
    );
    let rho = phi / (std::f64::consts::PI / 6.0);
    let carnahan_starling = rho * (1.0 + phi + phi * phi - phi.powi(3)) / (1.0 - phi).powi(3);
    assert!(
        (p_speck - carnahan_starling).abs() < 3.0 * e_speck + 0.01 * carnahan_starling,
        "spheropolyhedron {p_speck} ± {e_speck}, Carnahan-Starling {carnahan_starling}"
    );
    eprintln!(
        "betaP at phi {phi}: spheropolyhedron {p_speck:.4} ± {e_speck:.4}, sphere {p_sphere:.4} ± {e_sphere:.4}, CS {carnahan_starling:.4}"
    );
}

/// Rounded cubes (a unit cube swept by 0.15): the NPT density at the
/// scale-distribution pressure measured in NVT at φ = 0.4 is that φ within
/// three errors (two routes to one point of the equation of state, through
/// the overlap test, the scale-distribution bound and the volume moves).
#[test]
fn rounded_cubes_hold_their_density_at_their_own_pressure() {
    let rounded = "Spheropolyhedron(vertices: [(0.5, 0.5, 0.5), (0.5, 0.5, -0.5), \
                   (0.5, -0.5, 0.5), (0.5, -0.5, -0.5), (-0.5, 0.5, 0.5), (-0.5, 0.5, -0.5), \
                   (-0.5, -0.5, 0.5), (-0.5, -0.5, -0.5)], radius: 0.15)";
    let phi = 0.4;
    let nvt = format!(
        "Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: 1000), \
         MonteCarlo(ensemble: Nvt, sweeps: 8000)"
    );
    let [(p, e, ok)] = averages_every(rounded, 90, &nvt, &[(2, "pressure")], 20)[..] else {
        unreachable!()
    };
    assert!(ok, "not equilibrated");
    let npt = format!(
        "Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Npt(pressure: {p}), sweeps: 6000)"
    );
    let [(phi_npt, f, _)] = averages_every(rounded, 91, &npt, &[(1, "packing_fraction")], 20)[..]
    else {
        unreachable!()
    };
    // The pressure's own error moves the density too: dφ = φ/(βP) dβP/Z'
    // is below φ e/p for a fluid (compressibility below the ideal gas's).
    let spread = f.hypot(phi * e / p);
    assert!(
        (phi_npt - phi).abs() < 3.0 * spread,
        "at betaP {p} ± {e}: NPT phi {phi_npt} ± {f}, NVT phi {phi}"
    );
    eprintln!("rounded cubes: betaP {p:.4} ± {e:.4} at phi {phi}; NPT phi {phi_npt:.4} ± {f:.4}");
}
