//! Sphere–sphere: closed form.

use nalgebra::Vector3;

use super::{Contact, Method, Relative, Status};
use crate::geometry::shape::Sphere;

/// Overlap iff |r_AB| ≤ R_A + R_B (frame: see the module docs of `pair`).
#[inline]
pub fn overlap(a: &Sphere, b: &Sphere, rel: &Relative) -> bool {
    let reach = a.radius() + b.radius();
    rel.translation.norm_squared() <= reach * reach
}

/// Signed distance |r_AB| − R_A − R_B, with the points on the centre line.
pub fn distance(a: &Sphere, b: &Sphere, rel: &Relative) -> Contact {
    let r = rel.translation;
    let len = r.norm();
    let normal = if len > 0.0 { r / len } else { Vector3::x() };
    Contact {
        distance: len - a.radius() - b.radius(),
        point_a: normal * a.radius(),
        point_b: r - normal * b.radius(),
        normal,
        status: Status::Converged { iterations: 0 },
        method: Method::Analytic,
        warm_start: None,
    }
}
