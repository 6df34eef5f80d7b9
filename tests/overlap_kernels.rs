//! Every overlap kernel against an independent method, on random pairs and on
//! pairs within 1e-6 of contact; symmetric in argument order; consistent with
//! the sign of the distance kernel; invariant under a common rigid motion and
//! under periodic images.

mod common;

use common::*;
use hardbody::geometry::{DistanceOptions, Relative, Shape, distance, overlap};
use hardbody::space::PeriodicBox;
use rand::Rng;
use rayon::prelude::*;

/// Random pairs per pair type, and as many again placed within 1e-6 of
/// contact (5×10⁴ + 5×10⁴ by default; `HARDBODY_KERNEL_CASES` overrides).
fn cases() -> u64 {
    std::env::var("HARDBODY_KERNEL_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(50_000)
}

/// One case: shapes, placement and, for near-contact cases, the exact
/// signed distance (positive: apart by exactly that much; negative: overlapping).
fn case(
    ka: Kind,
    kb: Kind,
    tag: u64,
    i: u64,
    random_cases: u64,
) -> (Shape, Shape, Relative, Option<f64>) {
    let mut r = rng(tag, i);
    let a = random_shape(ka, &mut r);
    let b = random_shape(kb, &mut r);
    let q = random_rotation(&mut r);
    let u = random_unit(&mut r);
    if i < random_cases {
        let reach = a.bounding_radius() + b.bounding_radius();
        let s = r.r#gen::<f64>() * reach * 1.05;
        (a, b, placed(&u, s, &q), None)
    } else {
        // Touching with a random common normal, then moved by 1e-8..1e-6 of
        // the size along it: the distance is exactly delta.
        let len = a.min_half_extent().min(b.min_half_extent());
        let mag = len * 10f64.powf(-8.0 + 2.0 * r.r#gen::<f64>());
        let delta = if r.r#gen::<bool>() { mag } else { -mag };
        (a, b, touching(&a, &b, &q, &u, delta), Some(delta))
    }
}

fn check_pair(ka: Kind, kb: Kind, tag: u64) {
    let opts = DistanceOptions::default();
    let n = cases();
    let failures: Vec<String> = (0..2 * n)
        .into_par_iter()
        .filter_map(|i| {
            let (a, b, rel, known) = case(ka, kb, tag, i, n);
            let k = overlap(&a, &b, &rel);
            let mut why = Vec::new();
            if overlap(&b, &a, &rel.inverse()) != k {
                why.push("not symmetric in argument order".to_string());
            }
            match reference_overlap(&a, &b, &rel) {
                Some(x) if x != k => why.push(format!("kernel {k}, reference {x}")),
                None => why.push("reference undecided".into()),
                _ => {}
            }
            let c = distance(&a, &b, &rel, &opts, None);
            if let Some(delta) = known {
                if (delta < 0.0) != k {
                    why.push(format!("kernel {k} at exact signed distance {delta:e}"));
                }
                let len = a.min_half_extent().min(b.min_half_extent());
                if delta > 0.0 && (c.distance - delta).abs() > 1e-9 * len {
                    why.push(format!(
                        "distance {:e} ({:?}, {:?}), exact {delta:e}",
                        c.distance, c.status, c.method
                    ));
                }
            }
            if (c.distance <= 0.0) != k {
                why.push(format!(
                    "distance {:e} ({:?}) disagrees with overlap {k}",
                    c.distance, c.status
                ));
            }
            if !k && !c.is_converged() {
                why.push(format!("separated pair, distance status {:?}", c.status));
            }
            let c2 = distance(&b, &a, &rel.inverse(), &opts, None);
            if (c2.distance <= 0.0) != k {
                why.push(format!(
                    "swapped distance {:e} ({:?}) disagrees",
                    c2.distance, c2.status
                ));
            }
            (!why.is_empty()).then(|| {
                format!(
                    "case {i}: {a} / {b} at {:?}: {}",
                    rel.translation,
                    why.join("; ")
                )
            })
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{ka:?}-{kb:?}: {} of {} cases fail; first ones:\n{}",
        failures.len(),
        2 * n,
        failures
            .iter()
            .take(8)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn sphere_sphere() {
    check_pair(Kind::Sphere, Kind::Sphere, 1);
}
#[test]
fn sphere_ellipsoid() {
    check_pair(Kind::Sphere, Kind::Ellipsoid, 2);
}
#[test]
fn sphere_superellipsoid() {
    check_pair(Kind::Sphere, Kind::Superellipsoid, 3);
}
#[test]
fn cuboid_sphere() {
    check_pair(Kind::Cuboid, Kind::Sphere, 4);
}
#[test]
fn ellipsoid_ellipsoid() {
    check_pair(Kind::Ellipsoid, Kind::Ellipsoid, 5);
}
#[test]
fn ellipsoid_superellipsoid() {
    check_pair(Kind::Ellipsoid, Kind::Superellipsoid, 6);
}
#[test]
fn cuboid_ellipsoid() {
    check_pair(Kind::Cuboid, Kind::Ellipsoid, 7);
}
#[test]
fn superellipsoid_superellipsoid() {
    check_pair(Kind::Superellipsoid, Kind::Superellipsoid, 8);
}
#[test]
fn cuboid_superellipsoid() {
    check_pair(Kind::Cuboid, Kind::Superellipsoid, 9);
}
#[test]
fn cuboid_cuboid() {
    check_pair(Kind::Cuboid, Kind::Cuboid, 10);
}

/// A common rotation and translation of both bodies, and periodic images of
/// B, leave every overlap answer unchanged.
#[test]
fn invariant_under_rigid_motion_and_periodic_images() {
    let box_ = PeriodicBox::new(nalgebra::Vector3::new(7.0, 8.0, 9.0)).unwrap();
    for (ia, &ka) in KINDS.iter().enumerate() {
        for &kb in &KINDS[ia..] {
            let bad: Vec<String> = (0..4000u64)
                .into_par_iter()
                .filter_map(|i| {
                    let mut r = rng(77, i);
                    let a = random_shape(ka, &mut r);
                    let b = random_shape(kb, &mut r);
                    let (qa, qb) = (random_rotation(&mut r), random_rotation(&mut r));
                    let ra = V3::new(r.r#gen(), r.r#gen(), r.r#gen()) * 3.0;
                    let reach = a.bounding_radius() + b.bounding_radius();
                    let rb = ra + random_unit(&mut r) * reach * r.r#gen::<f64>();
                    let base = overlap(&a, &b, &Relative::new(&(rb - ra), &qa, &qb));
                    // Common rigid motion.
                    let g = random_rotation(&mut r);
                    let shift = V3::new(r.r#gen(), r.r#gen(), r.r#gen()) * 10.0;
                    let (ra2, rb2) = (g * ra + shift, g * rb + shift);
                    let moved = overlap(&a, &b, &Relative::new(&(rb2 - ra2), &(g * qa), &(g * qb)));
                    // B replaced by a periodic image, A wrapped into the box.
                    let image = rb + V3::new(7.0 * 2.0, -8.0, 9.0 * 3.0);
                    let d = box_.minimum_image(&(image - box_.wrap(&ra)));
                    let periodic = overlap(&a, &b, &Relative::new(&d, &qa, &qb));
                    (moved != base || periodic != base).then(|| format!("{ka:?}-{kb:?} case {i}"))
                })
                .collect();
            assert!(bad.is_empty(), "{bad:?}");
        }
    }
}
