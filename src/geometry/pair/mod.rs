//! The pair dispatch: one overlap test and one signed distance for every
//! unordered pair of the shapes, one file per pair kind.
//!
//! Frame convention, on every pair function: the kernel works in A's body
//! frame, with A at the origin; B's centre is `rel.translation`
//! (= q_A⁻¹ (r_B − r_A), with r_B − r_A already minimum-imaged by the caller)
//! and B's body axes are the columns of `rel.rotation` (= q_A⁻¹ q_B).
//! Points and normals in a [`Contact`] are in that frame too.

mod convex;
mod cuboid_cuboid;
mod cuboid_smooth;
mod cuboid_sphere;
mod features;
mod patch;
mod polyhedron;
mod quadric_quadric;
mod smooth_smooth;
mod sphere_sphere;
mod spherocylinder;
mod spheropolyhedron;
mod strains;

use nalgebra::{Matrix3, Vector3};

use super::contact::WarmStart;
pub use super::contact::{Contact, Failure, Method, Relative, Status};
use super::newton::NewtonOptions;
use super::polyhedron::MAX_VERTICES;
use super::shape::Shape;

pub use patch::{ContactPatch, MAX_PATCH};
pub use quadric_quadric::{Spheroid, perram_wertheim, spheroid_overlap};
pub use smooth_smooth::support_points_start;
pub use strains::{OverlapStrains, counting_strains};

type V3 = Vector3<f64>;

/// Options of the distance kernels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceOptions {
    /// Newton–Raphson knobs (smooth pairs).
    pub newton: NewtonOptions,
    /// GJK/EPA absolute tolerance, in units of the smaller body's smallest
    /// half-extent.
    pub gjk_tolerance: f64,
    /// GJK/EPA iteration cap.
    pub gjk_max_iterations: usize,
}

impl Default for DistanceOptions {
    fn default() -> Self {
        Self {
            newton: NewtonOptions::default(),
            gjk_tolerance: 1e-12,
            gjk_max_iterations: 1000,
        }
    }
}

/// Whether bodies `a` and `b` overlap (B placed by `rel` in A's frame).
/// Touching counts as overlap. Every test starts with the bounding spheres.
///
/// ```
/// use hardbody::geometry::{Relative, Shape, overlap};
/// use nalgebra::{UnitQuaternion, Vector3};
///
/// let rod: Shape = "Ellipsoid(a: 1.5, b: 0.5, c: 0.5)".parse().unwrap();
/// let aligned = UnitQuaternion::identity();
/// // Side by side 1.1 apart along y: clear; end to end along x: overlap.
/// let side = Relative::new(&Vector3::new(0.0, 1.1, 0.0), &aligned, &aligned);
/// let end = Relative::new(&Vector3::new(2.9, 0.0, 0.0), &aligned, &aligned);
/// assert!(!overlap(&rod, &rod, &side));
/// assert!(overlap(&rod, &rod, &end));
/// ```
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let reach = a.bounding_radius() + b.bounding_radius();
    if rel.translation.norm_squared() > reach * reach {
        return false;
    }
    use Shape::*;
    // The oriented bounding boxes next (15 axes, ~20 ns): for elongated or
    // flat bodies they reject most pairs whose bounding spheres meet, before
    // the exact tests (Perram–Wertheim, GJK) that cost far more.
    let needs_obb = matches!(
        (a, b),
        (
            Ellipsoid(_) | Superellipsoid(_) | Spherocylinder(_) | ConvexPolyhedron(_),
            _
        ) | (
            _,
            Ellipsoid(_) | Superellipsoid(_) | Spherocylinder(_) | ConvexPolyhedron(_)
        )
    );
    if needs_obb
        && !crate::geometry::obb::boxes_overlap(
            &a.obb_half_extents(),
            &b.obb_half_extents(),
            &rel.rotation,
            &rel.translation,
        )
    {
        return false;
    }
    match (a, b) {
        _ if swept_cores(a, b) => spheropolyhedron::overlap(a, b, rel),
        (ConvexPolyhedron(_), _) | (_, ConvexPolyhedron(_)) => polyhedron::overlap(a, b, rel),
        (Spherocylinder(_), _) | (_, Spherocylinder(_)) => spherocylinder::overlap(a, b, rel),
        (Sphere(p), Sphere(q)) => sphere_sphere::overlap(p, q, rel),
        (Cuboid(c), Sphere(s)) => cuboid_sphere::overlap(c, s, rel),
        (Sphere(s), Cuboid(c)) => cuboid_sphere::overlap(c, s, &rel.inverse()),
        (Cuboid(p), Cuboid(q)) => cuboid_cuboid::overlap(p, q, rel),
        (Sphere(_) | Ellipsoid(_), Sphere(_) | Ellipsoid(_)) => quadric_quadric::overlap(a, b, rel),
        (Superellipsoid(_), Sphere(_) | Ellipsoid(_) | Superellipsoid(_))
        | (Sphere(_) | Ellipsoid(_), Superellipsoid(_)) => smooth_smooth::overlap(a, b, rel),
        (Cuboid(_), Ellipsoid(_) | Superellipsoid(_)) => cuboid_smooth::overlap(a, b, rel),
        (Ellipsoid(_) | Superellipsoid(_), Cuboid(_)) => {
            cuboid_smooth::overlap(b, a, &rel.inverse())
        }
    }
}

