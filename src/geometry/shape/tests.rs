//! The shapes' unit tests: closed forms against quadrature and sampling.

use super::*;
use crate::geometry::roots::solve_power_sum;
use std::f64::consts::PI;

/// One body of each kind, the ellipsoids prolate-ish and flat, the
/// polyhedron irregular.
const SHAPES: [&str; 9] = [
    "Sphere(radius: 0.7)",
    "Ellipsoid(a: 1.3, b: 0.7, c: 0.4)",
    "Ellipsoid(a: 0.2, b: 2.0, c: 2.0)",
    "Superellipsoid(a: 1.0, b: 0.6, c: 0.3, exponents: (4.0, 4.0, 4.0))",
    "Cuboid(a: 1.0, b: 0.6, c: 0.3)",
    "Spherocylinder(radius: 0.4, length: 1.5)",
    "ConvexPolyhedron(vertices: [(1.0, 0.1, 0.0), (-0.6, 0.5, 0.2), (-0.4, -0.7, 0.1), (0.1, 0.2, 0.8), (0.0, -0.1, -0.6)])",
    "Tetrahedron(edge: 1.2)",
    "Spheropolyhedron(vertices: [(0.5, 0.4, 0.3), (-0.5, 0.4, 0.3), (0.5, -0.4, 0.3), (-0.5, -0.4, 0.3), (0.0, 0.0, -0.6)], radius: 0.15)",
];

/// The support value of a body turning at a constant body-frame ω
/// (u(τ) = u₀ rotated by −ωτ) stays under both bounds of
/// `support_growth` over several turns, and the quadratic bound is
/// tight at the start (value and slope are h and ḣ there).
#[test]
fn support_growth_bounds_a_turning_body() {
    use nalgebra::UnitQuaternion;
    let mut r = crate::test_support::uniform(12);
    let mut unit = || Vector3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
    for text in SHAPES {
        let shape: Shape = text.parse().unwrap();
        for case in 0..200 {
            // Every fourth direction along an axis or a face diagonal
            // (components exactly zero: a cuboid's support value has
            // a kink there, as after a face contact in a lattice).
            let u0 = match case % 8 {
                0 => Vector3::new(0.0, 0.0, -1.0),
                4 => Vector3::new(1.0, -1.0, 0.0).normalize(),
                _ => unit(),
            };
            let omega = unit() * (0.1 + 3.0 * (case as f64 / 200.0));
            let w = omega.norm();
            let u_dot = u0.cross(&omega);
            let g = shape.support_growth(&u0, &u_dot, w, w * w);
            let h = |tau: f64| {
                let u = UnitQuaternion::from_scaled_axis(-omega * tau) * u0;
                shape.support(&u).dot(&u)
            };
            assert!((g.value - h(0.0)).abs() < 1e-12, "{text}: value");
            let mut slack_near_start = f64::INFINITY;
            for k in 1..=2000 {
                let tau = k as f64 * 3.0 / (w * 2000.0);
                let exact = h(tau);
                let kinks: f64 = g
                    .kinks
                    .iter()
                    .map(|&(w, c, r)| w * ((c + r * tau).abs() - c.abs()))
                    .sum();
                let quadratic = g.value + g.slope * tau + kinks + 0.5 * g.curvature * tau * tau;
                let linear = g.value + g.lipschitz * tau;
                assert!(
                    exact <= quadratic + 1e-12,
                    "{text}: quadratic bound at τ = {tau}"
                );
                assert!(exact <= linear + 1e-12, "{text}: linear bound at τ = {tau}");
                if k == 1 {
                    slack_near_start = quadratic.min(linear) - exact;
                }
            }
            // Tight to first order: after one step of 1/2000 turn the
            // bound is above h by O(step²) (O(step) for the Lipschitz
            // bound of a superellipsoid).
            let step = 3.0 / 2000.0;
            assert!(
                slack_near_start <= 2.0 * step * shape.moment_arm().max(1e-3) + 1e-12,
                "{text}: slack {slack_near_start:e}"
            );
        }
    }
}

/// The moment arm bounds |x × n| over the surface, sampled densely,
/// and is attained for ellipsoids (within the sampling).
#[test]
fn moment_arm_bounds_the_surface_and_is_tight_for_ellipsoids() {
    use crate::geometry::implicit::SmoothSurface;
    let mut u = crate::test_support::uniform(11);
    for text in SHAPES {
        let shape: Shape = text.parse().unwrap();
        let mut largest: f64 = 0.0;
        for _ in 0..20_000 {
            let dir = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            // A surface point and its normal: the support point along
            // `dir` has normal `dir`.
            let x = shape.support(&dir);
            let n = match &shape {
                Shape::Superellipsoid(q) => q.implicit(&x).gradient.normalize(),
                // At a vertex every direction of the octant is a normal.
                _ => dir.normalize(),
            };
            largest = largest.max(x.cross(&n).norm());
        }
        assert!(largest <= shape.moment_arm() + 1e-12, "{text}: {largest}");
        if let Shape::Ellipsoid(_) | Shape::Sphere(_) | Shape::Cuboid(_) = shape {
            assert!(
                largest > 0.97 * shape.moment_arm() - 1e-12,
                "{text}: {largest}"
            );
        }
    }
}

