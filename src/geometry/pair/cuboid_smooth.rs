//! Cuboid–ellipsoid and cuboid–superellipsoid: exact convex methods on
//! support points. A is the cuboid, B the smooth body.

use nalgebra::Vector3;

use super::convex;
use super::{Contact, DistanceOptions, Relative};
use crate::geometry::shape::Shape;

/// Overlap: first the six face axes (the cuboid's and B's principal axes)
/// as candidate separating axes, and the two centre-inside tests, all exact
/// certificates; then GJK, where a separating plane or an enclosing simplex
/// is a certificate too. When GJK cannot decide the bodies are within
/// rounding of touching, which counts as overlap.
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let half = a.obb_half_extents();
    let t = rel.translation;
    let r = &rel.rotation;
    // Both bodies are centrally symmetric: an axis n separates them iff
    // |t·n| > h_A(n) + h_B(n), h the support function.
    let h_b = |n: &Vector3<f64>| {
        let local = r.tr_mul(n);
        b.support(&local).dot(&local)
    };
    for i in 0..3 {
        let n = Vector3::ith(i, 1.0);
        if t[i].abs() > half[i] + h_b(&n) {
            return false;
        }
    }
    let semi = b.obb_half_extents();
    for j in 0..3 {
        let n = r.column(j);
        let h_a = half.x * n.x.abs() + half.y * n.y.abs() + half.z * n.z.abs();
        if t.dot(&n).abs() > h_a + semi[j] {
            return false;
        }
    }
    if (0..3).all(|i| t[i].abs() <= half[i]) {
        return true; // B's centre is inside the cuboid
    }
    convex::intersect(a, b, rel, 200).unwrap_or(true)
}

/// GJK distance (separated) or EPA penetration depth (overlapping).
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    convex::distance(a, b, rel, opts)
}
