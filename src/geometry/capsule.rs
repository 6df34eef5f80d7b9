//! Capsules (spherocylinders): the points within a radius of a segment.
//! An elongated ellipsoid fits in one tightly (see
//! [`Capsule::bounding_ellipsoid`]), and two capsules are apart when their
//! segments are farther apart than the radii: a cheap, exact pre-filter
//! before the contact function of needles.

use nalgebra::Vector3;

use super::Shape;

type V3 = Vector3<f64>;

/// A capsule in its body frame: the segment from −`half_length` to
/// +`half_length` along body x, and the radius about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// Half the length of the core segment.
    pub half_length: f64,
    /// Radius about the segment.
    pub radius: f64,
}

impl Capsule {
    /// The smallest capsule about body x that holds the ellipsoid of
    /// semi-axes `a` (along x) ≥ `b` ≥ `c`: radius b, half-length a − b.
    /// The ellipsoid lies in the spheroid (a, b, b), and a point of it at
    /// x ∈ [a − b, a] is within b of the segment's end because
    /// (x − a + b)² + b²(1 − x²/a²) ≤ b² ⇔ |x − a + b| ≤ b x / a, which
    /// holds for x ≤ a; for |x| ≤ a − b its distance to the axis is ≤ b.
    pub fn bounding_ellipsoid(a: f64, b: f64) -> Self {
        debug_assert!(a >= b);
        Self {
            half_length: a - b,
            radius: b,
        }
    }
}

/// The smallest of a few capsules that hold `shape`, with the body axis
/// (0, 1, 2 for x, y, z) its segment lies along: for an ellipsoid the one
/// of [`Capsule::bounding_ellipsoid`] about its longest axis; for any other
/// body the smaller (by volume) of its bounding sphere and the capsule
/// about its longest box axis whose radius reaches the box's edges there
/// (radius √(b² + c²), half-length a: the body lies in its oriented box).
pub fn bounding_capsule(shape: &Shape) -> (usize, Capsule) {
    let h = shape.obb_half_extents();
    let k = h.imax();
    let (b, c) = (h[(k + 1) % 3], h[(k + 2) % 3]);
    let sphere = Capsule {
        half_length: 0.0,
        radius: shape.bounding_radius(),
    };
    let capsule = match shape {
        Shape::Sphere(_) => sphere,
        Shape::Ellipsoid(_) => Capsule::bounding_ellipsoid(h[k], b.max(c)),
        Shape::Spherocylinder(s) => Capsule {
            half_length: s.half_length(),
            radius: s.radius(),
        },
        Shape::Superellipsoid(_) | Shape::Cuboid(_) | Shape::ConvexPolyhedron(_) => Capsule {
            half_length: h[k],
            radius: (b * b + c * c).sqrt(),
        },
    };
    if capsule.volume() < sphere.volume() {
        (k, capsule)
    } else {
        (k, sphere)
    }
}

impl Capsule {
    /// Its volume.
    pub fn volume(&self) -> f64 {
        let r = self.radius;
        std::f64::consts::PI * r * r * (2.0 * self.half_length + 4.0 / 3.0 * r)
    }
}

/// The squared distance between the segments c₁ ± ℓ₁u and c₂ ± ℓ₂v (`u`,
/// `v` unit vectors) with `d` = c₂ − c₁: the minimum over s ∈ [−ℓ₁, ℓ₁],
/// t ∈ [−ℓ₂, ℓ₂] of |d + t v − s u|², found by clamping the minimiser of
/// the lines to the first segment, the second parameter to its segment
/// for that point, and the first again for that (each step minimises a
/// convex function of one parameter over an interval, which reaches the
/// minimum over the rectangle).
#[inline(always)]
pub fn segment_distance_squared(d: &V3, u: &V3, l1: f64, v: &V3, l2: f64) -> f64 {
    let (s, t) = closest_segment_parameters(d, u, l1, v, l2);
    (d + v * t - u * s).norm_squared()
}