/// Whether `shape` is a spheropolyhedron (a polyhedron with a rounding).
fn is_rounded(shape: &Shape) -> bool {
    matches!(shape, Shape::ConvexPolyhedron(p) if p.rounding() > 0.0)
}

/// Whether the pair is best taken as two polytope cores (a point and a
/// segment among them) swept by balls: a spheropolyhedron with anything,
/// a polyhedron with a sphere or a spherocylinder, a spherocylinder with
/// a cuboid. GJK between such cores ends exactly in finitely many steps,
/// where on the rounded surfaces it would converge only linearly.
fn swept_cores(a: &Shape, b: &Shape) -> bool {
    use Shape::*;
    let one_way = |p: &Shape, q: &Shape| {
        matches!(
            (p, q),
            (ConvexPolyhedron(_), Sphere(_) | Spherocylinder(_)) | (Cuboid(_), Spherocylinder(_))
        )
    };
    is_rounded(a) || is_rounded(b) || one_way(a, b) || one_way(b, a)
}

/// A body's shape as placed in the lab frame (its rotation applied), for a
/// driver to keep per particle: overlap tests against it can then work in
/// the lab frame without building the relative pose, where a kernel allows
/// (spheres and ellipsoids: the Perram–Wertheim test takes lab-frame shape
/// matrices as they are).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Placed {
    /// A sphere of this radius.
    Sphere(f64),
    /// An ellipsoid's shape matrix R diag(a², b², c²) Rᵀ.
    Quadric(Matrix3<f64>),
    /// An ellipsoid with two equal semi-axes, by its axis of symmetry.
    Spheroid(Spheroid),
    /// Any other shape: use [`overlap`] with the relative pose.
    Other,
}

impl Placed {
    /// `shape` turned by `rotation` (body → lab).
    pub fn new(shape: &Shape, rotation: &Matrix3<f64>) -> Self {
        match shape {
            Shape::Sphere(s) => Placed::Sphere(s.radius()),
            Shape::Ellipsoid(_) => {
                let h = shape.obb_half_extents();
                // The odd semi-axis k of a spheroid: the other two equal.
                let odd = (0..3).find(|&k| h[(k + 1) % 3] == h[(k + 2) % 3]);
                match odd {
                    Some(k) => {
                        let e = h[(k + 1) % 3] * h[(k + 1) % 3];
                        Placed::Spheroid(Spheroid {
                            axis: rotation.column(k).into(),
                            equatorial_sq: e,
                            excess: h[k] * h[k] - e,
                        })
                    }
                    None => Placed::Quadric(
                        rotation
                            * Matrix3::from_diagonal(&h.component_mul(&h))
                            * rotation.transpose(),
                    ),
                }
            }
            _ => Placed::Other,
        }
    }

    fn matrix(&self) -> Option<Matrix3<f64>> {
        match *self {
            Placed::Sphere(r) => Some(Matrix3::from_diagonal_element(r * r)),
            Placed::Quadric(m) => Some(m),
            Placed::Spheroid(s) => Some(s.matrix()),
            Placed::Other => None,
        }
    }
}

