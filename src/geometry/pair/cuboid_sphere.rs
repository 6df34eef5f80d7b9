//! Cuboid–sphere: OCSI (Tonti & Patti, Algorithm 5) for overlap and its exact
//! distance (eq. 2) for contact. A is the cuboid, B the sphere.

use nalgebra::Matrix3;

use super::{Contact, Method, Relative, Status};
use crate::geometry::ocsi::{ocsi, point_box_distance};
use crate::geometry::shape::{Cuboid, Sphere};

/// OCSI in the cuboid's frame (its axes are the identity there).
#[inline]
pub fn overlap(a: &Cuboid, b: &Sphere, rel: &Relative) -> bool {
    ocsi(
        &rel.translation,
        b.radius(),
        &Matrix3::identity(),
        &a.half_extents(),
    )
}

/// Signed distance: the exact point–box distance of the sphere centre (eq. 2,
/// negative inside the box) minus the radius. The normal is the direction
/// from the closest box point to the centre (outside) or the outward normal
/// of the nearest face (inside).
pub fn distance(a: &Cuboid, b: &Sphere, rel: &Relative) -> Contact {
    let c = rel.translation;
    let half = a.half_extents();
    let (d, on_box) = point_box_distance(&c, &half);
    let normal = if d > 0.0 {
        (c - on_box) / d
    } else {
        // Inside: outward normal of the nearest face.
        let i = (c.abs() - half).imax();
        let mut n = nalgebra::Vector3::zeros();
        n[i] = 1f64.copysign(c[i]);
        n
    };
    Contact {
        distance: d - b.radius(),
        point_a: on_box,
        point_b: c - normal * b.radius(),
        normal,
        status: Status::Converged { iterations: 0 },
        method: Method::Ocsi,
        warm_start: None,
    }
}
