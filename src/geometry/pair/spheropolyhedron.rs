//! Pairs with a spheropolyhedron: each body taken as a core swept by a
//! ball (a spheropolyhedron its polyhedron and rounding, a sphere its
//! centre and radius, a spherocylinder its axis segment and radius, any
//! other body itself and 0). The bodies overlap where their cores come
//! within the sum of the two radii, and their signed distance is the
//! cores' less that sum: GJK between the cores (polytopes, points and
//! segments: exact in finitely many steps), never GJK on the rounded
//! surfaces, where it would converge only linearly.

use super::convex;
use crate::geometry::gjk::{GjkOutcome, gjk_distance};
use crate::geometry::{Contact, DistanceOptions, Relative, Shape};

type V3 = nalgebra::Vector3<f64>;

/// What a body is swept from.
#[derive(Debug, Clone, Copy)]
enum Core {
    /// The centre (a sphere).
    Point,
    /// The segment from −h to h along body z (a spherocylinder).
    Segment(f64),
    /// A body of its own (a spheropolyhedron's polyhedron, or any body
    /// without a rounding).
    Body(Shape),
}

impl Core {
    /// Whether the core is a polytope (a point and a segment are).
    fn is_polytope(&self) -> bool {
        match self {
            Core::Point | Core::Segment(_) => true,
            Core::Body(s) => convex::is_polytope(s),
        }
    }

    #[inline]
    fn support(&self, dir: &V3) -> V3 {
        match self {
            Core::Point => V3::zeros(),
            Core::Segment(h) => V3::new(0.0, 0.0, if dir.z >= 0.0 { *h } else { -*h }),
            Core::Body(s) => s.support(dir),
        }
    }
}

/// `shape` as its core and the radius of the ball that sweeps it.
fn core_of(shape: &Shape) -> (Core, f64) {
    match shape {
        Shape::Sphere(s) => (Core::Point, s.radius()),
        Shape::Spherocylinder(s) => (Core::Segment(s.half_length()), s.radius()),
        Shape::ConvexPolyhedron(p) => (Core::Body(Shape::ConvexPolyhedron(p.core())), p.rounding()),
        _ => (Core::Body(*shape), 0.0),
    }
}

/// Whether `a` and `b` overlap (touching counts); one of them is a
/// spheropolyhedron. GJK's bounds decide where they leave the sum of the
/// radii outside [lower bound, distance]; within its tolerance of
/// touching, the signed distance decides (and is counted).
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let ((ca, ra), (cb, rb)) = (core_of(a), core_of(b));
    let margin = ra + rb;
    let opts = DistanceOptions::default();
    let tol = opts.gjk_tolerance * convex::length(a, b);
    let sa = |d: &V3| ca.support(d);
    let sb = |d: &V3| rel.b_to_a(&cb.support(&rel.rotation.tr_mul(d)));
    let g = gjk_distance(sa, sb, rel.translation, tol, opts.gjk_max_iterations);
    match g.outcome {
        GjkOutcome::Overlapping => true,
        _ if g.lower_bound > margin => false,
        _ if g.distance <= margin => true,
        _ => super::strains::settle(distance(a, b, rel, &opts).distance),
    }
}

