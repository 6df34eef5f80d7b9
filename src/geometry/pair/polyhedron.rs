//! Pairs with a convex polyhedron: GJK on the support mappings decides
//! the overlap, the signed distance deciding where GJK cannot (within
//! rounding of touching); the signed distance is GJK/EPA's, exact on two
//! polytopes in finitely many steps.

use super::convex;
use crate::geometry::gjk::gjk_intersect;
use crate::geometry::polyhedron::{ConvexPolyhedron, MAX_VERTICES, farthest};
use crate::geometry::{Contact, DistanceOptions, Method, Relative, Shape, Status};

type V3 = nalgebra::Vector3<f64>;

/// Whether `a` and `b` overlap (touching counts); one of them is a
/// polyhedron.
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let decided = match (a, b) {
        (Shape::ConvexPolyhedron(p), Shape::ConvexPolyhedron(q)) => polytopes_intersect(p, q, rel),
        _ => convex::intersect(a, b, rel, 200),
    };
    match decided {
        Some(overlapping) => overlapping,
        // A failed distance, NaN, counts as overlap: no move is accepted
        // on an undecided test.
        None => super::strains::settle(distance(a, b, rel, &DistanceOptions::default()).distance),
    }
}

/// The overlap test of two polyhedra: B's corners placed in A's frame
/// once (on the stack), each face plane of either tried as a separating
/// plane, then GJK, each support of B a loop over the placed corners;
/// `None` when undecided.
fn polytopes_intersect(p: &ConvexPolyhedron, q: &ConvexPolyhedron, rel: &Relative) -> Option<bool> {
    let mut placed = [V3::zeros(); MAX_VERTICES];
    for (slot, v) in placed.iter_mut().zip(q.corners()) {
        *slot = rel.rotation * v + rel.translation;
    }
    let placed = &placed[..q.hull().vertices().len()];
    // The face planes of each first (most pairs that come near but do not
    // overlap are apart across one): A's faces against B's corners, B's
    // faces against A's.
    let (a_scale, b_scale) = (p.scale(), q.scale());
    for f in p.hull().faces() {
        if placed.iter().all(|v| f.normal.dot(v) > f.offset * a_scale) {
            return Some(false);
        }
    }
    for f in q.hull().faces() {
        let normal = rel.rotation * f.normal;
        let offset = normal.dot(&rel.translation) + f.offset * b_scale;
        if (p.hull().vertices().iter()).all(|v| normal.dot(v) * a_scale > offset) {
            return Some(false);
        }
    }
    let support_b = |d: &V3| farthest(placed, d);
    gjk_intersect(|d: &V3| p.support(d), support_b, rel.translation, 200)
}

/// Signed distance, contact points and normal of `a` and `b`, one of them a
/// polyhedron: GJK apart, EPA overlapping; two polytopes apart on which
/// GJK stops short of its tolerance, by their closest features.
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    let (contact, short) = convex::distance_with_stall(a, b, rel, opts);
    if !short {
        return contact;
    }
    distance_by_features(a, b, rel).unwrap_or(contact)
}

/// The signed distance of polytopes `a` and `b` (polyhedra without
/// rounding or cuboids) by their features, for where GJK cannot certify
/// its own: the largest separation over the axes that can separate them
/// says whether they overlap, and by how much; apart, the closest
/// features say how far. None for other shapes.
pub(super) fn distance_by_features(a: &Shape, b: &Shape, rel: &Relative) -> Option<Contact> {
    let (p, q) = (as_polyhedron(a)?, as_polyhedron(b)?);
    let (distance, point_a, point_b, normal) = super::features::signed_distance(&p, &q, rel)?;
    Some(Contact {
        distance,
        point_a,
        point_b,
        normal,
        status: Status::Converged { iterations: 0 },
        method: Method::Features,
        warm_start: None,
    })
}

