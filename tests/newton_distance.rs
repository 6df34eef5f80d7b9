//! De Michele's Newton–Raphson distance: converges for ellipsoids of aspect
//! 0.1–10 and superellipsoids with exponents up to 8 from a cold start, in
//! both systems of equations, to the exact distance of configurations built
//! in contact and moved apart by a known amount; handles nearly touching,
//! nearly parallel needles and disks, tip-to-side and slight overlaps; and
//! beyond its range reports non-convergence rather than a wrong distance.

mod common;

use common::*;
use hardbody::geometry::implicit::SmoothSurface;
use hardbody::geometry::newton::{NewtonOptions, NewtonSystem, SteepestDescent, newton_distance};
use hardbody::geometry::{Contact, Ellipsoid, Relative, Shape, Superellipsoid};
use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;
use rayon::prelude::*;

fn solve(a: &Shape, b: &Shape, rel: &Relative, opts: &NewtonOptions) -> Contact {
    fn with_b<A: SmoothSurface>(a: &A, b: &Shape, rel: &Relative, o: &NewtonOptions) -> Contact {
        match b {
            Shape::Sphere(y) => newton_distance(a, y, rel, o, None),
            Shape::Ellipsoid(y) => newton_distance(a, y, rel, o, None),
            Shape::Superellipsoid(y) => newton_distance(a, y, rel, o, None),
            Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => {
                unreachable!()
            }
        }
    }
    match a {
        Shape::Sphere(x) => with_b(x, b, rel, opts),
        Shape::Ellipsoid(x) => with_b(x, b, rel, opts),
        Shape::Superellipsoid(x) => with_b(x, b, rel, opts),
        Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => unreachable!(),
    }
}

fn systems() -> [NewtonOptions; 2] {
    let full = NewtonOptions {
        system: NewtonSystem::Full8,
        ..NewtonOptions::default()
    };
    [NewtonOptions::default(), full]
}

/// Spheroid of aspect ratio `x0` (symmetry axis / other axes), smaller
/// axes 0.5.
fn spheroid(x0: f64) -> Shape {
    Shape::Ellipsoid(Ellipsoid::new(0.5, 0.5, 0.5 * x0).unwrap())
}

fn superellipsoid(x0: f64, p: f64) -> Shape {
    Shape::Superellipsoid(Superellipsoid::new(0.5 * x0, 0.5, 0.5, (2.0, 2.0, p)).unwrap())
}