/// Signed distance, contact points and normal of `a` and `b`, one of them a
/// spheropolyhedron: the cores' (GJK apart, EPA overlapping), less the
/// radii, the points moved out to the surfaces along the normal.
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    let ((ca, ra), (cb, rb)) = (core_of(a), core_of(b));
    let tol = opts.gjk_tolerance * convex::length(a, b);
    let sa = |d: &V3| ca.support(d);
    let sb = |d: &V3| rel.b_to_a(&cb.support(&rel.rotation.tr_mul(d)));
    let polytopes = ca.is_polytope() && cb.is_polytope();
    let (mut cores, short) = convex::distance_of_supports(&sa, &sb, polytopes, rel, tol, opts);
    if short
        && let (Core::Body(p), Core::Body(q)) = (ca, cb)
        && let Some(exact) = super::polyhedron::distance_by_features(&p, &q, rel)
    {
        cores = exact;
    }
    Contact {
        distance: cores.distance - (ra + rb),
        point_a: cores.point_a + cores.normal * ra,
        point_b: cores.point_b - cores.normal * rb,
        ..cores
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ConvexPolyhedron;
    use crate::geometry::ocsi::point_box_distance;
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// A unit cube given by its corners, swept by `r`.
    fn rounded_cube(r: f64) -> Shape {
        let corners: Vec<V3> = (0..8)
            .map(|k| V3::from_fn(|a, _| if k >> a & 1 == 1 { 0.5 } else { -0.5 }))
            .collect();
        Shape::ConvexPolyhedron(ConvexPolyhedron::new(&corners).unwrap().rounded(r))
    }

    /// A rounded cube overlaps, and is as far, as its core cube's exact
    /// distance says against the sum of the radii: with a sphere (the
    /// point–box distance), a cuboid and another rounded cube (the cuboid
    /// kernel's distance of the cores), either way round; random
    /// placements within 1e-9 of touching aside.
    #[test]
    fn a_rounded_cube_is_its_core_within_the_rounding() {
        let r = 0.15;
        let rounded = rounded_cube(r);
        let core: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        let brick: Shape = "Cuboid(a: 0.4, b: 0.3, c: 0.2)".parse().unwrap();
        let sphere: Shape = "Sphere(radius: 0.3)".parse().unwrap();
        let opts = DistanceOptions::default();
        let mut rng = Pcg64::seed_from_u64(8);
        let mut seen = [0usize; 2];
        for k in 0..12_000 {
            let q = UnitQuaternion::from_euler_angles(
                rng.r#gen::<f64>() * 6.3,
                rng.r#gen::<f64>() * 6.3,
                rng.r#gen::<f64>() * 6.3,
            );
            let rel = Relative {
                translation: Vector3::from_fn(|_, _| (rng.r#gen::<f64>() - 0.5) * 3.2),
                rotation: q.to_rotation_matrix().into_inner(),
            };
            let (other, oracle) = match k % 3 {
                0 => (
                    sphere,
                    point_box_distance(&rel.translation, &V3::repeat(0.5))
                        .0
                        .max(0.0)
                        - r
                        - 0.3,
                ),
                1 => (
                    brick,
                    crate::geometry::distance(&core, &brick, &rel, &opts, None).distance - r,
                ),
                _ => (
                    rounded,
                    crate::geometry::distance(&core, &core, &rel, &opts, None).distance - 2.0 * r,
                ),
            };
            if oracle.abs() < 1e-9 {
                continue;
            }
            let overlapping = oracle <= 0.0;
            assert_eq!(
                crate::geometry::overlap(&rounded, &other, &rel),
                overlapping,
                "{other:?} at {rel:?}"
            );
            let back = rel.inverse();
            assert_eq!(
                crate::geometry::overlap(&other, &rounded, &back),
                overlapping,
                "{other:?} at {back:?}"
            );
            seen[usize::from(overlapping)] += 1;
            if oracle > 0.0 {
                let d = crate::geometry::distance(&rounded, &other, &rel, &opts, None);
                assert!(
                    (d.distance - oracle).abs() < 1e-9,
                    "{other:?}: {} against {oracle}",
                    d.distance
                );
                // The points are on the surfaces, as far apart as said.
                assert!(((d.point_b - d.point_a).norm() - oracle).abs() < 1e-9);
                let e = crate::geometry::distance(&other, &rounded, &back, &opts, None);
                assert!(
                    (e.distance - oracle).abs() < 1e-9,
                    "{other:?}: {} against {oracle}",
                    e.distance
                );
            } else {
                let d = crate::geometry::distance(&rounded, &other, &rel, &opts, None);
                assert!(
                    d.distance <= 1e-9,
                    "{other:?}: {} against {oracle}",
                    d.distance
                );
            }
        }
        assert!(seen[0] > 2000 && seen[1] > 2000, "{seen:?}");
    }
}
