//! Cuboid–ellipsoid and cuboid–superellipsoid. A is the cuboid, B the
//! smooth body.
//!
//! Far from contact GJK on support points gives the distance. Near contact
//! GJK can stall (an ellipsoid against a cuboid's edge came out 1.6e-7
//! apart when it was 9.6e-8 apart, and undecided when they overlapped), so
//! there the distance is taken from the support functions directly: for
//! convex bodies the signed distance (the distance when apart, minus the
//! penetration depth when overlapping) is the largest gap between support
//! planes over unit directions n (A's frame, from A towards B),
//!
//!   D = max_n f(n),   f(n) = n·t − h_A(n) − h_B(−n),
//!
//! with t B's centre and h the support functions. Every value f(n) is a
//! lower bound on D, computed to rounding (no iteration), and the maximum is
//! flat, so an angle found to 1e-8 gives D to ~1e-16. The cuboid's h_A is
//! piecewise linear, so the maximum sits on one of its features: a face
//! (n a face normal: closed form), an edge (n in the plane normal to the
//! edge: a 1-D Newton search) or a vertex (n in the vertex's octant: 2-D).

use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

use super::convex;
use super::{Contact, DistanceOptions, Method, Relative, Status};
use crate::geometry::implicit::SmoothSurface;
use crate::geometry::roots::narrow_sign_change;
use crate::geometry::shape::Shape;

type V3 = Vector3<f64>;

/// Overlap: first the six face axes (the cuboid's and B's principal axes)
/// as candidate separating axes, and the two centre-inside tests, all exact
/// certificates; then GJK, where a separating plane or an enclosing simplex
/// is a certificate too; when GJK cannot decide, the sign of the exact
/// signed distance (touching counts as overlap).
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let half = a.obb_half_extents();
    let t = rel.translation;
    let r = &rel.rotation;
    // Both bodies are centrally symmetric: an axis n separates them iff
    // |t·n| > h_A(n) + h_B(n), h the support function.
    let h_b = |n: &Vector3<f64>| {
        let local = r.tr_mul(n);
        b.support(&local).dot(&local)
    };
    for i in 0..3 {
        let n = Vector3::ith(i, 1.0);
        if t[i].abs() > half[i] + h_b(&n) {
            return false;
        }
    }
    let semi = b.obb_half_extents();
    for j in 0..3 {
        let n = r.column(j);
        let h_a = half.x * n.x.abs() + half.y * n.y.abs() + half.z * n.z.abs();
        if t.dot(&n).abs() > h_a + semi[j] {
            return false;
        }
    }
    if (0..3).all(|i| t[i].abs() <= half[i]) {
        return true; // B's centre is inside the cuboid
    }
    match convex::intersect(a, b, rel, 200) {
        Some(overlapping) => overlapping,
        // Within rounding of touching: the distance decides (a failed one,
        // NaN, counts as overlap: no move is accepted on an undecided test).
        None => super::strains::settle(distance(a, b, rel, &DistanceOptions::default()).distance),
    }
}

/// Overlaps deeper than this (in units of the smaller body's smallest
/// half-extent) keep EPA's depth: the feature search finds the local
/// maximum of f next to EPA's normal, which is the global one near contact.
const POLISH_DEPTH: f64 = 0.1;

/// GJK's distance is trusted beyond this (units of `len`). Nearer contact
/// it can be wrong even when it reports convergence: 1.556e-7 for a pair
/// 1.427e-7 apart (its upper bound, the norm of the simplex point, loses
/// accuracy on the thin simplices of an edge contact).
const TRUST_GJK: f64 = 1e-2;

/// Signed distance: GJK when it converges well apart; otherwise (near
/// contact, GJK stalled, or overlapping) the maximum support gap over the
/// cuboid's features, started from GJK's normal.
pub fn distance(a: &Shape, b: &Shape, rel: &Relative, opts: &DistanceOptions) -> Contact {
    let g = convex::distance(a, b, rel, opts);
    let len = a.min_half_extent().min(b.min_half_extent());
    if g.method == Method::Gjk && g.is_converged() && g.distance > TRUST_GJK * len {
        return g;
    }
    if g.distance < -POLISH_DEPTH * len && !matches!(g.status, Status::IterationCap { .. }) {
        return g;
    }
    let gap = SupportGap {
        half: a.obb_half_extents(),
        b,
        rel,
        len,
    };
    gap.maximum(&g.normal).unwrap_or(g)
}

/// The support gap f(n) of the cuboid (half-extents `half`) and B.
struct SupportGap<'s> {
    half: V3,
    b: &'s Shape,
    rel: &'s Relative,
    /// Length unit of the tolerances.
    len: f64,
}