/// Whether placed bodies `a` and `b` with centres `d = r_b − r_a` apart
/// (lab frame, minimum-imaged) overlap, when a lab-frame kernel covers the
/// pair (spheres and ellipsoids); `None` otherwise. Agrees with [`overlap`]
/// on the same pair up to rounding.
#[inline]
pub fn placed_overlap(a: &Placed, b: &Placed, d: &V3) -> Option<bool> {
    match (a, b) {
        (Placed::Sphere(p), Placed::Sphere(q)) => {
            return Some(sphere_sphere::overlap_at(*p, *q, d));
        }
        (Placed::Spheroid(p), Placed::Spheroid(q)) => return Some(spheroid_overlap(p, q, d)),
        _ => {}
    }
    // Straight to the contact function: its first evaluation rejects most
    // pairs for less than the oriented-box test would cost.
    Some(perram_wertheim(&a.matrix()?, &b.matrix()?, d))
}

/// Signed distance between `a` and `b` (B placed by `rel` in A's frame),
/// with the contact points and normal; `warm` is a previous result for the
/// same pair (used by the Newton solver).
pub fn distance(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
    opts: &DistanceOptions,
    warm: Option<&WarmStart>,
) -> Contact {
    use Shape::*;
    match (a, b) {
        _ if swept_cores(a, b) => spheropolyhedron::distance(a, b, rel, opts),
        (ConvexPolyhedron(_), _) | (_, ConvexPolyhedron(_)) => {
            polyhedron::distance(a, b, rel, opts)
        }
        (Spherocylinder(_), _) | (_, Spherocylinder(_)) => {
            spherocylinder::distance(a, b, rel, opts)
        }
        (Sphere(p), Sphere(q)) => sphere_sphere::distance(p, q, rel),
        (Cuboid(c), Sphere(s)) => cuboid_sphere::distance(c, s, rel),
        (Sphere(s), Cuboid(c)) => cuboid_sphere::distance(c, s, &rel.inverse()).swapped(rel),
        (Cuboid(p), Cuboid(q)) => cuboid_cuboid::distance(p, q, rel, opts),
        (
            Sphere(_) | Ellipsoid(_) | Superellipsoid(_),
            Sphere(_) | Ellipsoid(_) | Superellipsoid(_),
        ) => smooth_smooth::distance(a, b, rel, opts, warm),
        (Cuboid(_), Ellipsoid(_) | Superellipsoid(_)) => cuboid_smooth::distance(a, b, rel, opts),
        (Ellipsoid(_) | Superellipsoid(_), Cuboid(_)) => {
            cuboid_smooth::distance(b, a, &rel.inverse(), opts).swapped(rel)
        }
    }
}

/// Where bodies touching with `normal` (A → B, A's frame) touch along a
/// flat feature of each: a face or an edge of each body's core within
/// `tolerance` of the contact plane, the cores being polytopes (cuboids,
/// polyhedra and spheropolyhedra, a spherocylinder's axis segment): the
/// corners of the shared region, on which a collision acts at once (see
/// [`ContactPatch`]). Empty for every other pair and contact: smooth
/// bodies touch at a point.
pub fn contact_patch(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
    normal: &V3,
    tolerance: f64,
) -> ContactPatch {
    let (Some((corners_a, na)), Some((mut corners_b, nb))) = (core_corners(a), core_corners(b))
    else {
        return ContactPatch::none();
    };
    if na < 2 && nb < 2 {
        return ContactPatch::none();
    }
    for v in &mut corners_b[..nb] {
        *v = rel.b_to_a(v);
    }
    patch::polytope_patch(&corners_a[..na], &corners_b[..nb], normal, tolerance)
}