/// A polytope as a polyhedron without rounding (a cuboid as its corners).
fn as_polyhedron(shape: &Shape) -> Option<Shape> {
    match shape {
        Shape::ConvexPolyhedron(p) if p.rounding() == 0.0 => Some(*shape),
        Shape::Cuboid(c) => {
            let h = c.half_extents();
            let corners: Vec<V3> = (0..8)
                .map(|k| V3::from_fn(|i, _| if k >> i & 1 == 1 { h[i] } else { -h[i] }))
                .collect();
            ConvexPolyhedron::new(&corners)
                .ok()
                .map(Shape::ConvexPolyhedron)
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ConvexPolyhedron;
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// A cube given as its eight corners overlaps exactly where the
    /// cuboid of the same size does (SAT, OCSI): with another cube, a
    /// sphere and an ellipsoid, over random placements, those within
    /// 1e-9 of touching aside; and apart, its distance is the cuboid's.
    #[test]
    fn a_cube_of_corners_is_the_cuboid() {
        let corners: Vec<Vector3<f64>> = (0..8)
            .map(|k| Vector3::from_fn(|a, _| if k >> a & 1 == 1 { 0.5 } else { -0.5 }))
            .collect();
        let polyhedron = Shape::ConvexPolyhedron(ConvexPolyhedron::new(&corners).unwrap());
        let cuboid: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let others: [Shape; 3] = [
            cuboid,
            "Sphere(radius: 0.4)".parse().unwrap(),
            "Ellipsoid(a: 0.7, b: 0.3, c: 0.2)".parse().unwrap(),
        ];
        let mut rng = Pcg64::seed_from_u64(2);
        let opts = DistanceOptions::default();
        let mut overlapping = 0;
        for other in &others {
            for _ in 0..4000 {
                let q = UnitQuaternion::from_euler_angles(
                    rng.r#gen::<f64>() * 6.3,
                    rng.r#gen::<f64>() * 6.3,
                    rng.r#gen::<f64>() * 6.3,
                );
                let rel = Relative {
                    translation: Vector3::from_fn(|_, _| (rng.r#gen::<f64>() - 0.5) * 2.6),
                    rotation: q.to_rotation_matrix().into_inner(),
                };
                let exact = crate::geometry::distance(&cuboid, other, &rel, &opts, None);
                if exact.distance.abs() < 1e-9 {
                    continue;
                }
                let mine = crate::geometry::overlap(&polyhedron, other, &rel);
                assert_eq!(
                    mine,
                    crate::geometry::overlap(&cuboid, other, &rel),
                    "{other:?} at {rel:?}"
                );
                overlapping += usize::from(mine);
                // Apart, GJK's distance is exact; overlapping, only the
                // sign is compared (depths are defined differently).
                let d = crate::geometry::distance(&polyhedron, other, &rel, &opts, None);
                let agree = if exact.distance > 0.0 {
                    (d.distance - exact.distance).abs() < 1e-6
                } else {
                    d.distance <= 0.0
                };
                assert!(
                    agree,
                    "{other:?}: {} against {}",
                    d.distance, exact.distance
                );
            }
        }
        assert!(overlapping > 1000, "{overlapping}");
    }

    /// Two tetrahedra touching to rounding (met by the dynamics at a
    /// predicted contact): the signed distance is continuous through the
    /// touch, EPA's depth as small as GJK's gap on the other side, and the
    /// normal the same; scaled separations 1 ± 1e-5 give ±4.48e-6.
    #[test]
    fn tetrahedra_touching_to_rounding_have_a_depth_of_rounding() {
        use nalgebra::Quaternion;
        let t: Shape = "Tetrahedron(edge: 1.0)".parse().unwrap();
        let d = Vector3::new(
            -0.6164396569415922,
            0.30676503341979944,
            -0.018442679617881264,
        );
        let q = |w, x, y, z| UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        let qa = q(
            -0.6196306736010364,
            0.6103995652072742,
            0.48900012085766886,
            0.06594756196162022,
        );
        let qb = q(
            0.08866082512234816,
            0.6381775028029585,
            -0.7624937160333443,
            -0.05892423961720778,
        );
        let at = |s: f64| {
            distance(
                &t,
                &t,
                &Relative::new(&(d * s), &qa, &qb),
                &DistanceOptions::default(),
            )
        };
        let (below, touching, above) = (at(1.0 - 1e-5), at(1.0), at(1.0 + 1e-5));
        assert!(below.distance < 0.0 && above.distance > 0.0);
        assert!(
            (below.distance + above.distance).abs() < 1e-12,
            "{below:?} {above:?}"
        );
        assert!(touching.distance.abs() < 1e-12, "{touching:?}");
        assert!(
            (touching.normal - above.normal).norm() < 1e-9,
            "{touching:?}"
        );
    }

    /// The distance by features is GJK/EPA's wherever GJK certifies its
    /// own, near contact either side (1e-6 of the contact distance and
    /// more) and far from it, for tetrahedra, cubes and octahedra in
    /// every pairing; the sign says overlap as the overlap test does.
    #[test]
    fn the_distance_by_features_is_gjks_where_gjk_is_sure() {
        let shapes: Vec<Shape> = [
            "Tetrahedron(edge: 1.0)",
            "Cube(edge: 1.0)",
            "Octahedron(edge: 1.0)",
        ]
        .iter()
        .map(|t| t.parse().unwrap())
        .collect();
        let mut rng = Pcg64::seed_from_u64(3);
        let opts = DistanceOptions::default();
        let (mut compared, mut overlapping) = (0, 0);
        for case in 0..600 {
            let (a, b) = (&shapes[case % 3], &shapes[(case / 3) % 3]);
            let mut turn = || {
                UnitQuaternion::from_euler_angles(
                    rng.r#gen::<f64>() * 6.3,
                    rng.r#gen::<f64>() * 6.3,
                    rng.r#gen::<f64>() * 6.3,
                )
            };
            let (qa, qb) = (turn(), turn());
            let dir = Vector3::from_fn(|_, _| rng.r#gen::<f64>() - 0.5).normalize();
            let at = |s: f64| Relative::new(&(dir * s), &qa, &qb);
            let (mut lo, mut hi) = (0.0, 3.0);
            for _ in 0..100 {
                let m = 0.5 * (lo + hi);
                if convex::distance(a, b, &at(m), &opts).distance < 0.0 {
                    lo = m
                } else {
                    hi = m
                }
            }
            for s in [0.9, 0.999, 1.0 - 1e-6, 1.0 + 1e-6, 1.001, 1.1] {
                let rel = at(hi * s);
                let (g, short) = convex::distance_with_stall(a, b, &rel, &opts);
                if short || !matches!(g.status, Status::Converged { .. }) {
                    continue;
                }
                let f = distance_by_features(a, b, &rel).unwrap();
                assert!(
                    (g.distance - f.distance).abs() < 1e-12,
                    "case {case} at {s}: GJK {g:?}, features {f:?}"
                );
                assert_eq!(
                    f.distance <= 0.0,
                    crate::geometry::overlap(a, b, &rel),
                    "case {case}"
                );
                compared += 1;
                overlapping += usize::from(f.distance < 0.0);
            }
        }
        assert!(
            compared > 3000 && overlapping > 1000,
            "{compared} {overlapping}"
        );
    }

    /// A cube of corners lying almost flat on another (tilted by 1e-9 to
    /// 1e-3 rad, 1e-12 to 1e-6 above it), where GJK's support points tie
    /// to within the rounding of its search direction: the polyhedron
    /// distance is the cuboid kernel's (exact on boxes by their own
    /// features) to rounding.
    #[test]
    fn a_cube_of_corners_lying_almost_flat_is_as_far_as_the_cuboid() {
        let corners: Shape = "Cube(edge: 1.0)".parse().unwrap();
        let cuboid: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let mut rng = Pcg64::seed_from_u64(8);
        let opts = DistanceOptions::default();
        let mut short = 0;
        for case in 0..400 {
            let tilt = 10f64.powf(-9.0 + 6.0 * rng.r#gen::<f64>());
            let axis =
                Vector3::new(rng.r#gen::<f64>() - 0.5, rng.r#gen::<f64>() - 0.5, 0.0).normalize();
            let spin =
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 6.3 * rng.r#gen::<f64>());
            let qb = UnitQuaternion::from_scaled_axis(axis * tilt) * spin;
            let gap = 10f64.powf(-12.0 + 6.0 * rng.r#gen::<f64>());
            let offset =
                Vector3::new(rng.r#gen::<f64>() - 0.5, rng.r#gen::<f64>() - 0.5, 0.0) * 0.8;
            // B's lowest point `gap` above A's top face.
            let probe = Relative::new(&(offset + Vector3::z()), &UnitQuaternion::identity(), &qb);
            let lowest = (probe.b_to_a(&corners.support(&probe.rotation.tr_mul(&-Vector3::z())))).z;
            let rel = Relative::new(
                &(offset + Vector3::z() * (1.0 + 0.5 + gap - lowest)),
                &UnitQuaternion::identity(),
                &qb,
            );
            let boxes = crate::geometry::distance(&cuboid, &cuboid, &rel, &opts, None);
            let mine = crate::geometry::distance(&corners, &corners, &rel, &opts, None);
            short += usize::from(mine.method == Method::Features);
            assert!(
                (mine.distance - boxes.distance).abs() < 1e-14,
                "case {case} (tilt {tilt:e}, gap {gap:e}): {mine:?} against {boxes:?}"
            );
        }
        eprintln!("{short} of 400 by features");
    }

    /// Two cubes of corners crossing edge to edge, touching to 1e-12 or
    /// overlapping by it: the features put the contact on the crossing of
    /// the two touching edges, where the cuboid kernel puts it, and not on
    /// an edge parallel to one of them (a cube has four along each axis,
    /// each giving the same separating axis).
    #[test]
    fn crossing_edges_touch_where_they_cross() {
        let cube: Shape = "Cube(edge: 1.0)".parse().unwrap();
        let cuboid: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let r = std::f64::consts::FRAC_1_SQRT_2;
        // A's edge along y at x = 0.5, z = -0.5, its outward bisector n;
        // B's edge along x at y = z = -0.5 (body frame), turned to run
        // along (1, 0, 1)/√2 with its own bisector along -n.
        let n = Vector3::new(r, 0.0, -r);
        let body = nalgebra::Matrix3::from_columns(&[
            Vector3::x(),
            Vector3::new(0.0, r, r),
            Vector3::new(0.0, -r, r),
        ]);
        let lab = nalgebra::Matrix3::from_columns(&[Vector3::new(r, 0.0, r), n, Vector3::y()]);
        let turn = UnitQuaternion::from_matrix(&(lab * body.transpose()));
        for (y0, s0) in [(0.2, 0.1), (-0.3, -0.35), (0.45, 0.0)] {
            let on_a = Vector3::new(0.5, y0, -0.5);
            for gap in [-1e-12, 0.0, 1e-12] {
                let centre = on_a + n * gap - turn * Vector3::new(s0, -0.5, -0.5);
                let rel = Relative::new(&centre, &UnitQuaternion::identity(), &turn);
                let exact = super::super::distance(
                    &cuboid,
                    &cuboid,
                    &rel,
                    &DistanceOptions::default(),
                    None,
                );
                let f = distance_by_features(&cube, &cube, &rel).unwrap();
                let case = format!("edge at y = {y0}, gap {gap:e}");
                assert!((f.distance - gap).abs() < 1e-13, "{case}: {}", f.distance);
                assert!((f.normal - n).norm() < 1e-9, "{case}: {:?}", f.normal);
                assert!((f.point_a - on_a).norm() < 1e-9, "{case}: {:?}", f.point_a);
                assert!(
                    (exact.point_a - on_a).norm() < 1e-9,
                    "{case}: cuboid {:?}",
                    exact.point_a
                );
            }
        }
    }
}
