//! The contact patch of two bodies touching along a flat feature: the
//! corners of the region a face or an edge of each core shares in the
//! contact plane, on which a collision acts at once.

use nalgebra::{Vector2, Vector3};

type V3 = Vector3<f64>;
type V2 = Vector2<f64>;

/// The most corners a patch keeps: the intersection of two convex
/// polygons has at most as many corners as the two together.
pub const MAX_PATCH: usize = 16;

/// The contact points of two bodies touching along a flat feature: where
/// a face or an edge of each body's core (the body itself for a
/// polytope; a spherocylinder's axis segment) lies in the contact plane
/// (to `tolerance`), the corners of the region they share there (a face
/// on a face: the polygon where the two faces overlap; an edge on a face,
/// or two parallel edges: a segment's two ends). A frame, each on the
/// plane midway between the two features. Empty where the bodies touch
/// at a single point (a vertex, or crossing edges): one contact point
/// says all there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPatch {
    points: [V3; MAX_PATCH],
    len: usize,
}

impl ContactPatch {
    /// No patch: a single contact point.
    pub fn none() -> Self {
        Self {
            points: [V3::zeros(); MAX_PATCH],
            len: 0,
        }
    }

    /// The corners of the shared region.
    pub fn points(&self) -> &[V3] {
        &self.points[..self.len]
    }

