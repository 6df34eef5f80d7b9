//! Cuboid–cuboid: the 15-axis separating-axis test for overlap; for the
//! distance the largest axis separation, exact where its features face
//! each other (and for overlapping boxes: the penetration depth), GJK
//! elsewhere, with the closest features enumerated where GJK stalls
//! (nearly parallel edges a hair apart).

use super::convex;
use super::{Contact, DistanceOptions, Method, Relative, Status};
use nalgebra::Vector3;

use crate::geometry::obb::{SeparatingFeature, boxes_overlap, max_axis_separation_with_feature};
use crate::geometry::shape::{Cuboid, Shape, Support};

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

/// Signed distance of two cuboids. The largest separation over the 15
/// axes comes first: it is a lower bound on the distance of separated
/// boxes, and where the features that define it face each other (a vertex
/// over a face, two edges crossing inside both) their points are that far
/// apart, so it is the distance ([`facing_features`]: the common case of
/// a dense packing, faces nearly parallel, where GJK's simplices
/// degenerate). Overlapping, it is minus the penetration depth, with the
/// contact points of its features, which is what a collision acts on.
/// Otherwise GJK. Where two edges are nearly parallel their cross axis is
/// lost to rounding (an axis e × R of length ℓ carries an error of about
/// 1e-16/ℓ, and below ℓ = 1e-9 it is skipped), so near contact the axes
/// can call a pair apart by a hair overlapping: there the closest features
/// ([`closest_features`], exact for separated boxes) decide, confirmed by
/// a support plane normal to their gap.
pub fn distance(a: &Cuboid, b: &Cuboid, rel: &Relative, opts: &DistanceOptions) -> Contact {
    let (ha, hb) = (a.half_extents(), b.half_extents());
    let (sep, axis, feature) =
        max_axis_separation_with_feature(&ha, &hb, &rel.rotation, &rel.translation);
    let by_axes = |(point_a, point_b)| Contact {
        distance: sep,
        point_a,
        point_b,
        normal: axis,
        status: Status::Converged { iterations: 0 },
        method: Method::SeparatingAxes,
        warm_start: None,
    };
    // Lengths the rounding of the axes is measured against.
    let size = rel.translation.norm() + ha.max() + hb.max();
    if sep > 0.0
        && let Some(points) = facing_features(a, b, rel, sep, &axis, feature, size)
    {
        return by_axes(points);
    }
    if sep < -rounding_of_axes(rel, size) {
        // Overlapping beyond the error of any axis.
        return by_axes(feature_points(a, b, rel, sep, &axis, feature));
    }
    if overlap(a, b, rel) {
        let mut iterations = 0;
        if sep > 0.0 {
            // Apart, within the guard of the overlap test: GJK's witness
            // points are exact here.
            let g = gjk(a, b, rel, opts);
            if g.is_converged() && g.distance > 0.0 {
                return g;
            }
            iterations = g.iterations();
        }
        // A plane normal to the closest features' gap that separates the
        // boxes proves them apart, by the features' distance (the support
        // gap along a normal off by α falls short of it by O(α²) only,
        // inside the features' normal cones).
        let features = closest_features(&ha, &hb, rel, iterations);
        if features.distance > 0.0 && support_gap(&ha, &hb, rel, &features.normal) > 0.0 {
            return features;
        }
        let points = feature_points(a, b, rel, sep, &axis, feature);
        if let SeparatingFeature::Edges(i, j) = feature
            && let Some(depth) = crossed_edges(&ha, &hb, rel, &axis, &points, i, j)
        {
            return Contact {
                distance: depth,
                ..by_axes(points)
            };
        }
        return by_axes(points);
    }
    let g = gjk(a, b, rel, opts);
    match g.status {
        // Stalled short of the tolerance (its distance is only an upper
        // bound: 2.1e-9 for two nearly parallel edges 3.5e-12 apart, which
        // ended a 10^7-collision soak); the axis test has shown the boxes
        // apart, so their closest features decide.
        Status::IterationCap { iterations } | Status::Failed { iterations, .. } => {
            closest_features(&ha, &hb, rel, iterations)
        }
        _ => g,
    }
}

