//! The contact patch of two cuboids touching along a flat feature: the
//! corners of the region a face or an edge of each shares in the contact
//! plane, on which a collision acts at once.

use nalgebra::Vector3;

use super::Relative;
use crate::geometry::shape::Cuboid;

/// The contact points of two cuboids touching along a flat feature: where
/// a face or an edge of each lies in the contact plane (to `tolerance`),
/// the corners of the region they share there (a face on a face: the
/// polygon where the two faces overlap, up to 8 corners; an edge on a
/// face, or two parallel edges: a segment's two ends). A frame, each on
/// the plane midway between the two features. Empty where the bodies
/// touch at a single point (a vertex, or crossing edges): one contact
/// point says all there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPatch {
    points: [Vector3<f64>; 8],
    len: usize,
}

impl ContactPatch {
    /// No patch: a single contact point.
    pub fn none() -> Self {
        Self {
            points: [Vector3::zeros(); 8],
            len: 0,
        }
    }

    /// The corners of the shared region.
    pub fn points(&self) -> &[Vector3<f64>] {
        &self.points[..self.len]
    }

    /// Whether there is no patch (a single contact point).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// The [`ContactPatch`] of cuboids `a` and `b` (B placed by `rel`) touching
/// with unit normal `normal` (A → B, A's frame): the vertices within
/// `tolerance` of each body's supporting plane make its feature.
pub fn cuboid_patch(
    a: &Cuboid,
    b: &Cuboid,
    rel: &Relative,
    normal: &Vector3<f64>,
    tolerance: f64,
) -> ContactPatch {
    let empty = ContactPatch::none();
    let corners = |h: Vector3<f64>| {
        [0, 1, 2, 3, 4, 5, 6, 7].map(|k| {
            let s = |bit: usize| if k & bit == 0 { -1.0 } else { 1.0 };
            Vector3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
        })
    };
    // Each body's feature: its vertices farthest along n (A) or −n (B).
    let feature = |vertices: [Vector3<f64>; 8], sign: f64| {
        let height = vertices.map(|v| sign * v.dot(normal));
        let top = height.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut chosen = [Vector3::zeros(); 4];
        let mut count = 0;
        for (v, h) in vertices.iter().zip(height) {
            if h >= top - tolerance {
                if count == 4 {
                    return None; // not a box feature: a tolerance too loose
                }
                chosen[count] = *v;
                count += 1;
            }
        }
        Some((chosen, count, sign * top))
    };
    let vertices_b = corners(b.half_extents()).map(|v| rel.b_to_a(&v));
    let (Some((fa, na, top_a)), Some((fb, nb, top_b))) = (
        feature(corners(a.half_extents()), 1.0),
        feature(vertices_b, -1.0),
    ) else {
        return empty;
    };
    if na == 1 || nb == 1 || na == 3 || nb == 3 {
        return empty;
    }
    // Coordinates in the contact plane.
    let e1 = normal.cross(&Vector3::ith(normal.iamin(), 1.0)).normalize();
    let e2 = normal.cross(&e1);
    let flat = |v: &Vector3<f64>| nalgebra::Vector2::new(v.dot(&e1), v.dot(&e2));
    // A face's four corners in order around it (a convex quadrilateral).
    let polygon = |f: &[Vector3<f64>; 4], n: usize| {
        let mut p = [nalgebra::Vector2::zeros(); 4];
        for k in 0..n {
            p[k] = flat(&f[k]);
        }
        if n == 4 {
            let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
            p.sort_by(|x, y| {
                let (ax, ay) = ((x - c).y.atan2((x - c).x), (y - c).y.atan2((y - c).x));
                ax.total_cmp(&ay)
            });
        }
        p
    };
    let (pa, pb) = (polygon(&fa, na), polygon(&fb, nb));
    let mut out = [nalgebra::Vector2::zeros(); 8];
    let len;
    if na == 4 || nb == 4 {
        // Clip the other feature (a face or an edge) by the face
        // (Sutherland–Hodgman; a segment is a two-corner polygon).
        let (clip, subject, n_subject) = if nb == 4 { (pb, pa, na) } else { (pa, pb, nb) };
        let orientation = (clip[1] - clip[0]).perp(&(clip[2] - clip[1])).signum();
        let mut poly = [nalgebra::Vector2::zeros(); 8];
        poly[..n_subject].copy_from_slice(&subject[..n_subject]);
        let mut n_poly = n_subject;
        for k in 0..4 {
            let (p, q) = (clip[k], clip[(k + 1) % 4]);
            let inside = |x: &nalgebra::Vector2<f64>| orientation * (q - p).perp(&(x - p));
            let mut next = [nalgebra::Vector2::zeros(); 8];
            let mut n_next = 0;
            // A segment is open: its closing edge back to the start would
            // add the same piece twice.
            let edges = if n_poly == 2 { 1 } else { n_poly };
            for m in 0..edges {
                let (x, y) = (poly[m], poly[(m + 1) % n_poly]);
                let (sx, sy) = (inside(&x), inside(&y));
                if sx >= 0.0 && n_next < 8 {
                    next[n_next] = x;
                    n_next += 1;
                }
                if (sx >= 0.0) != (sy >= 0.0) && n_next < 8 {
                    next[n_next] = x + (y - x) * (sx / (sx - sy));
                    n_next += 1;
                }
                if n_poly == 2 && sy >= 0.0 && n_next < 8 {
                    next[n_next] = y;
                    n_next += 1;
                }
            }
            poly = next;
            n_poly = n_next;
            if n_poly == 0 {
                return empty;
            }
        }
        out = poly;
        len = n_poly;
    } else {
        // Two edges: a segment only where they are parallel and overlap.
        let (u, w) = (pa[1] - pa[0], pb[1] - pb[0]);
        if u.perp(&w).abs() > 1e-9 * u.norm() * w.norm() {
            return empty;
        }
        let dir = u / u.norm_squared();
        let s = |x: &nalgebra::Vector2<f64>| (x - pa[0]).dot(&dir);
        let (lo, hi) = (s(&pb[0]).min(s(&pb[1])), s(&pb[0]).max(s(&pb[1])));
        let (lo, hi) = (lo.max(0.0), hi.min(1.0));
        if hi <= lo {
            return empty;
        }
        out[0] = pa[0] + u * lo;
        out[1] = pa[0] + u * hi;
        len = 2;
    }
    if len < 2 {
        return empty;
    }
    let mid = 0.5 * (top_a + top_b);
    let mut points = [Vector3::zeros(); 8];
    for k in 0..len {
        points[k] = e1 * out[k].x + e2 * out[k].y + normal * mid;
    }
    ContactPatch { points, len }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn patch(b_centre: Vector3<f64>, b_turn: UnitQuaternion<f64>) -> Vec<Vector3<f64>> {
        let a = Cuboid::new(1.0, 1.0, 0.5).unwrap();
        let b = Cuboid::new(0.5, 0.5, 0.5).unwrap();
        let rel = Relative::new(&b_centre, &UnitQuaternion::identity(), &b_turn);
        let mut points = cuboid_patch(&a, &b, &rel, &Vector3::z(), 1e-9)
            .points()
            .to_vec();
        points.sort_by(|p, q| p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y)));
        points
    }

    /// A face on a face, an edge on a face and a vertex on a face against
    /// the regions worked out by hand.
    #[test]
    fn patch_corners_match_the_shared_regions() {
        // B's bottom face (side 1) on A's top face (2 × 2), shifted so that
        // it hangs over A's edge at x = 1: the shared square is
        // [0.7, 1] × [−0.5, 0.5], midway between the faces (z = 0.5).
        let p = patch(
            Vector3::new(1.2, 0.0, 1.0 + 1e-12),
            UnitQuaternion::identity(),
        );
        let want = [(0.7, -0.5), (0.7, 0.5), (1.0, -0.5), (1.0, 0.5)];
        assert_eq!(p.len(), 4, "{p:?}");
        for (got, (x, y)) in p.iter().zip(want) {
            assert!(
                (got - Vector3::new(x, y, 0.5 + 0.5e-12)).norm() < 1e-12,
                "{p:?}"
            );
        }
        // Turned 45° about z, centred: B's square on A's larger one is
        // entirely inside it, four corners at radius √2/2 · ... on the axes.
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4);
        let p = patch(Vector3::new(0.0, 0.0, 1.0), turn);
        assert_eq!(p.len(), 4, "{p:?}");
        let r = std::f64::consts::SQRT_2 / 2.0;
        for got in &p {
            assert!(
                (got.xy().norm() - r).abs() < 1e-12 && (got.z - 0.5).abs() < 1e-12,
                "{p:?}"
            );
        }
        // Turned 45° and off to a corner of A: the overlap of two squares
        // is clipped by A's sides x = 1 and y = 1.
        let p = patch(Vector3::new(1.0, 1.0, 1.0), turn);
        for got in &p {
            assert!(got.x <= 1.0 + 1e-12 && got.y <= 1.0 + 1e-12, "{p:?}");
            assert!(
                (got.xy() - Vector3::new(1.0, 1.0, 0.0).xy()).abs().sum() <= r + 1e-12,
                "{p:?}"
            );
        }
        assert!(p.len() >= 3, "{p:?}");
        // An edge on the face: B turned 45° about x lies on its edge along
        // x, the segment x ∈ [−0.5, 0.5] at y = 0.
        let edge = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_4);
        let p = patch(
            Vector3::new(0.0, 0.0, 0.5 + std::f64::consts::SQRT_2 / 2.0),
            edge,
        );
        assert_eq!(p.len(), 2, "{p:?}");
        assert!(
            (p[0] - Vector3::new(-0.5, 0.0, 0.5)).norm() < 1e-12,
            "{p:?}"
        );
        assert!((p[1] - Vector3::new(0.5, 0.0, 0.5)).norm() < 1e-12, "{p:?}");
        // A vertex on the face: a single point, no patch.
        let vertex = UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, 1.0, 0.0)),
            0.6,
        );
        let a = Cuboid::new(1.0, 1.0, 0.5).unwrap();
        let b = Cuboid::new(0.5, 0.5, 0.5).unwrap();
        let rel = Relative::new(
            &Vector3::new(0.0, 0.0, 1.4),
            &UnitQuaternion::identity(),
            &vertex,
        );
        assert!(cuboid_patch(&a, &b, &rel, &Vector3::z(), 1e-9).is_empty());
    }
}