/// Random configurations at exact distances 1e-10 .. 2 (in units of the
/// smallest semi-axis); returns the cases that did not converge to the exact
/// distance within `tol` (relative to the smallest semi-axis).
fn sweep(
    a: &Shape,
    b: &Shape,
    cases: u64,
    tag: u64,
    opts: &NewtonOptions,
    tol: f64,
) -> Vec<String> {
    let len = a.min_half_extent().min(b.min_half_extent());
    (0..cases)
        .into_par_iter()
        .filter_map(|i| {
            let mut r = rng(tag, i);
            let q = random_rotation(&mut r);
            let n = random_unit(&mut r);
            let delta = len * 10f64.powf(-10.0 + 10.3 * r.r#gen::<f64>());
            let rel = touching(a, b, &q, &n, delta);
            let c = solve(a, b, &rel, opts);
            let ok = c.is_converged() && (c.distance - delta).abs() <= tol * len.max(delta);
            (!ok).then(|| {
                format!(
                    "case {i}: delta {delta:e}, got {:e} ({:?})",
                    c.distance, c.status
                )
            })
        })
        .collect()
}

#[test]
fn ellipsoids_of_aspect_0_1_to_10_converge_from_a_cold_start() {
    for (k, &x0) in [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0].iter().enumerate() {
        let s = spheroid(x0);
        for opts in systems() {
            let bad = sweep(&s, &s, 3000, 100 + k as u64, &opts, 1e-9);
            assert!(
                bad.is_empty(),
                "aspect {x0}, {:?}: {} failures: {:?}",
                opts.system,
                bad.len(),
                &bad[..bad.len().min(5)]
            );
        }
    }
    // Unlike pairs: a needle against a disk, a sphere against a needle.
    let pairs = [
        (spheroid(10.0), spheroid(0.1)),
        (spheroid(1.0), spheroid(10.0)),
    ];
    for (k, (a, b)) in pairs.iter().enumerate() {
        let bad = sweep(a, b, 3000, 200 + k as u64, &NewtonOptions::default(), 1e-9);
        assert!(
            bad.is_empty(),
            "{a} / {b}: {} failures: {:?}",
            bad.len(),
            &bad[..bad.len().min(5)]
        );
    }
}

#[test]
fn superellipsoids_with_exponents_up_to_8_converge_from_a_cold_start() {
    for (k, &p) in [2.5, 3.0, 4.0, 6.0, 8.0].iter().enumerate() {
        for &x0 in &[0.5, 1.0, 2.0] {
            let s = superellipsoid(x0, p);
            let bad = sweep(
                &s,
                &s,
                2000,
                300 + k as u64,
                &NewtonOptions::default(),
                1e-9,
            );
            assert!(
                bad.is_empty(),
                "p = {p}, X0 = {x0}: {} failures: {:?}",
                bad.len(),
                &bad[..bad.len().min(5)]
            );
        }
    }
}

/// Far beyond the range (exponent 40, aspect 40): whatever does not converge
/// says so; whatever claims convergence is right.
#[test]
fn beyond_the_range_failures_are_reported_never_wrong() {
    let hard = [
        superellipsoid(1.0, 40.0),
        spheroid(40.0),
        superellipsoid(4.0, 20.0),
    ];
    for (k, s) in hard.iter().enumerate() {
        let len = s.min_half_extent();
        let wrong: Vec<String> = (0..2000u64)
            .into_par_iter()
            .filter_map(|i| {
                let mut r = rng(400 + k as u64, i);
                let q = random_rotation(&mut r);
                let n = random_unit(&mut r);
                let delta = len * 10f64.powf(-8.0 + 8.0 * r.r#gen::<f64>());
                let rel = touching(s, s, &q, &n, delta);
                let opts = NewtonOptions {
                    steepest_descent: SteepestDescent::Never,
                    ..NewtonOptions::default()
                };
                let c = solve(s, s, &rel, &opts);
                (c.is_converged() && (c.distance - delta).abs() > 1e-8 * len.max(delta))
                    .then(|| format!("case {i}: exact {delta:e}, claimed {:e}", c.distance))
            })
            .collect();
        assert!(
            wrong.is_empty(),
            "{s}: wrong distances reported as converged: {wrong:?}"
        );
    }
}

/// Specific hard configurations, each at exact distances from 1e-10 down
/// to slight overlaps.
#[test]
fn needles_disks_tips_and_slight_overlaps() {
    let needle = spheroid(10.0); // long axis along body z
    let disk = spheroid(0.1); // short axis along body z
    let tilt = |angle: f64| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), angle);
    type Case<'s> = (
        &'static str,
        &'s Shape,
        &'s Shape,
        UnitQuaternion<f64>,
        Vector3<f64>,
    );
    let cases: Vec<Case> = vec![
        // Side by side, nearly parallel (B turned by 1e-6 rad).
        (
            "parallel needles",
            &needle,
            &needle,
            tilt(1e-6),
            Vector3::x(),
        ),
        (
            "exactly parallel needles",
            &needle,
            &needle,
            tilt(0.0),
            Vector3::x(),
        ),
        // Stacked face to face, nearly parallel.
        ("parallel disks", &disk, &disk, tilt(1e-6), Vector3::z()),
        // Tip of A against the side of B (B turned 90°).
        (
            "tip to side",
            &needle,
            &needle,
            tilt(std::f64::consts::FRAC_PI_2),
            Vector3::z(),
        ),
        // Rim of a disk against the face of another.
        (
            "rim to face",
            &disk,
            &disk,
            tilt(std::f64::consts::FRAC_PI_2),
            Vector3::z(),
        ),
    ];
    let len = 0.05;
    for (name, a, b, q, n) in cases {
        for opts in systems() {
            for &delta in &[1.0, 1e-2, 1e-6, 1e-10, -1e-10, -1e-6, -1e-3] {
                let d = delta * len;
                let rel = touching(a, b, &q, &n, d);
                let c = solve(a, b, &rel, &opts);
                assert!(
                    c.is_converged() && (c.distance - d).abs() <= 1e-9 * len,
                    "{name}, {:?}, exact distance {d:e}: got {:e} ({:?})",
                    opts.system,
                    c.distance,
                    c.status
                );
                // The contact normal is the construction's.
                assert!(
                    (c.normal - n).norm() < 1e-6,
                    "{name}: normal {:?}",
                    c.normal
                );
            }
        }
    }
}

/// A warm start from the previous solution converges in fewer iterations
/// after a small move.
#[test]
fn warm_start_saves_iterations() {
    let s = spheroid(3.0);
    let mut cold_total = 0;
    let mut warm_total = 0;
    for i in 0..200u64 {
        let mut r = rng(500, i);
        let q = random_rotation(&mut r);
        let n = random_unit(&mut r);
        let rel = touching(&s, &s, &q, &n, 0.1);
        let Shape::Ellipsoid(e) = s else {
            unreachable!()
        };
        let first = newton_distance(&e, &e, &rel, &NewtonOptions::default(), None);
        let moved = Relative {
            translation: rel.translation * 0.999,
            rotation: rel.rotation,
        };
        let cold = newton_distance(&e, &e, &moved, &NewtonOptions::default(), None);
        let warm = newton_distance(
            &e,
            &e,
            &moved,
            &NewtonOptions::default(),
            first.warm_start.as_ref(),
        );
        assert!(warm.is_converged() && (warm.distance - cold.distance).abs() < 1e-12);
        let it = |c: &Contact| match c.status {
            hardbody::geometry::Status::Converged { iterations } => iterations,
            _ => unreachable!(),
        };
        cold_total += it(&cold);
        warm_total += it(&warm);
    }
    assert!(
        warm_total * 2 < cold_total,
        "warm {warm_total} vs cold {cold_total} iterations"
    );
}