#[test]
fn invalid_sizes_are_errors() {
    assert!(Sphere::new(0.0).is_err());
    assert!(Ellipsoid::new(1.0, -1.0, 1.0).is_err());
    assert!(Cuboid::new(1.0, 1.0, f64::NAN).is_err());
    assert!(matches!(
        Superellipsoid::new(1.0, 1.0, 1.0, (2.0, 1.5, 2.0)),
        Err(ShapeError::BadExponent { field: "m", .. })
    ));
}

#[test]
fn parses_scene_spelling_and_round_trips() {
    let s: Shape = "Cuboid(a: 0.5, b: 1.0, c: 1.5)".parse().unwrap();
    assert_eq!(s, Shape::Cuboid(Cuboid::new(0.5, 1.0, 1.5).unwrap()));
    let q: Shape = "Superellipsoid(a: 1.0, b: 0.5, c: 0.5, exponents: (2.0, 4.0, 8.0))"
        .parse()
        .unwrap();
    assert_eq!(q.to_string().parse::<Shape>().unwrap(), q);
    let err = "Sphere(radius: -1.0)".parse::<Shape>().unwrap_err();
    assert!(err.to_string().contains("radius"), "{err}");
    assert!("Sphere(radius: 1.0, colour: 2)".parse::<Shape>().is_err());
    // A named solid is written by its name, and is the polyhedron of its
    // corners.
    let t: Shape = "Tetrahedron(edge: 1.5)".parse().unwrap();
    assert_eq!(t.to_string(), "Tetrahedron(edge:1.5)");
    assert_eq!(t.to_string().parse::<Shape>().unwrap(), t);
    assert!((t.volume() - 1.5f64.powi(3) / (6.0 * 2f64.sqrt())).abs() < 1e-12);
    let err = "Octahedron(edge: -1.0)".parse::<Shape>().unwrap_err();
    assert!(err.to_string().contains("edge"), "{err}");
}

/// A shape grown chunk by chunk (scaled again and again) is, to the
/// bit, the shape read back from a record of it: a jam resumed from
/// a frame sees the bounding radius the run saw. (Scaling the cached
/// radius instead differs in its last bit for most factors.)
#[test]
fn a_grown_shape_is_the_shape_its_record_reads_back_to() {
    for text in SHAPES {
        let mut grown: Shape = text.parse().unwrap();
        for k in 0..40 {
            grown = grown.scaled(1.0 + 0.013 * (k as f64 + 0.37).sin().abs());
            let record = serde_json::to_string(&grown).unwrap();
            let read: Shape = serde_json::from_str(&record).unwrap();
            assert_eq!(read, grown, "{text} after {k} scalings");
        }
    }
}

#[test]
fn superellipsoid_with_exponent_two_is_the_ellipsoid() {
    let q = Shape::Superellipsoid(Superellipsoid::new(1.0, 2.0, 3.0, (2.0, 2.0, 2.0)).unwrap());
    let e = Shape::Ellipsoid(Ellipsoid::new(1.0, 2.0, 3.0).unwrap());
    assert!((q.volume() - e.volume()).abs() < 1e-12 * e.volume());
    assert!((q.inertia_tensor(1.0) - e.inertia_tensor(1.0)).norm() < 1e-12);
    assert!((q.bounding_radius() - 3.0).abs() < 1e-8);
    let d = Vector3::new(0.3, -0.7, 0.2);
    assert!((q.support(&d) - e.support(&d)).norm() < 1e-12);
}

#[test]
fn volumes_and_inertia_match_closed_forms() {
    let s = Shape::Sphere(Sphere::new(2.0).unwrap());
    assert!((s.volume() - 32.0 / 3.0 * PI).abs() < 1e-12);
    // Solid sphere: I = 2/5 m r².
    assert!((s.inertia_tensor(3.0)[(0, 0)] - 0.4 * 3.0 * 4.0).abs() < 1e-12);
    let c = Shape::Cuboid(Cuboid::new(0.5, 1.0, 1.5).unwrap());
    assert!((c.volume() - 6.0).abs() < 1e-12);
    // Box of sides 1, 2, 3: Ixx = m (2² + 3²)/12.
    assert!((c.inertia_tensor(1.0)[(0, 0)] - 13.0 / 12.0).abs() < 1e-12);
    // Large exponents tend to the box.
    let q =
        Shape::Superellipsoid(Superellipsoid::new(0.5, 1.0, 1.5, (400.0, 400.0, 400.0)).unwrap());
    assert!((q.volume() / 6.0 - 1.0).abs() < 0.01);
    assert!((q.bounding_radius() / c.bounding_radius() - 1.0).abs() < 0.01);
}