    /// Whether there is no patch (a single contact point).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A body's feature along a direction: its corners within `tolerance` of
/// the farthest (at most [`MAX_PATCH`]; None where more are, a tolerance
/// too loose for a feature), how many, and how far the farthest reaches.
fn feature(
    corners: &[V3],
    direction: &V3,
    tolerance: f64,
) -> Option<([V3; MAX_PATCH], usize, f64)> {
    let top = (corners.iter()).fold(f64::NEG_INFINITY, |m, v| m.max(v.dot(direction)));
    let mut chosen = [V3::zeros(); MAX_PATCH];
    let mut count = 0;
    for v in corners {
        if v.dot(direction) >= top - tolerance {
            if count == MAX_PATCH {
                return None;
            }
            chosen[count] = *v;
            count += 1;
        }
    }
    Some((chosen, count, top))
}

/// The [`ContactPatch`] of two polytope cores with corners `corners_a`
/// and `corners_b` (both in A's frame) touching with unit normal `normal`
/// (A → B): the corners within `tolerance` of each core's supporting
/// plane make its feature.
pub fn polytope_patch(
    corners_a: &[V3],
    corners_b: &[V3],
    normal: &V3,
    tolerance: f64,
) -> ContactPatch {
    let empty = ContactPatch::none();
    let (Some((fa, na, top_a)), Some((fb, nb, top_b))) = (
        feature(corners_a, normal, tolerance),
        feature(corners_b, &-normal, tolerance),
    ) else {
        return empty;
    };
    if na < 2 || nb < 2 {
        return empty;
    }
    // Coordinates in the contact plane.
    let e1 = normal.cross(&V3::ith(normal.iamin(), 1.0)).normalize();
    let e2 = normal.cross(&e1);
    let flat = |v: &V3| V2::new(v.dot(&e1), v.dot(&e2));
    // A face's corners in order around it (a convex polygon: every
    // corner of a face of a convex body is on its boundary).
    let polygon = |f: &[V3; MAX_PATCH], n: usize| {
        let mut p = [V2::zeros(); MAX_PATCH];
        for k in 0..n {
            p[k] = flat(&f[k]);
        }
        if n > 2 {
            let c = p[..n].iter().sum::<V2>() / n as f64;
            p[..n].sort_by(|x, y| {
                let (ax, ay) = ((x - c).y.atan2((x - c).x), (y - c).y.atan2((y - c).x));
                ax.total_cmp(&ay)
            });
        }
        p
    };
    let (pa, pb) = (polygon(&fa, na), polygon(&fb, nb));
    let mut out = [V2::zeros(); MAX_PATCH];
    let len;
    if na > 2 || nb > 2 {
        // Clip the other feature (a face or an edge) by a face
        // (Sutherland–Hodgman; a segment is a two-corner polygon).
        let (clip, n_clip, subject, n_subject) = if nb > 2 {
            (pb, nb, pa, na)
        } else {
            (pa, na, pb, nb)
        };
        let orientation = (clip[1] - clip[0]).perp(&(clip[2] - clip[1])).signum();
        let mut poly = subject;
        let mut n_poly = n_subject;
        for k in 0..n_clip {
            let (p, q) = (clip[k], clip[(k + 1) % n_clip]);
            let inside = |x: &V2| orientation * (q - p).perp(&(x - p));
            let mut next = [V2::zeros(); MAX_PATCH];
            let mut n_next = 0;
            let mut push = |x: V2| {
                if n_next < MAX_PATCH {
                    next[n_next] = x;
                    n_next += 1;
                }
            };
            // A segment is open: its closing edge back to the start would
            // add the same piece twice.
            let edges = if n_poly == 2 { 1 } else { n_poly };
            for m in 0..edges {
                let (x, y) = (poly[m], poly[(m + 1) % n_poly]);
                let (sx, sy) = (inside(&x), inside(&y));
                if sx >= 0.0 {
                    push(x);
                }
                if (sx >= 0.0) != (sy >= 0.0) {
                    push(x + (y - x) * (sx / (sx - sy)));
                }
                if n_poly == 2 && sy >= 0.0 {
                    push(y);
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
        let s = |x: &V2| (x - pa[0]).dot(&dir);
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
    let mid = 0.5 * (top_a - top_b);
    let mut points = [V3::zeros(); MAX_PATCH];
    for k in 0..len {
        points[k] = e1 * out[k].x + e2 * out[k].y + normal * mid;
    }
    ContactPatch { points, len }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pair::contact_patch;
    use crate::geometry::{Relative, Shape};
    use nalgebra::UnitQuaternion;

    fn patch(b_centre: Vector3<f64>, b_turn: UnitQuaternion<f64>) -> Vec<Vector3<f64>> {
        let a: Shape = "Cuboid(a: 1.0, b: 1.0, c: 0.5)".parse().unwrap();
        let b: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let rel = Relative::new(&b_centre, &UnitQuaternion::identity(), &b_turn);
        let mut points = contact_patch(&a, &b, &rel, &Vector3::z(), 1e-9)
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
        let a: Shape = "Cuboid(a: 1.0, b: 1.0, c: 0.5)".parse().unwrap();
        let b: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let rel = Relative::new(
            &Vector3::new(0.0, 0.0, 1.4),
            &UnitQuaternion::identity(),
            &vertex,
        );
        assert!(contact_patch(&a, &b, &rel, &Vector3::z(), 1e-9).is_empty());
    }

    /// The same regions for polytopes of any kind: a cube given by its
    /// corners as the cuboid's; a spherocylinder lying on a face, the
    /// segment of its axis over the face; two tetrahedra face on face,
    /// one turned a sixth of a turn, the hexagon the two triangles share
    /// (the triangles of a star of David).
    #[test]
    fn polytopes_share_the_regions_their_faces_overlap_in() {
        let corners: Shape = "Cube(edge: 1.0)".parse().unwrap();
        let cuboid: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let mut u = crate::test_support::uniform(7);
        for _ in 0..50 {
            let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 6.0 * u());
            let rel = Relative::new(
                &Vector3::new(u() - 0.5, u() - 0.5, 1.0),
                &UnitQuaternion::identity(),
                &turn,
            );
            let sorted = |a: &Shape, b: &Shape| {
                let mut p = contact_patch(a, b, &rel, &Vector3::z(), 1e-9)
                    .points()
                    .to_vec();
                p.sort_by(|p, q| p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y)));
                p
            };
            let (mine, boxes) = (sorted(&corners, &corners), sorted(&cuboid, &cuboid));
            assert!(
                mine.len() >= 3 && mine.len() == boxes.len(),
                "{mine:?} {boxes:?}"
            );
            for (p, q) in mine.iter().zip(&boxes) {
                assert!((p - q).norm() < 1e-12, "{mine:?} {boxes:?}");
            }
        }
        // A rod of half-length 0.6 lying across a cube's top face along x,
        // its axis 0.5 + 0.2 above the centre: the face holds x in
        // [-0.5, 0.5] of it.
        let rod: Shape = "Spherocylinder(radius: 0.2, length: 1.2)".parse().unwrap();
        let along_x =
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
        let rel = Relative::new(
            &Vector3::new(0.0, 0.1, 0.7),
            &UnitQuaternion::identity(),
            &along_x,
        );
        let mut p = contact_patch(&corners, &rod, &rel, &Vector3::z(), 1e-9)
            .points()
            .to_vec();
        p.sort_by(|p, q| p.x.total_cmp(&q.x));
        assert_eq!(p.len(), 2, "{p:?}");
        assert!(
            (p[0].x + 0.5).abs() < 1e-12 && (p[1].x - 0.5).abs() < 1e-12,
            "{p:?}"
        );
        assert!(p.iter().all(|x| (x.y - 0.1).abs() < 1e-12), "{p:?}");
        // A tetrahedron's face turned to face another's, a sixth of a turn
        // about the common normal apart.
        let tetra: Shape = "Tetrahedron(edge: 1.0)".parse().unwrap();
        let Shape::ConvexPolyhedron(t) = tetra else {
            unreachable!()
        };
        let face = &t.hull().faces()[0];
        let n = face.normal;
        // Half a turn about the line from the face's centre to one of its
        // corners: the face onto itself, facing the other way.
        let corner = t.hull().vertices()[face.vertices[0]] - n * face.offset;
        let flip = UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(corner),
            std::f64::consts::PI,
        );
        let sixth = UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(n),
            std::f64::consts::FRAC_PI_3,
        );
        let rel = Relative::new(
            &(n * 2.0 * face.offset),
            &UnitQuaternion::identity(),
            &(sixth * flip),
        );
        let p = contact_patch(&tetra, &tetra, &rel, &n, 1e-9);
        assert_eq!(p.points().len(), 6, "{:?}", p.points());
        for x in p.points() {
            assert!((x.dot(&n) - face.offset).abs() < 1e-12, "{:?}", p.points());
        }
    }
}
