//! Every distance kernel against exact distances: bodies placed touching at
//! their support points along a random common normal, then moved apart by a
//! known δ (1e-10 to 1 of the size), so the distance is exactly δ and the
//! normal is the construction's. Slight overlaps (δ < 0) give negative
//! distances: exactly δ where the method defines the distance along the
//! common normal (Newton's β < 0 solution, OCSI), and an overlap (d < 0) for
//! the minimum-translation methods (SAT depth, EPA). Oriented bounding boxes
//! hold their bodies.

mod common;

use common::*;
use hardbody::geometry::pair::distance_lower_bound;
use hardbody::geometry::{DistanceOptions, Method, Obb, Shape, distance, overlap};
use nalgebra::Vector3;
use rand::Rng;
use rayon::prelude::*;

fn check(ka: Kind, kb: Kind, tag: u64) {
    let opts = DistanceOptions::default();
    let bad: Vec<String> = (0..4000u64)
        .into_par_iter()
        .filter_map(|i| {
            let mut r = rng(tag, i);
            let a = random_shape(ka, &mut r);
            let b = random_shape(kb, &mut r);
            let q = random_rotation(&mut r);
            let n = random_unit(&mut r);
            let len = a.min_half_extent().min(b.min_half_extent());
            let apart = i % 4 != 0;
            let delta = if apart {
                len * 10f64.powf(-10.0 + 10.0 * r.r#gen::<f64>())
            } else {
                -len * 10f64.powf(-8.0 + 5.0 * r.r#gen::<f64>())
            };
            let rel = touching(&a, &b, &q, &n, delta);
            let c = distance(&a, &b, &rel, &opts, None);
            let mut why = Vec::new();
            // The cheap lower bound the dynamics steps with never exceeds the
            // exact distance.
            // Overlapping, it must not be positive (its negative values are
            // not a depth).
            let (bound, _) = distance_lower_bound(&a, &b, &rel);
            if bound > delta.max(0.0) + 1e-12 * len {
                why.push(format!(
                    "lower bound {bound:e} above the distance {delta:e}"
                ));
            }
            if apart {
                if !c.is_converged() || (c.distance - delta).abs() > 1e-9 * len.max(delta) {
                    why.push(format!(
                        "distance {:e} ({:?}, {:?}) for exact {delta:e}",
                        c.distance, c.status, c.method
                    ));
                }
                let gap = c.point_b - c.point_a;
                if ((gap.norm() - c.distance).abs() > 1e-9 * len.max(delta))
                    || (c.normal.dot(&gap) - c.distance).abs() > 1e-9 * len.max(delta)
                {
                    why.push(format!(
                        "points {:?} / {:?} and normal {:?} do not span the distance",
                        c.point_a, c.point_b, c.normal
                    ));
                }
                // The normal is the construction's wherever it is unique
                // (the support point along n is a single point for smooth
                // bodies; cuboid contacts may touch along an edge or face).
                if delta > 1e-6 * len
                    && !matches!(c.method, Method::Gjk)
                    && (c.normal - n).norm() > 1e-6
                {
                    why.push(format!("normal {:?}, construction {:?}", c.normal, n));
                }
            } else {
                let exact = matches!(c.method, Method::Newton | Method::Ocsi | Method::Analytic);
                if c.distance >= 0.0 || (exact && (c.distance - delta).abs() > 1e-9 * len) {
                    why.push(format!(
                        "overlap by {delta:e}: distance {:e} ({:?}, {:?})",
                        c.distance, c.status, c.method
                    ));
                }
                if !overlap(&a, &b, &rel) {
                    why.push("overlap kernel says apart".into());
                }
            }
            (!why.is_empty()).then(|| format!("case {i}: {a} / {b}: {}", why.join("; ")))
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{ka:?}-{kb:?}: {} failures, first: {:#?}",
        bad.len(),
        &bad[..bad.len().min(6)]
    );
}

#[test]
fn every_pair_distance_is_exact() {
    for (ia, &ka) in KINDS.iter().enumerate() {
        for (ib, &kb) in KINDS[ia..].iter().enumerate() {
            check(ka, kb, 1000 + 10 * ia as u64 + ib as u64);
            check(kb, ka, 2000 + 10 * ia as u64 + ib as u64);
        }
    }
}

/// The tight OBB holds the body: every support point lies inside it, and a
/// pair that overlaps has overlapping OBBs (what neighbour lists rely on).
#[test]
fn oriented_bounding_boxes_hold_their_bodies() {
    for (ia, &ka) in KINDS.iter().enumerate() {
        for &kb in &KINDS[ia..] {
            for i in 0..3000u64 {
                let mut r = rng(3000, i);
                let a = random_shape(ka, &mut r);
                let b = random_shape(kb, &mut r);
                let (qa, qb) = (random_rotation(&mut r), random_rotation(&mut r));
                let ra = Vector3::new(r.r#gen(), r.r#gen(), r.r#gen());
                let rb = ra
                    + random_unit(&mut r)
                        * (a.bounding_radius() + b.bounding_radius())
                        * r.r#gen::<f64>();
                let oa = Obb::of_shape(&a, ra, qa.to_rotation_matrix().into_inner(), 0.0);
                let ob = Obb::of_shape(&b, rb, qb.to_rotation_matrix().into_inner(), 0.0);
                let rel = hardbody::geometry::Relative::new(&(rb - ra), &qa, &qb);
                if overlap(&a, &b, &rel) {
                    assert!(
                        oa.overlaps(&ob) && ob.overlaps(&oa),
                        "{a} / {b}: bodies overlap, OBBs do not"
                    );
                }
                let d = random_unit(&mut r);
                let p = a.support(&d);
                let h = a.obb_half_extents();
                assert!(
                    (0..3).all(|k| p[k].abs() <= h[k] * (1.0 + 1e-12)),
                    "{a}: support point outside its OBB"
                );
                assert!(
                    p.norm() <= a.bounding_radius() * (1.0 + 1e-12),
                    "{a}: support point outside its bounding sphere"
                );
            }
        }
    }
}

#[test]
fn shapes_parse_and_report_bad_input_by_name() {
    let bad = [
        ("Ellipsoid(a: 1.0, b: 0.0, c: 1.0)", "b"),
        (
            "Superellipsoid(a: 1.0, b: 1.0, c: 1.0, exponents: (2.0, 1.0, 2.0))",
            "exponent m",
        ),
        ("Cuboid(a: 1.0, b: 1.0)", "c"),
        ("Sphere(r: 1.0)", "r"),
    ];
    for (text, needle) in bad {
        let err = text.parse::<Shape>().unwrap_err().to_string();
        assert!(err.contains(needle), "{text}: {err}");
    }
}
