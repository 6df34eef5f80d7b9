//! Pairs with a spherocylinder. With another spherocylinder or a sphere
//! the overlap test is exact in closed form: the bodies are the points
//! within their radii of a segment (or a point), so they overlap when the
//! segments come closer than the sum of the radii. With any other body,
//! GJK on the support mappings (a spherocylinder's is its segment's end
//! plus the sphere's), the signed distance deciding where GJK cannot. The
//! signed distance is GJK/EPA's for every pair.

use super::convex;
use crate::geometry::capsule::{closest_segment_parameters, segment_distance_squared};
use crate::geometry::contact::{Method, Status};
use crate::geometry::{Contact, DistanceOptions, Relative, Shape};

type V3 = nalgebra::Vector3<f64>;

/// The axis segment (half-length) and radius of a sphere or a
/// spherocylinder: a sphere is a segment of length 0.
fn swept_segment(shape: &Shape) -> Option<(f64, f64)> {
    match shape {
        Shape::Spherocylinder(s) => Some((s.half_length(), s.radius())),
        Shape::Sphere(s) => Some((0.0, s.radius())),
        _ => None,
    }
}

/// Whether `a` and `b` overlap (touching counts); one of them is a
/// spherocylinder.
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    if let (Some((la, ra)), Some((lb, rb))) = (swept_segment(a), swept_segment(b)) {
        let axis_b: V3 = rel.rotation.column(2).into();
        let reach = ra + rb;
        return segment_distance_squared(&rel.translation, &V3::z(), la, &axis_b, lb)
            <= reach * reach;
    }
    match convex::intersect(a, b, rel, 200) {
        Some(overlapping) => overlapping,
        // Within rounding of touching: the distance decides (a failed one,
        // NaN, counts as overlap: no move is accepted on an undecided test).
        None => super::strains::settle(distance(a, b, rel, &DistanceOptions::default()).distance),
    }
}

/// Signed distance, contact points and normal of `a` and `b`, one of them a
/// spherocylinder: in closed form with another spherocylinder or a sphere
/// (the closest points of the axis segments, each pushed out by its
/// radius), else GJK apart and EPA overlapping.
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    let (Some((la, ra)), Some((lb, rb))) = (swept_segment(a), swept_segment(b)) else {
        return convex::distance(a, b, rel, opts);
    };
    let axis_b: V3 = rel.rotation.column(2).into();
    let (on_a, on_b) = closest_on_segments(&rel.translation, la, &axis_b, lb);
    let w = on_b - on_a;
    let len = w.norm();
    // Axes that cross: any direction across A's axis is a normal.
    let normal = if len > 0.0 { w / len } else { V3::x() };
    Contact {
        distance: len - ra - rb,
        point_a: on_a + normal * ra,
        point_b: on_b - normal * rb,
        normal,
        status: Status::Converged { iterations: 0 },
        method: Method::Analytic,
        warm_start: None,
    }
}

/// The closest points (A's frame) of A's axis segment ±ℓ₁ e_z and B's,
/// `d` ± ℓ₂ `v`.
fn closest_on_segments(d: &V3, l1: f64, v: &V3, l2: f64) -> (V3, V3) {
    let (s, t) = closest_segment_parameters(d, &V3::z(), l1, v, l2);
    (V3::new(0.0, 0.0, s), d + v * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pair::overlap_by_gjk;
    use nalgebra::{UnitQuaternion, Vector3};

    /// The closed-form test against GJK on the support mappings alone, and
    /// the signed distance's sign against both, for spherocylinders with
    /// each other and with spheres, at random poses bisected to within
    /// 1e-6 of touching and at random separations either side.
    #[test]
    fn the_segment_test_agrees_with_gjk_and_the_distance() {
        let mut u = crate::test_support::uniform(17);
        let shapes: Vec<Shape> = [
            "Spherocylinder(radius: 0.5, length: 2.0)",
            "Spherocylinder(radius: 0.2, length: 3.0)",
            "Sphere(radius: 0.6)",
        ]
        .iter()
        .map(|t| t.parse().unwrap())
        .collect();
        let mut checked = 0;
        for _ in 0..3000 {
            let (a, b) = (&shapes[(u() * 2.0) as usize], &shapes[(u() * 3.0) as usize]);
            let q = |u: &mut dyn FnMut() -> f64| {
                UnitQuaternion::from_euler_angles(u() * 6.3, u() * 6.3, u() * 6.3)
            };
            let (qa, qb) = (q(&mut u), q(&mut u));
            let dir = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
            let at = |d: f64| Relative::new(&(dir * d), &qa, &qb);
            let (mut lo, mut hi) = (0.0, a.bounding_radius() + b.bounding_radius());
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if overlap(a, b, &at(mid)) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            for d in [lo * (1.0 - 1e-6), hi * (1.0 + 1e-6), u() * hi * 1.5] {
                let rel = at(d);
                let ours = overlap(a, b, &rel);
                if let Some(gjk) = overlap_by_gjk(a, b, &rel) {
                    assert_eq!(ours, gjk, "{a} / {b} at {d}");
                    checked += 1;
                }
                let contact = distance(a, b, &rel, &DistanceOptions::default());
                assert_eq!(
                    ours,
                    contact.distance <= 0.0,
                    "{a} / {b} at {d}: {contact:?}"
                );
            }
        }
        assert!(checked > 8000, "{checked}");
    }
}