/// The corners of a body's polytope core, and how many: a cuboid's eight,
/// a polyhedron's (a spheropolyhedron's core's), a spherocylinder's axis
/// ends, a sphere's centre; None for curved bodies.
fn core_corners(shape: &Shape) -> Option<([V3; MAX_VERTICES], usize)> {
    let mut corners = [V3::zeros(); MAX_VERTICES];
    let n = match shape {
        Shape::Sphere(_) => 1,
        Shape::Spherocylinder(s) => {
            corners[0] = V3::new(0.0, 0.0, s.half_length());
            corners[1] = -corners[0];
            2
        }
        Shape::Cuboid(c) => {
            let h = c.half_extents();
            for (k, v) in corners.iter_mut().take(8).enumerate() {
                let s = |bit: usize| if k & bit == 0 { -1.0 } else { 1.0 };
                *v = V3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z);
            }
            8
        }
        Shape::ConvexPolyhedron(p) => {
            let scale = p.scale();
            let vertices = p.hull().vertices();
            for (v, c) in corners.iter_mut().zip(vertices) {
                *v = c * scale;
            }
            vertices.len()
        }
        Shape::Ellipsoid(_) | Shape::Superellipsoid(_) => return None,
    };
    Some((corners, n))
}

/// A lower bound on the distance of `a` and `b` (B placed by `rel` in A's
/// frame), far cheaper than [`distance`]: for spheres and ellipsoids the
/// bound from the Perram–Wertheim scaling factor; otherwise the larger of
/// the gap along the centre line between the bodies' support planes and
/// the largest gap of their oriented bounding boxes over the 15 separating
/// axes (each the separation of the projections on one axis, which no two
/// points of the bodies can beat). Not positive when it cannot tell the
/// bodies apart (a negative value is not a penetration depth). With it, a
/// unit direction (A's frame, from A towards B) along which the bodies are
/// well separated: the Perram–Wertheim normal, the centre line or the best
/// box axis, a start for bounds on the separation along a fixed direction.
pub fn distance_lower_bound(a: &Shape, b: &Shape, rel: &Relative) -> (f64, V3) {
    distance_lower_bound_near(a, b, rel, None)
}

/// [`distance_lower_bound`], told a direction (A's frame) along which the
/// bodies were well apart a moment ago, e.g. the previous step's normal in
/// a collision search: pairs with a superellipsoid start their ascent of
/// the support-plane gap there instead of at the centre line.
pub fn distance_lower_bound_near(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
    hint: Option<&V3>,
) -> (f64, V3) {
    use Shape::*;
    if let (Sphere(_) | Ellipsoid(_), Sphere(_) | Ellipsoid(_)) = (a, b) {
        // Tight for ellipsoids side by side; the others add little.
        return quadric_quadric::distance_lower_bound(a, b, rel);
    }
    let t = rel.translation;
    let smooth = !matches!(a, Cuboid(_)) && !matches!(b, Cuboid(_));
    if let (Some(hint), true) = (hint, smooth) {
        let (boxes, axis) = crate::geometry::obb::max_axis_separation(
            &a.obb_half_extents(),
            &b.obb_half_extents(),
            &rel.rotation,
            &t,
        );
        let (gap, normal) = support_gap_ascent(a, b, rel, *hint, 0.05);
        return if boxes > gap {
            (boxes, axis)
        } else {
            (gap, normal)
        };
    }
    if let (Cuboid(_), Cuboid(_)) = (a, b) {
        // The 15 axes are the boxes' own: the line of centres beats them
        // in under 0.2 % of a dense cube fluid's bounds, not worth its
        // two support points each time.
        return crate::geometry::obb::max_axis_separation(
            &a.obb_half_extents(),
            &b.obb_half_extents(),
            &rel.rotation,
            &t,
        );
    }
    let len = t.norm();
    let (along_centres, u) = if len > 0.0 {
        let u = t / len;
        let u_b = -rel.rotation.tr_mul(&u);
        (len - u.dot(&a.support(&u)) - u_b.dot(&b.support(&u_b)), u)
    } else {
        (f64::NEG_INFINITY, V3::x())
    };
    let (boxes, axis) = crate::geometry::obb::max_axis_separation(
        &a.obb_half_extents(),
        &b.obb_half_extents(),
        &rel.rotation,
        &t,
    );
    let (best, normal) = if boxes > along_centres {
        (boxes, axis)
    } else {
        (along_centres, u)
    };
    if !smooth {
        // A cuboid's support point jumps from vertex to vertex: the ascent
        // below has no gradient to follow.
        return (best, normal);
    }
    let (gap, normal) = support_gap_ascent(a, b, rel, normal, 0.05);
    (gap.max(best), normal)
}

