//! Pairs of smooth bodies (sphere, ellipsoid, superellipsoid): De Michele's
//! Newton–Raphson distance, with GJK as the certified fallback; and the
//! overlap of pairs with a superellipsoid (GJK, then Newton where GJK cannot
//! decide).

use super::{Contact, DistanceOptions, Relative, Status};
use super::{convex, quadric_quadric};
use crate::geometry::contact::WarmStart;
use crate::geometry::implicit::SmoothSurface;
use crate::geometry::newton::{SteepestDescent, newton_distance};
use crate::geometry::shape::Shape;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Overlap for pairs with a superellipsoid.
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    match convex::intersect(a, b, rel, 200) {
        Some(answer) => answer,
        // Within rounding of touching: ask Newton; touching counts.
        None => {
            super::strains::settle(distance(a, b, rel, &DistanceOptions::default(), None).distance)
        }
    }
}

/// Signed distance of two smooth bodies.
pub fn distance(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
    opts: &DistanceOptions,
    warm: Option<&WarmStart>,
) -> Contact {
    match a {
        Shape::Sphere(x) => with_b(x, a, b, rel, opts, warm),
        Shape::Ellipsoid(x) => with_b(x, a, b, rel, opts, warm),
        Shape::Superellipsoid(x) => with_b(x, a, b, rel, opts, warm),
        Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => {
            unreachable!("smooth_smooth::distance called with a body that is not smooth")
        }
    }
}

fn with_b<A: SmoothSurface>(
    a: &A,
    shape_a: &Shape,
    shape_b: &Shape,
    rel: &Relative,
    opts: &DistanceOptions,
    warm: Option<&WarmStart>,
) -> Contact {
    match shape_b {
        Shape::Sphere(y) => robust(a, y, shape_a, shape_b, rel, opts, warm),
        Shape::Ellipsoid(y) => robust(a, y, shape_a, shape_b, rel, opts, warm),
        Shape::Superellipsoid(y) => robust(a, y, shape_a, shape_b, rel, opts, warm),
        Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => {
            unreachable!("smooth_smooth::distance called with a body that is not smooth")
        }
    }
}

/// Newton from the paper's guess; if it does not converge, GJK (separated)
/// whose witness points restart Newton, or EPA (overlapping). Never returns
/// an unconverged number as if it were the distance: the status says.
fn robust<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    shape_a: &Shape,
    shape_b: &Shape,
    rel: &Relative,
    opts: &DistanceOptions,
    warm: Option<&WarmStart>,
) -> Contact {
    if rel.translation.norm_squared() > 0.0 {
        // Spheres and ellipsoids start cold from the Perram–Wertheim contact
        // point (close to the solution for close bodies) rather than from
        // the centre line and a descent.
        let guess = match warm {
            None if is_quadric(shape_a) && is_quadric(shape_b) => {
                quadric_quadric::contact_points_guess(shape_a, shape_b, rel)
                    .map(|(xa, xb)| start_at(a, b, rel, xa, xb))
            }
            // Superellipsoids: from the centre line.
            None => support_points_start(shape_a, shape_b, rel, &rel.translation.normalize()),
            Some(_) => None,
        };
        let start = warm.or(guess.as_ref());
        let c = newton_distance(a, b, rel, &opts.newton, start);
        if c.is_converged() {
            return c;
        }
        // A start that led Newton astray (support points of a flat
        // superellipsoid against a flat ellipsoid can cycle without end):
        // the cold start from the centre line, refined by steepest descent,
        // before GJK, whose convergence on curved bodies near contact is
        // only linear and may stop short of the tolerance.
        if start.is_some() {
            let c = newton_distance(a, b, rel, &opts.newton, None);
            if c.is_converged() {
                return c;
            }
        }
    }
    let g = convex::distance(shape_a, shape_b, rel, opts);
    if g.distance > 0.0 {
        if g.is_converged() {
            let start = start_at(a, b, rel, g.point_a, g.point_b);
            let mut newton = opts.newton;
            newton.steepest_descent = SteepestDescent::Never;
            let c = newton_distance(a, b, rel, &newton, Some(&start));
            if c.is_converged() {
                return c;
            }
        }
        return g;
    }
    Contact {
        status: Status::DeepOverlap,
        ..g
    }
}

/// Newton's start from a point of each surface (both in A's frame), with
/// the multiplier α of eq. (9a) that balances their gradients.
fn start_at<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
    point_a: V3,
    point_b: V3,
) -> WarmStart {
    let local_b = rel.rotation.tr_mul(&(point_b - rel.translation));
    balanced_start(
        point_a,
        local_b,
        a.implicit(&point_a).gradient.norm(),
        b.implicit(&local_b).gradient.norm(),
    )
}

/// The start at `point_a` (A's frame) and `point_b` (B's frame), whose
/// surfaces' gradients there have norms `grad_a` and `grad_b`:
/// α = √(|∇f_A| / |∇f_B|).
fn balanced_start(point_a: V3, point_b: V3, grad_a: f64, grad_b: f64) -> WarmStart {
    WarmStart {
        point_a,
        point_b,
        alpha: (grad_a / grad_b).sqrt(),
    }
}

/// Spheres and ellipsoids: the bodies the Perram–Wertheim function covers.
fn is_quadric(s: &Shape) -> bool {
    matches!(s, Shape::Sphere(_) | Shape::Ellipsoid(_))
}

/// A cold start for the distance equations of smooth bodies from the
/// support points along the direction that (nearly) maximises the
/// support-plane gap, where the equations are solved: the gap ascended to a
/// thousandth from `hint` (A's frame). For pairs with a superellipsoid the
/// centre line and a steepest descent took 8-13 Newton iterations more.
/// `None` unless the pair is smooth with a superellipsoid (spheres and
/// ellipsoids start from the Perram–Wertheim contact point).
pub fn support_points_start(a: &Shape, b: &Shape, rel: &Relative, hint: &V3) -> Option<WarmStart> {
    // Newton's surfaces only (a spherocylinder has none: GJK finds its
    // contacts).
    let newton = |s: &Shape| {
        matches!(
            s,
            Shape::Sphere(_) | Shape::Ellipsoid(_) | Shape::Superellipsoid(_)
        )
    };
    if !(newton(a) && newton(b)) || (is_quadric(a) && is_quadric(b)) {
        return None;
    }
    let (_, n) = super::support_gap_ascent(a, b, rel, *hint, 1e-3);
    let xa = a.support(&n);
    let local_b = b.support(&rel.rotation.tr_mul(&-n));
    let gradient_norm = |s: &Shape, x: &V3| match s {
        Shape::Sphere(q) => q.implicit(x).gradient.norm(),
        Shape::Ellipsoid(q) => q.implicit(x).gradient.norm(),
        Shape::Superellipsoid(q) => q.implicit(x).gradient.norm(),
        Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => unreachable!(),
    };
    Some(balanced_start(
        xa,
        local_b,
        gradient_norm(a, &xa),
        gradient_norm(b, &local_b),
    ))
}