/// A spherocylinder's volume and second moments against a Monte Carlo
/// integration over its bounding box (a point is inside when it lies
/// within the radius of the axis segment): the caps' offset terms of
/// the closed form are what this can catch.
#[test]
fn spherocylinder_volume_and_inertia_match_sampling() {
    let rod = Spherocylinder::new(0.4, 1.5).unwrap();
    let (r, h) = (rod.radius(), rod.half_length());
    let half = Vector3::new(r, r, r + h);
    let mut u = crate::test_support::uniform(29);
    let samples = 2_000_000;
    let (mut inside, mut moments) = (0_u64, Vector3::zeros());
    for _ in 0..samples {
        let x = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5).component_mul(&half) * 2.0;
        let on_axis = Vector3::new(0.0, 0.0, x.z.clamp(-h, h));
        if (x - on_axis).norm() <= r {
            inside += 1;
            moments += x.component_mul(&x);
        }
    }
    let cell = 8.0 * half.product() / samples as f64;
    let shape = Shape::Spherocylinder(rod);
    let volume = inside as f64 * cell;
    assert!((volume / shape.volume() - 1.0).abs() < 0.005, "{volume}");
    let expected = shape.second_moments();
    for k in 0..3 {
        let sampled = moments[k] * cell;
        assert!(
            (sampled / expected[k] - 1.0).abs() < 0.01,
            "axis {k}: sampled {sampled}, closed form {}",
            expected[k]
        );
    }
}

#[test]
fn superellipsoid_support_points_lie_on_the_surface_and_maximise() {
    for q in [
        Superellipsoid::new(1.0, 0.6, 0.3, (2.0, 4.0, 8.0)).unwrap(),
        Superellipsoid::new(1.0, 0.6, 0.3, (5.0, 5.0, 5.0)).unwrap(),
    ] {
        check_support(&q);
    }
}

fn check_support(q: &Superellipsoid) {
    let mut uniform = crate::test_support::uniform(12345);
    let mut next = || 2.0 * uniform() - 1.0;
    for _ in 0..200 {
        let d = Vector3::new(next(), next(), next());
        let x = q.support(&d);
        let f: f64 = (0..3)
            .map(|i| (x[i] / q.semi_axes[i]).abs().powf(q.exponents[i]))
            .sum();
        assert!((f - 1.0).abs() < 1e-10, "off surface: {f}");
        // No other surface point sampled goes further along d.
        for _ in 0..50 {
            let v = Vector3::new(next(), next(), next());
            let t = solve_power_sum(
                &Vector3::new(
                    (v.x / q.semi_axes.x).abs().powf(q.exponents.x),
                    (v.y / q.semi_axes.y).abs().powf(q.exponents.y),
                    (v.z / q.semi_axes.z).abs().powf(q.exponents.z),
                ),
                &q.exponents,
            );
            assert!((v * t).dot(&d) <= x.dot(&d) + 1e-12);
        }
    }
}

/// A body without a centre of symmetry reaches unevenly up and down: a
/// tetrahedron's extents along each lab axis are its corners' largest
/// and smallest coordinates there, turned or not, and the half-extents
/// the larger of the two.
#[test]
fn a_tetrahedron_reaches_unevenly_up_and_down() {
    use nalgebra::UnitQuaternion;
    let shape: Shape = "Tetrahedron(edge: 1.0)".parse().unwrap();
    let Shape::ConvexPolyhedron(p) = shape else {
        unreachable!()
    };
    let mut r = crate::test_support::uniform(19);
    let mut uneven = 0;
    for case in 0..100 {
        let q = if case == 0 {
            UnitQuaternion::identity()
        } else {
            UnitQuaternion::from_scaled_axis(Vector3::new(r(), r(), r()) * 6.0)
        };
        let rotation = q.to_rotation_matrix().into_inner();
        let (up, down) = shape.lab_extents(&rotation);
        let turned: Vec<Vector3<f64>> = p.corners().map(|v| rotation * v).collect();
        for k in 0..3 {
            let top = turned
                .iter()
                .map(|v| v[k])
                .fold(f64::NEG_INFINITY, f64::max);
            let bottom = turned.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min);
            assert!((up[k] - top).abs() < 1e-12 && (down[k] + bottom).abs() < 1e-12);
            assert_eq!(shape.lab_half_extents(&rotation)[k], up[k].max(down[k]));
            uneven += usize::from((up[k] - down[k]).abs() > 0.05);
        }
    }
    assert!(uneven > 100, "{uneven}");
}