/// Raises the support-plane gap f(n) = n·t − h_A(n) − h_B(−n) (a lower
/// bound on the distance for every unit n; its maximum is the distance, or
/// minus the penetration depth of overlapping bodies, at the contact
/// normal) by gradient ascent on the unit sphere from the direction `n`
/// (A's frame). The gradient of f is w = x_B(−n) − x_A(n), the vector
/// between the support points, and f = n·w; on the sphere the Hessian is
/// −(ρ_A + ρ_B + f) across n (ρ the radii of curvature at the support
/// points), so the step is the tangential part of w over an estimate of
/// ρ_A + ρ_B + f (the bounding radii: exact for spheres); too short a step
/// only slows the ascent, and a step that lowers f is halved. Stops when a
/// full step promises less than `relative` of the gap (or after 8 steps
/// for a bound, 40 otherwise: see the callers). Smooth bodies only (a
/// cuboid's support map is piecewise constant). Returns the best f(n) less
/// a rounding margin, so that it stays a lower bound, and its n.
pub fn support_gap_ascent(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
    mut n: V3,
    relative: f64,
) -> (f64, V3) {
    let radii = a.bounding_radius() + b.bounding_radius();
    let margin = 1e-12 * (rel.translation.norm() + radii);
    let gap = |n: &V3| -> (f64, V3) {
        let x_a = a.support(n);
        let x_b = rel.b_to_a(&b.support(&rel.rotation.tr_mul(&-n)));
        let w = x_b - x_a;
        (n.dot(&w), w)
    };
    let (mut value, mut w) = gap(&n);
    // ρ_A + ρ_B: the bounding radii at first, then the curvature the last
    // step met, −Δw·Δn/|Δn|² (w changes by −(∇²h_A + ∇²h_B) Δn), which
    // follows a superellipsoid from its sharp edges to its flat faces.
    let mut rho = radii;
    let steps = if relative >= 0.01 { 8 } else { 40 };
    for _ in 0..steps {
        let tangent = w - n * value;
        let stiffness = rho + value.max(0.0);
        // The gain a full step promises, |g|²/2(ρ + f): once it is a small
        // part of the gap, the bound is as good as the caller needs.
        let gain = tangent.norm_squared() / (2.0 * stiffness);
        if gain <= 1e-12 * radii || gain <= relative * value.abs() {
            break;
        }
        let trial = (n + tangent / stiffness).normalize();
        let (v, w_trial) = gap(&trial);
        if v > value {
            let dn = trial - n;
            let curvature = -(w_trial - w).dot(&dn) / dn.norm_squared();
            rho = curvature.max(1e-3 * radii);
            n = trial;
            value = v;
            w = w_trial;
        } else {
            rho *= 4.0;
        }
    }
    (value - margin, n)
}

/// The centre–centre distance at which `a` and `b` touch, where it does not
/// depend on their orientations (two spheres): the event-driven driver then
/// predicts their contact in closed form
/// ([`sphere_sphere::contact_time`]).
pub fn contact_sum(a: &Shape, b: &Shape) -> Option<f64> {
    match (a, b) {
        (Shape::Sphere(p), Shape::Sphere(q)) => Some(p.radius() + q.radius()),
        _ => None,
    }
}

pub use sphere_sphere::contact_time as sphere_contact_time;
pub use sphere_sphere::contact_time_from_products as sphere_contact_time_from_products;
pub use sphere_sphere::contact_time_or_never as sphere_contact_time_or_never;
pub use sphere_sphere::contact_times_from_products as sphere_contact_times_from_products;
pub use sphere_sphere::grown_contact_time_from_products as grown_sphere_contact_time;