/// How far (units of `len`) a witness may lie outside its feature and still
/// count as on it (the neighbouring feature then gives the same gap).
const FEATURE_SLACK: f64 = 1e-12;
/// How far (radians) a normal may lie outside its feature's directions.
const DIRECTION_SLACK: f64 = 1e-9;
const MAX_ITERATIONS: u32 = 60;

/// One local maximum of f: its value, direction and B's witness point.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    gap: f64,
    normal: V3,
    point_b: V3,
    iterations: u32,
}

impl SupportGap<'_> {
    /// B's point farthest along −n (towards A), in A's frame.
    fn point_b(&self, n: &V3) -> V3 {
        self.rel
            .b_to_a(&self.b.support(&-self.rel.rotation.tr_mul(n)))
    }

    /// The largest support gap over the features next to direction
    /// `start` (the three faces, three edges and the vertex of its octant),
    /// or over all 26 features when none of those holds a positive one.
    ///
    /// g(n) = min over A and B of n·(x_B − x_A) is concave and positively
    /// homogeneous, so a feature's maximum with a positive gap is the
    /// maximum over the unit ball, hence the distance. A negative one need
    /// not be: a pair apart also has stationary points of g on the sphere
    /// facing away from B (Euler: ∇g = g n there, so g < 0), and a poor
    /// start (GJK's normal where GJK stalled) led the octant search to the
    /// face of such a point, −2.75 for a pair 6.3e-6 apart.
    fn maximum(&self, start: &V3) -> Option<Contact> {
        let sigma = start.map(|x| if x < 0.0 { -1.0 } else { 1.0 });
        let octant = self.best((1..8u8).map(|mask| (sigma, mask)), start);
        let best = octant.filter(|c| c.gap > 0.0).or_else(|| {
            let all = (0..8u8).flat_map(|s| {
                let sigma = V3::from_fn(|i, _| if s >> i & 1 == 1 { -1.0 } else { 1.0 });
                // Each feature once: a free axis takes its sign from s, a
                // fixed one only with s's bit clear.
                (1..8u8)
                    .filter(move |mask| (0..3).all(|i| mask >> i & 1 == 1 || s >> i & 1 == 0))
                    .map(move |mask| (sigma, mask))
            });
            self.best(all, start)
        })?;
        let n = best.normal;
        Some(Contact {
            distance: best.gap,
            point_a: best.point_b - n * best.gap,
            point_b: best.point_b,
            normal: n,
            status: Status::Converged {
                iterations: best.iterations,
            },
            method: Method::SupportGap,
            warm_start: None,
        })
    }

    fn best(&self, features: impl Iterator<Item = (V3, u8)>, start: &V3) -> Option<Candidate> {
        features
            .filter_map(|(sigma, mask)| self.feature(&sigma, mask, start))
            .max_by(|p, q| p.gap.total_cmp(&q.gap))
    }

    /// The maximum of f on one feature: the axes in `mask` are free (n's
    /// components there have the signs `sigma`), the others are zero. One
    /// free axis is a face, two an edge, three a vertex. `None` when the
    /// maximum is not on the feature (the witness is off it, or n leaves
    /// the feature's directions) or the search does not converge.
    fn feature(&self, sigma: &V3, mask: u8, start: &V3) -> Option<Candidate> {
        let free = [mask & 1 != 0, mask & 2 != 0, mask & 4 != 0];
        let slack = FEATURE_SLACK * self.len;
        // The feature's point with zero components along the axes n is
        // normal to: n·v = h_A(n) for every n of the feature.
        let v = V3::from_fn(|i, _| {
            if free[i] {
                sigma[i] * self.half[i]
            } else {
                0.0
            }
        });
        let on_feature = |p: &V3| (0..3).all(|i| free[i] || p[i].abs() <= self.half[i] + slack);
        let candidate = match free.iter().filter(|&&f| f).count() {
            1 => {
                // A face: closed form.
                let i = free.iter().position(|&f| f)?;
                let n = V3::ith(i, sigma[i]);
                let p = self.point_b(&n);
                Candidate {
                    gap: n.dot(&(p - v)),
                    normal: n,
                    point_b: p,
                    iterations: 0,
                }
            }
            2 => self.edge(sigma, &free, &v)?,
            _ => match self.b {
                Shape::Ellipsoid(e) => self.vertex(e, &v, start)?,
                Shape::Superellipsoid(s) => self.vertex(s, &v, start)?,
                _ => return None,
            },
        };
        let n = candidate.normal;
        let inside = (0..3).all(|i| {
            if free[i] {
                sigma[i] * n[i] >= -DIRECTION_SLACK
            } else {
                n[i] == 0.0
            }
        });
        (inside && on_feature(&candidate.point_b)).then_some(candidate)
    }

    /// An edge (free axes i < j): n = σᵢ cos φ eᵢ + σⱼ sin φ eⱼ, φ in
    /// [0, π/2]; the maximum of f(φ) where df/dφ = n′·(p_B − v) changes sign,
    /// found by bracketing (B's support may turn infinitely fast at a
    /// superellipsoid's flat face, where Newton steps overshoot).
    fn edge(&self, sigma: &V3, free: &[bool; 3], v: &V3) -> Option<Candidate> {
        let i = free.iter().position(|&f| f)?;
        let j = free.iter().rposition(|&f| f)?;
        let normal = |phi: f64| {
            let mut n = V3::zeros();
            n[i] = sigma[i] * phi.cos();
            n[j] = sigma[j] * phi.sin();
            n
        };
        let slope = |phi: f64| {
            let mut dn = V3::zeros();
            dn[i] = -sigma[i] * phi.sin();
            dn[j] = sigma[j] * phi.cos();
            dn.dot(&(self.point_b(&normal(phi)) - v))
        };
        let quarter = std::f64::consts::FRAC_PI_2;
        let (s0, s1) = (slope(0.0), slope(quarter));
        if !(s0 > 0.0 && s1 < 0.0) {
            return None; // the maximum is at a face (or f is flat)
        }
        let (lo, _, hi, _, evals) = narrow_sign_change(slope, (0.0, s0), (quarter, s1), 0.0, 200);
        let n = normal(0.5 * (lo + hi));
        let p = self.point_b(&n);
        Some(Candidate {
            gap: n.dot(&(p - v)),
            normal: n,
            point_b: p,
            iterations: evals + 2,
        })
    }

    /// A vertex v: the point of B's surface nearest to v (farthest inside,
    /// when v is inside B), by Newton on x − v + λ∇F(x) = 0, F(x) = 0 in B's
    /// frame. Primal rather than over directions: at a superellipsoid's flat
    /// face the surface is flat but its support map turns infinitely fast.
    fn vertex<S: SmoothSurface>(&self, s: &S, v: &V3, start: &V3) -> Option<Candidate> {
        let r = &self.rel.rotation;
        let u = r.tr_mul(&(v - self.rel.translation)); // v in B's frame
        let size = s.semi_axes().min();
        let mut x = self.b.support(&-r.tr_mul(start));
        let grad = s.implicit(&x).gradient;
        let mut lambda = (u - x).dot(&grad) / grad.norm_squared();
        let residual = |x: &V3, lambda: f64| {
            let f = s.implicit(x);
            let r1 = x - u + f.gradient * lambda;
            Vector4::new(r1.x, r1.y, r1.z, f.value)
        };
        let mut res = residual(&x, lambda);
        for iteration in 1..=MAX_ITERATIONS {
            let f = s.implicit(&x);
            let mut jac = Matrix4::zeros();
            jac.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(Matrix3::identity() + f.hessian * lambda));
            jac.fixed_view_mut::<3, 1>(0, 3).copy_from(&f.gradient);
            jac.fixed_view_mut::<1, 3>(3, 0)
                .copy_from(&f.gradient.transpose());
            let step = jac.lu().solve(&-res)?;
            let mut dx = step.xyz();
            let mut dl = step[3];
            // At most a quarter of B's smallest semi-axis per step.
            let cap = 0.25 * size / dx.norm().max(f64::MIN_POSITIVE);
            if cap < 1.0 {
                dx *= cap;
                dl *= cap;
            }
            let small = dx.norm() <= 1e-13 * size;
            // Backtrack while the residual grows (beyond rounding).
            let mut accepted = false;
            for _ in 0..30 {
                let trial = residual(&(x + dx), lambda + dl);
                if trial.norm() <= res.norm() * (1.0 + 1e-12) + 1e-15 || small {
                    x += dx;
                    lambda += dl;
                    res = trial;
                    accepted = true;
                    break;
                }
                dx *= 0.5;
                dl *= 0.5;
            }
            if !accepted {
                return None;
            }
            if small {
                let outward = s.implicit(&x).gradient.normalize();
                let n = -(r * outward);
                let gap = outward.dot(&(u - x));
                return Some(Candidate {
                    gap,
                    normal: n,
                    point_b: self.rel.b_to_a(&x),
                    iterations: iteration,
                });
            }
        }
        None
    }
}
