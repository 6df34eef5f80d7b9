//! GJK/EPA glue for any pair of shapes through their support mappings, in
//! the pair's relative frame (A at the origin; see the `pair` module docs).

use nalgebra::Vector3;

use super::{Contact, DistanceOptions, Method, Relative, Status};
use crate::geometry::gjk::{
    Enclosure, GjkOutcome, Vertex, epa, gjk_distance, gjk_enclose, gjk_intersect,
};
use crate::geometry::shape::Shape;

type V3 = Vector3<f64>;

/// EPA converges finitely on polytopes but only as O(1/n) on curved
/// surfaces; past this many expansions it reports `IterationCap` with its
/// estimate (the sign, overlap, is certain).
const EPA_MAX_ITERATIONS: usize = 64;

/// Support of A (at the origin) and of B (placed by `rel`), both in A's frame.
fn supports<'s>(
    a: &'s Shape,
    b: &'s Shape,
    rel: &'s Relative,
) -> (impl Fn(&V3) -> V3 + 's, impl Fn(&V3) -> V3 + 's) {
    let sa = move |d: &V3| a.support(d);
    let sb = move |d: &V3| rel.b_to_a(&b.support(&rel.rotation.tr_mul(d)));
    (sa, sb)
}

/// GJK overlap test; `None` when undecided within `max_iterations`.
pub fn intersect(a: &Shape, b: &Shape, rel: &Relative, max_iterations: usize) -> Option<bool> {
    let (sa, sb) = supports(a, b, rel);
    gjk_intersect(sa, sb, rel.translation, max_iterations)
}

/// The length unit of the tolerances: the smaller body's smallest half-extent.
pub(super) fn length(a: &Shape, b: &Shape) -> f64 {
    a.min_half_extent().min(b.min_half_extent())
}

/// Signed distance by GJK (separated) or EPA (overlapping).
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    distance_with_stall(a, b, rel, opts).0
}

/// [`distance`], and whether GJK stopped short of its tolerance: apart,
/// its distance still above the lower bound it proved by more than the
/// tolerance. GJK on two polytopes can stop so, with no new support point
/// (a face whose vertices tie in the support map), and report
/// convergence.
pub fn distance_with_stall(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
    opts: &DistanceOptions,
) -> (Contact, bool) {
    let tol = opts.gjk_tolerance * length(a, b);
    let (sa, sb) = supports(a, b, rel);
    let polytopes = is_polytope(a) && is_polytope(b);
    distance_of_supports(&sa, &sb, polytopes, rel, tol, opts)
}

/// Whether `shape` is a polytope (a cuboid, or a polyhedron without a
/// rounding): its support map is a finite set of corners.
pub(super) fn is_polytope(shape: &Shape) -> bool {
    match shape {
        Shape::Cuboid(_) => true,
        Shape::ConvexPolyhedron(p) => p.rounding() == 0.0,
        _ => false,
    }
}