/// The kernels the dispatch uses for a pair of shapes: (overlap test,
/// distance), named for the plan a scene prints. Kept beside [`overlap`]
/// and [`distance`], whose `match` arms they mirror.
pub fn kernel_names(a: &Shape, b: &Shape) -> (&'static str, &'static str) {
    use Shape::*;
    match (a, b) {
        _ if swept_cores(a, b) => (
            "OBB, then GJK between the cores against the radii (the distance where GJK cannot decide)",
            "GJK/EPA between the cores, less the radii",
        ),
        (ConvexPolyhedron(_), _) | (_, ConvexPolyhedron(_)) => (
            "OBB, then GJK on support points (the distance where GJK cannot decide)",
            "GJK/EPA",
        ),
        (Spherocylinder(_), Spherocylinder(_) | Sphere(_)) | (Sphere(_), Spherocylinder(_)) => (
            "OBB, then segment distance",
            "closed form (closest points of the axis segments)",
        ),
        (Spherocylinder(_), _) | (_, Spherocylinder(_)) => (
            "OBB, then GJK on support points (the distance where GJK cannot decide)",
            "GJK/EPA",
        ),
        (Sphere(_), Sphere(_)) => ("centre distance", "closed form"),
        (Cuboid(_), Sphere(_)) | (Sphere(_), Cuboid(_)) => {
            ("OCSI (Tonti & Patti)", "OCSI closest point")
        }
        (Cuboid(_), Cuboid(_)) => (
            "separating axes (15)",
            "largest axis separation where its features face (and overlapping); GJK",
        ),
        (Sphere(_) | Ellipsoid(_), Sphere(_) | Ellipsoid(_)) => (
            "OBB, then Perram-Wertheim",
            "Newton-Raphson (De Michele), GJK fallback",
        ),
        (Superellipsoid(_), Sphere(_) | Ellipsoid(_) | Superellipsoid(_))
        | (Sphere(_) | Ellipsoid(_), Superellipsoid(_)) => (
            "OBB, then GJK (Newton where GJK cannot decide)",
            "Newton-Raphson (De Michele), GJK fallback",
        ),
        (Cuboid(_), Ellipsoid(_) | Superellipsoid(_))
        | (Ellipsoid(_) | Superellipsoid(_), Cuboid(_)) => (
            "OBB, then GJK on support points",
            "GJK; near contact the largest support-plane gap over the cuboid's features",
        ),
    }
}

/// The overlap test by GJK on support points alone, for any pair: the
/// independent second method the tests compare the pair kernels with.
pub fn overlap_by_gjk(a: &Shape, b: &Shape, rel: &Relative) -> Option<bool> {
    convex::intersect(a, b, rel, 10_000)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// The lab-frame kernels answer as the relative-pose dispatch does, on
    /// random sphere and ellipsoid pairs placed 1e-9 of the contact
    /// distance either side of touching (found by bisection on the
    /// dispatch) and at random distances.
    #[test]
    fn placed_overlap_agrees_with_the_dispatch() {
        let mut u = crate::test_support::uniform(41);
        let shapes: Vec<Shape> = [
            "Sphere(radius: 0.5)",
            "Sphere(radius: 0.15)",
            "Ellipsoid(a: 0.5, b: 0.5, c: 2.5)",
            "Ellipsoid(a: 1.0, b: 0.2, c: 0.6)",
        ]
        .iter()
        .map(|t| t.parse().unwrap())
        .collect();
        let mut checked = 0;
        for _ in 0..400 {
            let (a, b) = (&shapes[(4.0 * u()) as usize], &shapes[(4.0 * u()) as usize]);
            let turn = |u: &mut dyn FnMut() -> f64| {
                UnitQuaternion::from_euler_angles(7.0 * u(), 7.0 * u(), 7.0 * u())
            };
            let (qa, qb) = (turn(&mut u), turn(&mut u));
            let dir = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
            let agree = |d: &V3| {
                let rel = Relative::new(d, &qa, &qb);
                let placed = placed_overlap(
                    &Placed::new(a, &qa.to_rotation_matrix().into_inner()),
                    &Placed::new(b, &qb.to_rotation_matrix().into_inner()),
                    d,
                )
                .expect("a lab-frame kernel covers spheres and ellipsoids");
                assert_eq!(placed, overlap(a, b, &rel), "{a:?} {b:?} at {d:?}");
            };
            // Contact along `dir` by bisection on the dispatch.
            let (mut lo, mut hi) = (0.0, a.bounding_radius() + b.bounding_radius());
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if overlap(a, b, &Relative::new(&(dir * mid), &qa, &qb)) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            for s in [1.0 - 1e-9, 1.0 + 1e-9, 0.5 + u(), 0.3 * u()] {
                agree(&(dir * hi * s));
                checked += 1;
            }
        }
        assert_eq!(checked, 1600);
    }
}