/// Two edges that have crossed by a hair, A's along axis `i` and B's
/// along its axis `j` (their closest points `points`, inside both edges):
/// their signed separation along `axis` (A → B), negative for the
/// crossing. Measured as [`closest_features`] measures two edges apart,
/// across A's edge in the plane normal to it, where it stays exact to
/// rounding of the size however parallel the edges are; the separation
/// along the edges' cross axis (SAT) carries a rounding error of about
/// 1e-16/ℓ for a cross product of length ℓ, and jumped by 10⁻¹¹ from one
/// pose to the next for edges 4×10⁻⁴ rad from parallel. `None` where the
/// closest points are not inside both edges.
fn crossed_edges(
    ha: &Vector3<f64>,
    hb: &Vector3<f64>,
    rel: &Relative,
    axis: &Vector3<f64>,
    (point_a, point_b): &(Vector3<f64>, Vector3<f64>),
    i: usize,
    j: usize,
) -> Option<f64> {
    let (k, l) = ((i + 1) % 3, (i + 2) % 3);
    let w = rel.rotation.column(j).into_owned();
    let across = (axis[k] * axis[k] + axis[l] * axis[l]).sqrt();
    if w[k] * w[k] + w[l] * w[l] == 0.0 || across == 0.0 {
        return None;
    }
    let corner = |x: f64, h: f64| if x < 0.0 { -h } else { h };
    let (ak, al) = (corner(point_a[k], ha[k]), corner(point_a[l], ha[l]));
    let (along, (gk, gl)) = across_edge(i, (ak, al), point_b, &w);
    let foot = point_b + w * along;
    let on_b = rel.rotation.tr_mul(&(foot - rel.translation));
    if foot[i].abs() > ha[i] || on_b[j].abs() > hb[j] {
        return None;
    }
    Some((gk * axis[k] + gl * axis[l]) / across)
}

/// Across A's edge along axis `i`, which is the point `corner` (its
/// coordinates i + 1, i + 2) in the plane normal to it: the foot of B's
/// edge line (through `on_b`, direction `w`, not parallel to the edge)
/// nearest to that point, as the step along `w` from `on_b`, and the gap
/// from A's edge to the foot there. A 2D point–line distance, exact to
/// rounding of the size however parallel the two edges are.
fn across_edge(
    i: usize,
    corner: (f64, f64),
    on_b: &Vector3<f64>,
    w: &Vector3<f64>,
) -> (f64, (f64, f64)) {
    let (k, l) = ((i + 1) % 3, (i + 2) % 3);
    let ww = w[k] * w[k] + w[l] * w[l];
    let (pk, pl) = (on_b[k] - corner.0, on_b[l] - corner.1);
    let along = -(pk * w[k] + pl * w[l]) / ww;
    (along, (pk + along * w[k], pl + along * w[l]))
}

/// GJK's distance, converged only where it proved it: stopped with its
/// distance and its lower bound within its tolerance. On two boxes whose
/// faces tie in the support map it can stop short (5.4e-9 for a corner
/// 1.6e-15 from an edge, its edge lying on the face to 3e-9 rad, which
/// ended a cube jam near βPV/N = 10⁷); that is an `IterationCap`.
fn gjk(a: &Cuboid, b: &Cuboid, rel: &Relative, opts: &DistanceOptions) -> Contact {
    let (g, short) = convex::distance_with_stall(&Shape::Cuboid(*a), &Shape::Cuboid(*b), rel, opts);
    match g.status {
        Status::Converged { iterations } if short => Contact {
            status: Status::IterationCap { iterations },
            ..g
        },
        _ => g,
    }
}