/// The parameters (s, t) of the closest points c₁ + s u and c₂ + t v of
/// the segments of [`segment_distance_squared`], found as it says.
#[inline(always)]
pub fn closest_segment_parameters(d: &V3, u: &V3, l1: f64, v: &V3, l2: f64) -> (f64, f64) {
    let b = u.dot(v);
    let c = u.dot(d);
    let f = v.dot(d);
    let det = 1.0 - b * b;
    // Nearly parallel lines make the quotient inexact, but only along the
    // valley where |d + t v − s u|² hardly changes (its curvature is det),
    // so the distance stays exact to rounding. Exactly parallel: every s
    // minimises the lines' distance; any is as good a start.
    let s = if det > 1e-300 {
        ((c - b * f) / det).clamp(-l1, l1)
    } else {
        c.clamp(-l1, l1)
    };
    let t = (b * s - f).clamp(-l2, l2);
    let s = (c + b * t).clamp(-l1, l1);
    (s, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a dense grid of both parameters (refined about its best
    /// point): the clamped solution is never farther than the grid's best
    /// and never more than rounding nearer (it is a point pair of the
    /// segments), for random, parallel and crossing segments.
    #[test]
    fn segment_distance_is_the_minimum_over_both_segments() {
        let mut u = crate::test_support::uniform(12);
        let unit = crate::test_support::unit_vector;
        for case in 0..600 {
            let a = unit(&mut u);
            let b = match case % 3 {
                0 => unit(&mut u),
                1 => a,                                     // parallel
                _ => (a + unit(&mut u) * 1e-7).normalize(), // nearly parallel
            };
            let d = V3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 4.0;
            let (l1, l2) = (2.0 * u(), 2.0 * u());
            let got = segment_distance_squared(&d, &a, l1, &b, l2);
            let at = |s: f64, t: f64| (d + b * t - a * s).norm_squared();
            let (mut best, mut bs, mut bt) = (f64::INFINITY, 0.0, 0.0);
            let n = 200;
            for i in 0..=n {
                for j in 0..=n {
                    let (s, t) = (
                        l1 * (2.0 * i as f64 / n as f64 - 1.0),
                        l2 * (2.0 * j as f64 / n as f64 - 1.0),
                    );
                    if at(s, t) < best {
                        (best, bs, bt) = (at(s, t), s, t);
                    }
                }
            }
            // Refine about the grid's best point.
            let (ds, dt) = (l1 / n as f64 * 2.0, l2 / n as f64 * 2.0);
            for i in 0..=n {
                for j in 0..=n {
                    let s = (bs + ds * (2.0 * i as f64 / n as f64 - 1.0)).clamp(-l1, l1);
                    let t = (bt + dt * (2.0 * j as f64 / n as f64 - 1.0)).clamp(-l2, l2);
                    best = best.min(at(s, t));
                }
            }
            assert!(
                got <= best + 1e-12,
                "case {case}: {got} above the grid's {best}"
            );
            assert!(
                got >= best - 1e-6 * (1.0 + best),
                "case {case}: {got} far below the grid's {best}"
            );
        }
    }

    /// Every shape's bounding capsule holds the body's support points in
    /// every direction (a convex body lies in a convex set iff its
    /// extreme points do, and the support points include them), and for
    /// needles it is the capsule, for cubes the bounding sphere.
    #[test]
    fn bounding_capsules_hold_their_bodies() {
        let mut u = crate::test_support::uniform(14);
        for text in [
            "Sphere(radius: 0.5)",
            "Ellipsoid(a: 0.5, b: 2.5, c: 0.5)",
            "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
            "Superellipsoid(a: 0.5, b: 0.5, c: 2.0, exponents: (4.0, 4.0, 4.0))",
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
            "Cuboid(a: 1.5, b: 0.3, c: 0.4)",
        ] {
            let shape: Shape = text.parse().unwrap();
            let (k, cap) = bounding_capsule(&shape);
            let mut most = f64::NEG_INFINITY;
            for _ in 0..20000 {
                let p = shape.support(&V3::new(u() - 0.5, u() - 0.5, u() - 0.5));
                let x = p[k].clamp(-cap.half_length, cap.half_length);
                let mut q = p;
                q[k] -= x;
                most = most.max(q.norm() - cap.radius);
            }
            assert!(most <= 1e-12, "{text}: a point {most} outside");
            assert!(
                cap.volume()
                    <= 4.0 / 3.0 * std::f64::consts::PI * shape.bounding_radius().powi(3) + 1e-12
            );
        }
        let needle: Shape = "Ellipsoid(a: 0.5, b: 2.5, c: 0.5)".parse().unwrap();
        assert_eq!(
            bounding_capsule(&needle),
            (
                1,
                Capsule {
                    half_length: 2.0,
                    radius: 0.5
                }
            )
        );
        let cube: Shape = "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap();
        assert_eq!(bounding_capsule(&cube).1.half_length, 0.0);
    }

    /// Points of the ellipsoid's surface lie in its bounding capsule, and
    /// the capsule is tight: its tips and waist touch the ellipsoid.
    #[test]
    fn the_bounding_capsule_holds_the_ellipsoid() {
        let mut u = crate::test_support::uniform(13);
        for (a, b, c) in [
            (2.5, 0.5, 0.5),
            (1.2, 1.0, 0.3),
            (3.0, 0.4, 0.1),
            (1.0, 1.0, 1.0),
        ] {
            let cap = Capsule::bounding_ellipsoid(a, b);
            let outside = |p: &V3| {
                let x = p.x.clamp(-cap.half_length, cap.half_length);
                (p - V3::new(x, 0.0, 0.0)).norm() - cap.radius
            };
            let mut most = f64::NEG_INFINITY;
            for _ in 0..20000 {
                let n = V3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
                let p = V3::new(a * n.x, b * n.y, c * n.z);
                most = most.max(outside(&p));
            }
            assert!(most <= 1e-12, "({a}, {b}, {c}): a point {most} outside");
            // Tight: the tip (a, 0, 0) and the waist (0, b, 0) are on it.
            assert!(outside(&V3::new(a, 0.0, 0.0)).abs() < 1e-12);
            assert!(outside(&V3::new(0.0, b, 0.0)).abs() < 1e-12);
        }
    }
}