/// [`distance_with_stall`] of the bodies of support mappings `sa` and `sb`
/// (both in A's frame, B's centre at `rel.translation`), to the absolute
/// tolerance `tol`; `polytopes` says both are polytopes (finitely many
/// corners), whose contact normals are then taken from the faces of the
/// Minkowski difference GJK ends on.
pub fn distance_of_supports(
    sa: &impl Fn(&V3) -> V3,
    sb: &impl Fn(&V3) -> V3,
    polytopes: bool,
    rel: &Relative,
    tol: f64,
    opts: &DistanceOptions,
) -> (Contact, bool) {
    let not_short = |c: Contact| (c, false);
    let g = gjk_distance(sa, sb, rel.translation, tol, opts.gjk_max_iterations);
    let iterations = g.iterations as u32;
    // Touching to rounding: the normal of the simplex's face where it is
    // a triangle of two polytopes, else GJK's between the bodies moved
    // apart along the line of centres by a little more than the
    // tolerance (the line of centres itself is a normal only for balls).
    let centres = rel.translation.try_normalize(0.0).unwrap_or(V3::x());
    let touching = || {
        let apart = || {
            let shift = centres * (1e4 * tol);
            let sb_apart = |d: &V3| sb(d) + shift;
            let t = rel.translation + shift;
            let h = gjk_distance(sa, sb_apart, t, tol, opts.gjk_max_iterations);
            (h.outcome == GjkOutcome::Separated).then(|| {
                face_normal(&h.simplex, h.simplex_len, polytopes, &t)
                    .or_else(|| (h.point_b - h.point_a).try_normalize(0.0))
            })?
        };
        Contact {
            distance: -0.0,
            point_a: g.point_a,
            point_b: g.point_b,
            normal: face_normal(&g.simplex, g.simplex_len, polytopes, &rel.translation)
                .or_else(apart)
                .unwrap_or(centres),
            status: Status::Converged { iterations },
            method: Method::Gjk,
            warm_start: None,
        }
    };
    let penetration = |simplex: &[Vertex; 4], iterations: u32| -> Contact {
        match epa(sa, sb, simplex, tol, EPA_MAX_ITERATIONS) {
            Some(p) => Contact {
                distance: -p.depth,
                point_a: p.point_a,
                point_b: p.point_b,
                normal: p.normal,
                status: if p.converged {
                    Status::Converged {
                        iterations: iterations + p.iterations as u32,
                    }
                } else {
                    Status::IterationCap {
                        iterations: iterations + p.iterations as u32,
                    }
                },
                method: Method::Epa,
                warm_start: None,
            },
            None => Contact {
                status: Status::DeepOverlap,
                ..touching()
            },
        }
    };
    match g.outcome {
        GjkOutcome::Separated | GjkOutcome::IterationCap => {
            if g.outcome == GjkOutcome::IterationCap {
                // GJK stalled without a separating plane: its distance is
                // only an upper bound, and the bodies may overlap (an
                // ellipsoid against a cuboid overlapping by 1e-7 came out
                // as apart by 2.5e-8; a superellipsoid against a cuboid
                // overlapping by 1e-10, as apart by 6e-13). Decide with the
                // boolean GJK and measure the depth from its tetrahedron.
                match gjk_enclose(sa, sb, rel.translation, opts.gjk_max_iterations) {
                    Enclosure::Enclosed(Some(simplex)) => {
                        return not_short(penetration(&simplex, iterations));
                    }
                    Enclosure::Enclosed(None) => {
                        // On a face of M: overlapping to rounding.
                        return not_short(Contact {
                            distance: -tol,
                            ..touching()
                        });
                    }
                    Enclosure::Separated | Enclosure::Undecided => {}
                }
            }
            let d = g.point_b - g.point_a;
            let len = d.norm();
            let normal = match face_normal(&g.simplex, g.simplex_len, polytopes, &rel.translation) {
                Some(n) => n,
                None if len > 0.0 => d / len,
                None => rel.translation.normalize(),
            };
            // Short of the tolerance, or stalled on polytopes without
            // telling overlap from touching: the distance is GJK's upper
            // bound only.
            let short = (g.outcome == GjkOutcome::Separated && g.distance - g.lower_bound > tol)
                || (g.outcome == GjkOutcome::IterationCap && polytopes);
            let contact = Contact {
                distance: g.distance,
                point_a: g.point_a,
                point_b: g.point_b,
                normal,
                status: if g.outcome == GjkOutcome::Separated {
                    Status::Converged { iterations }
                } else {
                    Status::IterationCap { iterations }
                },
                method: Method::Gjk,
                warm_start: None,
            };
            (contact, short)
        }
        GjkOutcome::Overlapping => {
            if g.simplex_len < 4 {
                // The origin is on the simplex: within rounding of touching.
                return not_short(touching());
            }
            not_short(penetration(&g.simplex, iterations))
        }
    }
}

/// The contact normal (A → B) of two polytopes from GJK's last simplex
/// when it is a triangle: the normal of that face of the Minkowski
/// difference M = A − B, turned outward (away from −t, M's centre, with
/// t B's centre in A's frame).
/// The closest point lies inside the triangle, so the normal is the
/// direction between the witness points, but computed from the corners
/// it is exact to rounding however close the bodies are, where the
/// witness points' difference, at a distance near the rounding of the
/// corners, points only roughly (1e-6 radians at a distance of 1e-10):
/// enough to miss a face lying on a face, and to send an impulse off
/// the line it acts along.
fn face_normal(simplex: &[Vertex; 4], len: usize, polytopes: bool, t: &V3) -> Option<V3> {
    if !(polytopes && len == 3) {
        return None;
    }
    let (w0, w1, w2) = (simplex[0].w, simplex[1].w, simplex[2].w);
    let n = (w1 - w0).cross(&(w2 - w0)).try_normalize(0.0)?;
    Some(if n.dot(&(w0 + t)) >= 0.0 { n } else { -n })
}