/// A bound on the rounding error of the separations along the 15 axes:
/// a few roundings of the pair's `size` for a face axis, divided by ℓ for
/// a cross axis e × R of length ℓ. An axis shorter than 1e-9 is skipped
/// (edges that parallel leave the face axes to stand in for it, to within
/// ℓ times the size), and then the bound is that of ℓ = 1e-9 for all.
/// Overlaps shallower than this are left to the closest features to judge
/// (see [`distance`]).
fn rounding_of_axes(rel: &Relative, size: f64) -> f64 {
    let r = &rel.rotation;
    let mut shortest_squared = f64::INFINITY;
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            shortest_squared =
                shortest_squared.min(r[(i1, j)] * r[(i1, j)] + r[(i2, j)] * r[(i2, j)]);
        }
    }
    64.0 * f64::EPSILON * size / shortest_squared.sqrt().max(1e-9)
}

/// Where the features that separate the boxes most along `axis` (by
/// `sep` > 0) face each other: a point of each box, `sep` apart to
/// rounding. The separation along any axis is a lower bound on the
/// distance and two points of the bodies give an upper bound, so then the
/// distance is `sep`. The points are the features' closest points pulled
/// onto the boxes (a vertex's foot outside the face it projects on, or an
/// edge's closest point beyond its end, moves, and the points then lie
/// farther apart than `sep`: not facing). Both bounds are exact to a few
/// roundings of the pair's `size`, and so is the distance returned. Cross
/// axes e × R of length ℓ < 0.1, whose separation carries a rounding error
/// of about 1e-16 size/ℓ, are left to GJK and the closest features.
fn facing_features(
    a: &Cuboid,
    b: &Cuboid,
    rel: &Relative,
    sep: f64,
    axis: &Vector3<f64>,
    feature: SeparatingFeature,
    size: f64,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    if let SeparatingFeature::Edges(i, j) = feature {
        let cosine = rel.rotation[(i, j)];
        if 1.0 - cosine * cosine < 1e-2 {
            return None;
        }
    }
    let (ha, hb) = (a.half_extents(), b.half_extents());
    let (point_a, point_b) = feature_points(a, b, rel, sep, axis, feature);
    let point_a = Vector3::from_fn(|k, _| point_a[k].clamp(-ha[k], ha[k]));
    let in_b = rel.rotation.tr_mul(&(point_b - rel.translation));
    let point_b = rel.b_to_a(&Vector3::from_fn(|k, _| in_b[k].clamp(-hb[k], hb[k])));
    let upper = (point_b - point_a).norm();
    (upper <= sep + 4.0 * f64::EPSILON * size).then_some((point_a, point_b))
}

/// n·t − h_A(n) − h_B(−n): the gap between the boxes' support planes
/// normal to `n` (A's frame); positive only if the plane separates them.
fn support_gap(ha: &Vector3<f64>, hb: &Vector3<f64>, rel: &Relative, n: &Vector3<f64>) -> f64 {
    let nb = rel.rotation.tr_mul(n);
    n.dot(&rel.translation) - ha.dot(&n.abs()) - hb.dot(&nb.abs())
}

