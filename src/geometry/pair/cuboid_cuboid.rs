//! Cuboid–cuboid: the 15-axis separating-axis test for overlap; GJK for the
//! distance of separated cuboids (finite for polytopes) and the largest
//! axis separation (the exact penetration depth) for overlapping ones.

use super::convex;
use super::{Contact, DistanceOptions, Method, Relative, Status};
use nalgebra::Vector3;

use crate::geometry::obb::{SeparatingFeature, boxes_overlap, max_axis_separation_with_feature};
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

/// Signed distance of two cuboids. Overlapping, touching, or apart by
/// less than the separating-axis guard, the depth (or gap) along the axis
/// of largest separation, with the contact points of the features that
/// define it (a vertex on a face, or two edges), which is what a collision
/// acts on; farther apart, GJK.
pub fn distance(a: &Cuboid, b: &Cuboid, rel: &Relative, opts: &DistanceOptions) -> Contact {
    if overlap(a, b, rel) {
        let (ha, hb) = (a.half_extents(), b.half_extents());
        let (sep, axis, feature) =
            max_axis_separation_with_feature(&ha, &hb, &rel.rotation, &rel.translation);
        if sep > 0.0 {
            // Apart, within the guard of the overlap test: GJK's witness
            // points are exact here.
            let g = convex::distance(&Shape::Cuboid(*a), &Shape::Cuboid(*b), rel, opts);
            if g.is_converged() && g.distance > 0.0 {
                return g;
            }
        }
        let (point_a, point_b) = feature_points(&ha, &hb, rel, sep, &axis, feature);
        return Contact {
            distance: sep,
            point_a,
            point_b,
            normal: axis,
            status: Status::Converged { iterations: 0 },
            method: Method::SeparatingAxes,
            warm_start: None,
        };
    }
    convex::distance(&Shape::Cuboid(*a), &Shape::Cuboid(*b), rel, opts)
}

/// The contact points of boxes touching (or slightly overlapping) along
/// `axis` (A → B): B's deepest vertex and its projection on A's face, A's
/// deepest vertex and its projection on B's face, or the closest points of
/// the two edges.
fn feature_points(
    ha: &Vector3<f64>,
    hb: &Vector3<f64>,
    rel: &Relative,
    sep: f64,
    axis: &Vector3<f64>,
    feature: SeparatingFeature,
) -> (Vector3<f64>, Vector3<f64>) {
    let box_a = Shape::Cuboid(Cuboid::new(ha.x, ha.y, ha.z).expect("valid"));
    let box_b = Shape::Cuboid(Cuboid::new(hb.x, hb.y, hb.z).expect("valid"));
    let vertex_a = box_a.support(axis);
    let vertex_b = rel.b_to_a(&box_b.support(&rel.rotation.tr_mul(&-axis)));
    match feature {
        SeparatingFeature::FaceA(_) => (vertex_b - axis * sep, vertex_b),
        SeparatingFeature::FaceB(_) => (vertex_a, vertex_a + axis * sep),
        SeparatingFeature::Edges(i, j) => {
            // A's edge along e_i through vertex_a, B's along R e_j through
            // vertex_b; closest points of the two lines, kept on the edges.
            let u = Vector3::ith(i, 1.0);
            let v = rel.rotation.column(j).into_owned();
            let w = vertex_a - vertex_b;
            let (uv, uw, vw) = (u.dot(&v), u.dot(&w), v.dot(&w));
            let denom = 1.0 - uv * uv;
            let (s, t) = if denom > 1e-12 {
                ((uv * vw - uw) / denom, (vw - uv * uw) / denom)
            } else {
                (0.0, 0.0)
            };
            // Parameters measured from the support vertices, which sit at
            // one end of each edge (±h along the edge).
            let clamp = |x: f64, from: f64, h: f64| (from + x).clamp(-h, h) - from;
            let s = clamp(s, vertex_a[i], ha[i]);
            let local_b = rel.rotation.tr_mul(&(vertex_b - rel.translation));
            let t = clamp(t, local_b[j], hb[j]);
            (vertex_a + u * s, vertex_b + v * t)
        }
    }
}
