//! Cuboid–ellipsoid and cuboid–superellipsoid: exact convex methods on
//! support points. A is the cuboid, B the smooth body.

use super::convex;
use super::{Contact, DistanceOptions, Relative};
use crate::geometry::shape::Shape;

/// GJK overlap: a separating plane or an enclosing simplex is a certificate;
/// when neither is found the bodies are within rounding of touching, which
/// counts as overlap.
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    convex::intersect(a, b, rel, 200).unwrap_or(true)
}

/// GJK distance (separated) or EPA penetration depth (overlapping).
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    convex::distance(a, b, rel, opts)
}