/// The distance of two separated boxes (A axis-aligned at the origin with
/// half-extents `ha`, B placed by `rel` with `hb`) by enumerating the
/// features its closest points can lie on: a vertex of either box against
/// the other box (vertex–face, –edge, –vertex), or two edges with both
/// closest points inside them. Every term is a well-conditioned
/// projection (an edge of A is a coordinate axis: the edge–edge distance
/// is a 2D point–line distance across it), so the result is exact to
/// rounding even for edges parallel to 1e-12, where GJK's simplices
/// degenerate. About 160 small terms: a fallback, not the first resort.
fn closest_features(
    ha: &Vector3<f64>,
    hb: &Vector3<f64>,
    rel: &Relative,
    iterations: u32,
) -> Contact {
    let r = &rel.rotation;
    let t = &rel.translation;
    let corner = |h: &Vector3<f64>, k: usize| {
        Vector3::new(
            if k & 1 == 0 { -h.x } else { h.x },
            if k & 2 == 0 { -h.y } else { h.y },
            if k & 4 == 0 { -h.z } else { h.z },
        )
    };
    // (distance, point of A, point of B, normal A → B if exact, else None).
    let mut best = (f64::INFINITY, Vector3::zeros(), Vector3::zeros(), None);
    // A point against an axis-aligned box: its clamp; the normal is a face
    // normal when one coordinate is clamped.
    let against_box = |p: &Vector3<f64>, h: &Vector3<f64>| {
        let q = Vector3::from_fn(|i, _| p[i].clamp(-h[i], h[i]));
        let mut clamped = 0;
        let mut axis = 0;
        for i in 0..3 {
            if q[i] != p[i] {
                clamped += 1;
                axis = i;
            }
        }
        let normal = (clamped == 1).then(|| Vector3::ith(axis, (p[axis] - q[axis]).signum()));
        ((p - q).norm(), q, normal)
    };
    let inverse = rel.inverse();
    for k in 0..8 {
        // B's vertex against A.
        let vb = rel.b_to_a(&corner(hb, k));
        let (d, q, n) = against_box(&vb, ha);
        if d < best.0 {
            best = (d, q, vb, n);
        }
        // A's vertex against B (in B's frame, then back).
        let va = inverse.b_to_a(&corner(ha, k));
        let (d, q, n) = against_box(&va, hb);
        if d < best.0 {
            // The normal points from A to B: into B's face, so reversed.
            best = (d, rel.b_to_a(&va), rel.b_to_a(&q), n.map(|n| -(r * n)));
        }
    }
    // Edge pairs: A's edge along axis i at (±ha_j, ±ha_k), B's along its
    // axis m through its edge centre; across axis i the gap is the 2D
    // distance from A's edge (a point) to B's edge (a line).
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        for m in 0..3 {
            let w = r.column(m).into_owned();
            let w2 = (w[j], w[k]);
            let ww = w2.0 * w2.0 + w2.1 * w2.1;
            if ww == 0.0 {
                // Parallel: the vertex terms cover it.
                continue;
            }
            for eb in 0..4 {
                // B's edge centre: 0 along its axis m, ± the half-extents
                // across it.
                let (m1, m2) = ((m + 1) % 3, (m + 2) % 3);
                let mut cb = Vector3::zeros();
                cb[m1] = if eb & 1 == 0 { -hb[m1] } else { hb[m1] };
                cb[m2] = if eb & 2 == 0 { -hb[m2] } else { hb[m2] };
                let centre_b = rel.b_to_a(&cb);
                for ea in 0..4 {
                    let aj = if ea & 1 == 0 { -ha[j] } else { ha[j] };
                    let ak = if ea & 2 == 0 { -ha[k] } else { ha[k] };
                    let (along, (gj, gk)) = across_edge(i, (aj, ak), &centre_b, &w);
                    if along.abs() >= hb[m] {
                        continue;
                    }
                    let point_b = centre_b + w * along;
                    if point_b[i].abs() >= ha[i] {
                        continue;
                    }
                    let d = (gj * gj + gk * gk).sqrt();
                    if d < best.0 {
                        let mut point_a = Vector3::zeros();
                        point_a[i] = point_b[i];
                        point_a[j] = aj;
                        point_a[k] = ak;
                        // Normal to both edges, towards B.
                        let cross = Vector3::ith(i, 1.0).cross(&w);
                        let gap = point_b - point_a;
                        let normal = cross
                            .try_normalize(1e-6)
                            .map(|n| if n.dot(&gap) < 0.0 { -n } else { n });
                        best = (d, point_a, point_b, normal);
                    }
                }
            }
        }
    }
    let (distance, point_a, point_b, normal) = best;
    let normal = normal
        .or_else(|| (point_b - point_a).try_normalize(0.0))
        .unwrap_or_else(|| t.normalize());
    Contact {
        distance,
        point_a,
        point_b,
        normal,
        status: Status::Converged { iterations },
        method: Method::Features,
        warm_start: None,
    }
}

