//! Cuboid–cuboid: the 15-axis separating-axis test for overlap; GJK for the
//! distance of separated cuboids (finite for polytopes) and the largest
//! axis separation (the exact penetration depth) for overlapping ones.

use super::convex;
use super::{Contact, DistanceOptions, Method, Relative, Status};
use crate::geometry::obb::{boxes_overlap, max_axis_separation};
use crate::geometry::shape::{Cuboid, Shape};

/// Separating-axis test in A's frame.
#[inline]
pub fn overlap(a: &Cuboid, b: &Cuboid, rel: &Relative) -> bool {
    boxes_overlap(
        &a.half_extents(),
        &b.half_extents(),
        &rel.rotation,
        &rel.translation,
    )
}

/// Signed distance of two cuboids.
pub fn distance(a: &Cuboid, b: &Cuboid, rel: &Relative, opts: &DistanceOptions) -> Contact {
    if overlap(a, b, rel) {
        let (sep, axis) = max_axis_separation(
            &a.half_extents(),
            &b.half_extents(),
            &rel.rotation,
            &rel.translation,
        );
        // Deepest points along the axis.
        let sa = Shape::Cuboid(*a).support(&axis);
        let sb = rel.b_to_a(&Shape::Cuboid(*b).support(&rel.rotation.tr_mul(&-axis)));
        return Contact {
            distance: sep.min(0.0),
            point_a: sa,
            point_b: sb,
            normal: axis,
            status: Status::Converged { iterations: 0 },
            method: Method::SeparatingAxes,
            warm_start: None,
        };
    }
    convex::distance(&Shape::Cuboid(*a), &Shape::Cuboid(*b), rel, opts)
}