/// The contact points of boxes touching (or slightly overlapping) along
/// `axis` (A → B): B's deepest vertex and its projection on A's face, A's
/// deepest vertex and its projection on B's face, or the closest points of
/// the two edges.
fn feature_points(
    a: &Cuboid,
    b: &Cuboid,
    rel: &Relative,
    sep: f64,
    axis: &Vector3<f64>,
    feature: SeparatingFeature,
) -> (Vector3<f64>, Vector3<f64>) {
    let (ha, hb) = (a.half_extents(), b.half_extents());
    let vertex_a = a.support(axis);
    let vertex_b = rel.b_to_a(&b.support(&rel.rotation.tr_mul(&-axis)));
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// Half-extents uniform in [lo, 1).
    fn random_box(rng: &mut rand_pcg::Pcg64, lo: f64) -> Vector3<f64> {
        use rand::Rng;
        Vector3::from_fn(|_, _| rng.gen_range(lo..1.0))
    }

    /// A vector uniform in the cube [−1, 1)³.
    fn random_vector(rng: &mut rand_pcg::Pcg64) -> Vector3<f64> {
        use rand::Rng;
        Vector3::from_fn(|_, _| rng.gen_range(-1.0..1.0))
    }

    /// Two edges a hair apart, parallel or nearly so (the pose that ended
    /// a 10^7-collision cube soak: GJK stalled on it and gave 2.1e-9 for
    /// 3.5e-12): B's edge along z faces A's edge at the corner (h, h) across
    /// the diagonal n, at distance δ, turned by θ about n through its
    /// middle (the common perpendicular stays n, the distance δ). The
    /// distance is δ to rounding for every δ and θ, and so the contact
    /// points' gap; and the features' enumeration alone agrees with GJK
    /// where GJK converges, over random separated pairs.
    #[test]
    fn edges_a_hair_apart_give_their_exact_distance() {
        let (a, b) = (
            Cuboid::new(0.5, 0.5, 0.5).unwrap(),
            Cuboid::new(0.5, 0.5, 0.5).unwrap(),
        );
        let n = Vector3::new(1.0, 1.0, 0.0).normalize();
        let opts = DistanceOptions::default();
        for delta in [1e-13, 1e-12, 3.5e-12, 1e-11, 1e-9, 1e-6, 1e-3] {
            for theta in [0.0, 1e-13, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2] {
                let turn = UnitQuaternion::from_scaled_axis(n * theta);
                // B's edge (its corner (−h, −h) across z) at (h, h) + δ n.
                let edge = Vector3::new(0.5, 0.5, 0.0) + n * delta;
                let centre = edge + turn * Vector3::new(0.5, 0.5, 0.0);
                let rel = Relative::new(&centre, &UnitQuaternion::identity(), &turn);
                let c = distance(&a, &b, &rel, &opts);
                let err = (c.distance - delta).abs();
                assert!(
                    err <= 1e-15 + 1e-9 * delta,
                    "δ {delta:e}, θ {theta:e}: distance {:e} ({:?}, {:?})",
                    c.distance,
                    c.status,
                    c.method
                );
                assert!(c.is_converged());
                let gap = (c.point_b - c.point_a).norm();
                assert!((gap - delta).abs() <= 1e-15 + 1e-9 * delta, "gap {gap:e}");
                assert!(
                    (c.normal.dot(&n) - 1.0).abs() < 1e-6,
                    "normal {:?}",
                    c.normal
                );
                // Pushed in by δ instead: overlapping, never called apart
                // (the axes may overstate the depth, by at most θ h).
                let edge = Vector3::new(0.5, 0.5, 0.0) - n * delta;
                let centre = edge + turn * Vector3::new(0.5, 0.5, 0.0);
                let rel = Relative::new(&centre, &UnitQuaternion::identity(), &turn);
                let c = distance(&a, &b, &rel, &opts);
                assert!(
                    c.distance < 0.0 && c.distance >= -(delta + theta) - 1e-15,
                    "δ −{delta:e}, θ {theta:e}: distance {:e} ({:?})",
                    c.distance,
                    c.method
                );
            }
        }
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let mut compared = 0;
        for _ in 0..2000 {
            let (ha, hb) = (random_box(&mut rng, 0.1), random_box(&mut rng, 0.1));
            let turn = UnitQuaternion::from_scaled_axis(random_vector(&mut rng) * 3.0);
            let centre = Vector3::new(
                rng.gen_range(-2.5..2.5),
                rng.gen_range(-2.5..2.5),
                rng.gen_range(-2.5..2.5),
            );
            let rel = Relative::new(&centre, &UnitQuaternion::identity(), &turn);
            let (ca, cb) = (
                Cuboid::new(ha.x, ha.y, ha.z).unwrap(),
                Cuboid::new(hb.x, hb.y, hb.z).unwrap(),
            );
            if overlap(&ca, &cb, &rel) {
                continue;
            }
            let g = convex::distance(&Shape::Cuboid(ca), &Shape::Cuboid(cb), &rel, &opts);
            if !g.is_converged() {
                continue;
            }
            let f = closest_features(&ha, &hb, &rel, 0);
            assert!(
                (f.distance - g.distance).abs() < 1e-11,
                "features {:e}, GJK {:e}",
                f.distance,
                g.distance
            );
            assert!(((f.point_b - f.point_a).norm() - f.distance).abs() < 1e-12);
            compared += 1;
        }
        assert!(compared > 500, "{compared} separated pairs");
    }

    /// The largest axis separation, where its features face each other,
    /// is the distance: over boxes nearly aligned (a dense packing of
    /// cubes, where it takes over from GJK) and turned at random, apart by
    /// 1e-12 to 1, `distance` agrees with the closest features (the exact
    /// enumeration) to rounding, its points lie on the boxes that far
    /// apart, and the axes decide a good share of the pairs (the test
    /// fails if the path is never taken, or taken where it should not be).
    /// Pushed in by the gap, they overlap by at most the gap.
    #[test]
    fn facing_features_give_the_exact_distance() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let opts = DistanceOptions::default();
        let (mut by_axes, mut compared) = (0, 0);
        for case in 0..4000 {
            let (ha, hb) = (random_box(&mut rng, 0.2), random_box(&mut rng, 0.2));
            let spread = if case % 2 == 0 { 0.05 } else { 3.0 };
            let turn = UnitQuaternion::from_scaled_axis(random_vector(&mut rng) * spread);
            let direction = random_vector(&mut rng).normalize();
            // Slide B along the direction from the centre until the axes
            // say apart, then out by the gap.
            let gap = 10f64.powf(rng.gen_range(-12.0..0.0));
            let (a, b) = (
                Cuboid::new(ha.x, ha.y, ha.z).unwrap(),
                Cuboid::new(hb.x, hb.y, hb.z).unwrap(),
            );
            let at = |s: f64| Relative::new(&(direction * s), &UnitQuaternion::identity(), &turn);
            let (mut lo, mut hi) = (0.0, 4.0);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                let (sep, _, _) = max_axis_separation_with_feature(
                    &ha,
                    &hb,
                    &at(mid).rotation,
                    &at(mid).translation,
                );
                if sep > 0.0 { hi = mid } else { lo = mid }
            }
            let rel = at(hi + gap);
            let exact = closest_features(&ha, &hb, &rel, 0);
            let c = distance(&a, &b, &rel, &opts);
            let size = rel.translation.norm() + ha.max() + hb.max();
            assert!(
                (c.distance - exact.distance).abs() <= 1e-14 * size,
                "case {case}: {:e} by {:?}, closest features {:e}",
                c.distance,
                c.method,
                exact.distance
            );
            if c.method == Method::SeparatingAxes {
                by_axes += 1;
                // The points lie on the boxes, that far apart.
                // (To the rounding of a change of frame.)
                let inside = |p: &Vector3<f64>, h: &Vector3<f64>| {
                    (0..3).all(|k| p[k].abs() <= h[k] + 1e-15 * size)
                };
                assert!(inside(&c.point_a, &ha), "case {case}: {:?}", c.point_a);
                let in_b = rel.rotation.tr_mul(&(c.point_b - rel.translation));
                assert!(inside(&in_b, &hb), "case {case}: {in_b:?} in {hb:?}");
                let apart = (c.point_b - c.point_a).norm();
                assert!((apart - c.distance).abs() <= 1e-14 * size, "case {case}");
                assert!((c.normal.norm() - 1.0).abs() < 1e-12);
            }
            // Pushed in by the gap instead: overlapping (the centres' line
            // runs inside the boxes' Minkowski difference up to `hi`), by
            // at most the gap, never called apart, whether the axes judge
            // it or the closest features.
            if gap > 1e-10 {
                let c = distance(&a, &b, &at(hi - gap), &opts);
                assert!(
                    c.distance < 0.0 && c.distance >= -gap * (1.0 + 1e-9) - 1e-14 * size,
                    "case {case}: pushed in by {gap:e}, distance {:e} by {:?}",
                    c.distance,
                    c.method
                );
            }
            compared += 1;
        }
        assert_eq!(compared, 4000);
        // Nearly aligned boxes touch face to face or vertex to face most
        // of the time; turned at random, often by a vertex near an edge.
        assert!(
            by_axes > 2000 && by_axes < 4000,
            "{by_axes} of 4000 by the axes"
        );
    }

    /// The pose of the soak failure itself (cubes, φ = 0.5, 10^7
    /// collisions, particles 21 and 102 at t = 352.077, replayed from its
    /// dump): GJK stalled there and reported 2.1e-9 (an upper bound), the
    /// collision check refused it. The gap is 3.5148e-12, as a pose 1e-16
    /// away gave GJK when it converged.
    #[test]
    fn the_cube_soak_pose_has_its_exact_distance() {
        let cube = Cuboid::new(0.5, 0.5, 0.5).unwrap();
        let q = |x: f64, y: f64, z: f64, w: f64| {
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
        };
        let rel = Relative::new(
            &Vector3::new(
                -0.3994197800537145,
                0.24811469661290042,
                -0.8926867107150991,
            ),
            &q(
                -0.09073716957927351,
                -0.517844436595549,
                -0.2597338533393072,
                0.8100260680825623,
            ),
            &q(
                -0.22900489817198022,
                -0.06340452833214115,
                -0.4960664665815027,
                -0.8351375234855408,
            ),
        );
        let c = distance(&cube, &cube, &rel, &DistanceOptions::default());
        assert!(c.is_converged(), "{:?}", c.status);
        assert!((c.distance - 3.5148e-12).abs() < 1e-15, "{:e}", c.distance);
    }

    /// A cube's corner 1.6e-15 from another's edge, its edge lying on the
    /// other's face to 3e-9 rad (a pose that ended a cube jam near
    /// βPV/N = 10⁷): GJK stops there at 5.4e-9 and calls it converged; the
    /// distance is that of the closest features.
    #[test]
    fn a_corner_at_an_edge_with_its_edge_on_the_face() {
        let h = 0.7855735963018353;
        let cube = Cuboid::new(h, h, h).unwrap();
        let rel = Relative {
            translation: Vector3::new(
                -1.571147210362963,
                -0.45351675504999667,
                -0.14692026277400894,
            ),
            rotation: nalgebra::Matrix3::from_columns(&[
                Vector3::new(3.264215502063461e-9, 0.977886459657852, 0.20913649135870976),
                Vector3::new(
                    0.9999999999999996,
                    8.532044445952458e-10,
                    -1.9597500719448213e-8,
                ),
                Vector3::new(
                    -1.934256677049717e-8,
                    0.20913649135870982,
                    -0.9778864596578518,
                ),
            ]),
        };
        let hv = cube.half_extents();
        let exact = closest_features(&hv, &hv, &rel, 0).distance;
        assert!(exact.abs() < 1e-14, "closest features {exact:e}");
        let g = convex::distance(
            &Shape::Cuboid(cube),
            &Shape::Cuboid(cube),
            &rel,
            &DistanceOptions::default(),
        );
        assert!(g.distance > 1e-9, "GJK stops short here: {g:?}");
        let d = distance(&cube, &cube, &rel, &DistanceOptions::default());
        assert!(
            d.is_converged() && (d.distance - exact).abs() < 1e-14,
            "{d:?} against {exact:e}"
        );
    }
}
