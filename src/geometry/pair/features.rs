//! The distance of two separated polytopes by their closest features: the
//! exact answer where GJK stops short of its tolerance (support points
//! that tie to within the rounding of its search direction, as when a
//! face lies almost flat on a face: its simplex then overestimates the
//! distance by up to the tilt times the size).
//!
//! The closest points of two convex polytopes lie on a vertex of one and
//! anywhere on the other, or inside an edge of each: the smallest of the
//! distances of every vertex to the other polytope (to a face it faces,
//! or to an edge) and of every pair of edges is the distance, and each
//! term is that of two points of the bodies, so none is below it.

use crate::geometry::capsule::closest_segment_parameters;
use crate::geometry::polyhedron::MAX_VERTICES;
use crate::geometry::{Relative, Shape};

type V3 = nalgebra::Vector3<f64>;

/// Faces and edges of a hull of at most [`MAX_VERTICES`] corners (Euler:
/// F ≤ 2V − 4, E ≤ 3V − 6).
const MAX_FACES: usize = 2 * MAX_VERTICES;
const MAX_EDGES: usize = 3 * MAX_VERTICES;

/// A polytope's features placed in A's frame: corners, face planes
/// (outward unit normal, offset) and edges (corner indices).
struct Placed {
    corners: [V3; MAX_VERTICES],
    n_corners: usize,
    planes: [(V3, f64); MAX_FACES],
    n_planes: usize,
    edges: &'static [(usize, usize)],
    /// Per edge its class of parallel edges, and per class its first.
    edge_directions: &'static [usize],
    direction_edges: &'static [usize],
}

impl Placed {
    /// The polytope `shape` (a polyhedron without rounding) placed by
    /// `rel` (identity for A); None for any other shape.
    fn new(shape: &Shape, rel: &Relative) -> Option<Self> {
        let Shape::ConvexPolyhedron(p) = shape else {
            return None;
        };
        if p.rounding() > 0.0 {
            return None;
        }
        let hull = p.hull();
        let mut placed = Self {
            corners: [V3::zeros(); MAX_VERTICES],
            n_corners: hull.vertices().len(),
            planes: [(V3::zeros(), 0.0); MAX_FACES],
            n_planes: hull.faces().len().min(MAX_FACES),
            edges: hull.edges(),
            edge_directions: hull.edge_directions(),
            direction_edges: hull.direction_edges(),
        };
        for (slot, v) in placed.corners.iter_mut().zip(p.corners()) {
            *slot = rel.b_to_a(&v);
        }
        for (slot, f) in placed.planes.iter_mut().zip(hull.faces()) {
            let normal = rel.rotation * f.normal;
            *slot = (normal, normal.dot(&rel.translation) + f.offset * p.scale());
        }
        Some(placed)
    }

    fn corners(&self) -> &[V3] {
        &self.corners[..self.n_corners]
    }

    fn planes(&self) -> &[(V3, f64)] {
        &self.planes[..self.n_planes]
    }

    /// The closest point of the polytope to `x` outside it, and, where it
    /// is inside a face, that face's normal; None if `x` is inside.
    fn closest_to(&self, x: &V3) -> Option<(V3, Option<V3>)> {
        let outside =
            |x: &V3, slack: f64| (self.planes().iter()).any(|(n, o)| n.dot(x) - o > slack);
        if !outside(x, 0.0) {
            return None;
        }
        let mut best = (f64::INFINITY, V3::zeros(), None);
        let scale = self.corners().iter().fold(0.0f64, |m, v| m.max(v.norm()));
        for (n, o) in self.planes() {
            let h = n.dot(x) - o;
            if h <= 0.0 || h >= best.0 {
                continue;
            }
            let foot = x - n * h;
            if !outside(&foot, 1e-12 * scale) {
                best = (h, foot, Some(*n));
            }
        }
        for &(i, j) in self.edges {
            let (p, q) = (self.corners[i], self.corners[j]);
            let e = q - p;
            let s = ((x - p).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
            let on = p + e * s;
            let d = (x - on).norm();
            if d < best.0 {
                best = (d, on, None);
            }
        }
        Some((best.1, best.2))
    }
}

/// The signed distance of polyhedra `a` and `b` (B placed by `rel` in A's
/// frame, neither rounded) by their features, with a point of each and
/// the normal (A → B): the largest separation over the axes that can
/// separate them says whether they overlap, and by how much; apart, the
/// closest features say how far. None for other shapes.
pub fn signed_distance(a: &Shape, b: &Shape, rel: &Relative) -> Option<(f64, V3, V3, V3)> {
    let identity = Relative {
        translation: V3::zeros(),
        rotation: nalgebra::Matrix3::identity(),
    };
    let pa = Placed::new(a, &identity)?;
    let pb = Placed::new(b, rel)?;
    let t = &rel.translation;
    let (separation, axis, point_a, point_b) = largest_separation(&pa, &pb);
    if separation > 0.0
        && let Some(apart) = closest_features(&pa, &pb, t)
    {
        return Some(apart);
    }
    // Overlapping, or touching to rounding (a corner on a face: the
    // separation is then the distance to rounding).
    Some((separation, point_a, point_b, axis))
}

/// `n`, or `-n` where it points away from `t`, B's centre in A's frame: a
/// separating direction has A's centre on its near side and B's on the
/// far one.
fn towards(n: V3, t: &V3) -> V3 {
    if n.dot(t) >= 0.0 { n } else { -n }
}

/// The closest points of A's edge i–j and B's edge k–l, the edges' unit
/// directions, and whether both points are inside their edges.
fn edge_pair(
    pa: &Placed,
    (i, j): (usize, usize),
    pb: &Placed,
    (k, l): (usize, usize),
) -> (V3, V3, V3, V3, bool) {
    let (p, q, r, s) = (pa.corners[i], pa.corners[j], pb.corners[k], pb.corners[l]);
    let (centre_a, half_a) = (0.5 * (p + q), 0.5 * (q - p).norm());
    let (centre_b, half_b) = (0.5 * (r + s), 0.5 * (s - r).norm());
    let (u, v) = ((q - p) / (2.0 * half_a), (s - r) / (2.0 * half_b));
    let (sa, sb) = closest_segment_parameters(&(centre_b - centre_a), &u, half_a, &v, half_b);
    let inside = sa.abs() < half_a && sb.abs() < half_b;
    (centre_a + u * sa, centre_b + v * sb, u, v, inside)
}

/// The distance of separated polyhedra `pa` and `pb` (both in A's frame,
/// B's centre at `t`) by their closest features, with the closest points
/// and the normal (A → B): a face's where a vertex faces a face, the
/// edges' cross product where two edges hold the points, else the
/// direction between the points. None where they touch or overlap (a
/// vertex inside the other).
fn closest_features(pa: &Placed, pb: &Placed, t: &V3) -> Option<(f64, V3, V3, V3)> {
    // (distance, point of A, point of B, exact normal if known).
    let mut best = (f64::INFINITY, V3::zeros(), V3::zeros(), None);
    for x in pb.corners() {
        let (on_a, face) = pa.closest_to(x)?;
        let d = (x - on_a).norm();
        if d < best.0 {
            best = (d, on_a, *x, face);
        }
    }
    for x in pa.corners() {
        let (on_b, face) = pb.closest_to(x)?;
        let d = (on_b - x).norm();
        if d < best.0 {
            best = (d, *x, on_b, face.map(|n| -n));
        }
    }
    // Each edge's midpoint and half-length: a pair of edges is no closer
    // than its midpoints less both half-lengths, so pairs that cannot
    // beat the best found so far are passed over.
    let spans = |p: &Placed| {
        let mut spans = [(V3::zeros(), 0.0); MAX_EDGES];
        for (span, &(i, j)) in spans.iter_mut().zip(p.edges) {
            let (x, y) = (p.corners[i], p.corners[j]);
            *span = (0.5 * (x + y), 0.5 * (y - x).norm());
        }
        spans
    };
    let (spans_a, spans_b) = (spans(pa), spans(pb));
    for (&edge_a, &(mid_a, half_a)) in pa.edges.iter().zip(&spans_a) {
        for (&edge_b, &(mid_b, half_b)) in pb.edges.iter().zip(&spans_b) {
            if (mid_b - mid_a).norm() - half_a - half_b >= best.0 {
                continue;
            }
            let (on_a, on_b, u, v, inside) = edge_pair(pa, edge_a, pb, edge_b);
            let d = (on_b - on_a).norm();
            if d < best.0 {
                // Inside both edges: across both, the edges' cross product,
                // turned by the centres (the points' own difference is
                // rounding where the edges touch).
                let across = u.cross(&v).try_normalize(1e-6).filter(|_| inside);
                best = (d, on_a, on_b, across.map(|n| towards(n, t)));
            }
        }
    }
    let (d, on_a, on_b, normal) = best;
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    // Between the points where no face or pair of edges gives it, turned
    // by the centres where rounding (points a hair apart) turned it away.
    let normal = normal.unwrap_or_else(|| towards((on_b - on_a) / d, t));
    Some((d, on_a, on_b, normal))
}

/// The largest separation of the projections of polyhedra `pa` and `pb`
/// (both in A's frame) on the axes that can separate them: each one's face
/// normals and the cross products of an edge of each (those of edges
/// within 1e-6 of parallel left out: the faces beside stand in for them
/// to within the square of the angle times the size), with the axis (A →
/// B) and a point of each where the separation is measured (B's deepest
/// corner under a face of A, A's under a face of B, the closest points of
/// the two edges). Positive: apart, and a lower bound on the distance
/// (equal to it where a face, or an edge of each, holds the closest
/// points). Not positive: they overlap, by minus it (the depth: every
/// face of the Minkowski difference has one of these normals).
fn largest_separation(pa: &Placed, pb: &Placed) -> (f64, V3, V3, V3) {
    // The lowest and highest corner along n: (value, index) each.
    let range = |corners: &[V3], n: &V3| {
        let mut lo = (f64::INFINITY, 0);
        let mut hi = (f64::NEG_INFINITY, 0);
        for (k, v) in corners.iter().enumerate() {
            let x = v.dot(n);
            if x < lo.0 {
                lo = (x, k);
            }
            if x > hi.0 {
                hi = (x, k);
            }
        }
        (lo, hi)
    };
    #[derive(Clone, Copy)]
    enum Witness {
        /// A's corner: under a face of B facing A.
        CornerOfA(usize),
        /// B's corner: under a face of A facing B, or any other axis.
        CornerOfB(usize),
        /// Edges i–j of A and k–l of B.
        Edges(usize, usize, usize, usize),
    }
    let mut best = (f64::NEG_INFINITY, V3::x(), Witness::CornerOfB(0));
    // The edge of `p` in parallel class `class` whose both ends lie at
    // `level` along `n`, to rounding.
    let supporting = |p: &Placed, class: usize, n: &V3, level: f64, rounding: f64| {
        (p.edges.iter().zip(p.edge_directions))
            .find(|&(&(i, j), &c)| {
                c == class
                    && (p.corners[i].dot(n) - level).abs() <= rounding
                    && (p.corners[j].dot(n) - level).abs() <= rounding
            })
            .map(|(&e, _)| e)
    };
    // `of_b`: the axis is a face normal of B (outward), so that B's face
    // faces A where the separation is taken against it. `classes`: the
    // axis is across a class of parallel edges of each; it is a face of
    // the Minkowski difference only where an edge of each class is the
    // extreme feature along it, and those edges hold the closest points
    // (any other edge of the class gives the same axis and separation but
    // points on the far side of the body).
    let mut try_axis = |n: &V3, of_b: bool, classes: Option<(usize, usize)>| {
        let ((a_lo, a_hi), (b_lo, b_hi)) = (range(pa.corners(), n), range(pb.corners(), n));
        let (up, down) = (b_lo.0 - a_hi.0, a_lo.0 - b_hi.0);
        let rounding = 1e-9 * (a_hi.0 - a_lo.0 + b_hi.0 - b_lo.0);
        let witness = |a_level: f64, b_level: f64, corner: Witness| match classes {
            None => Some(corner),
            Some((ca, cb)) => {
                let (i, j) = supporting(pa, ca, n, a_level, rounding)?;
                let (k, l) = supporting(pb, cb, n, b_level, rounding)?;
                Some(Witness::Edges(i, j, k, l))
            }
        };
        if up > best.0
            && let Some(w) = witness(a_hi.0, b_lo.0, Witness::CornerOfB(b_lo.1))
        {
            best = (up, *n, w);
        }
        let corner = if of_b {
            Witness::CornerOfA(a_lo.1)
        } else {
            Witness::CornerOfB(b_hi.1)
        };
        if down > best.0
            && let Some(w) = witness(a_lo.0, b_hi.0, corner)
        {
            best = (down, -n, w);
        }
    };
    for (n, _) in pa.planes() {
        try_axis(n, false, None);
    }
    for (n, _) in pb.planes() {
        try_axis(n, true, None);
    }
    let direction = |p: &Placed, e: usize| {
        let (i, j) = p.edges[e];
        (p.corners[j] - p.corners[i]).normalize()
    };
    for (ca, &ea) in pa.direction_edges.iter().enumerate() {
        let u = direction(pa, ea);
        for (cb, &eb) in pb.direction_edges.iter().enumerate() {
            if let Some(n) = u.cross(&direction(pb, eb)).try_normalize(1e-6) {
                try_axis(&n, false, Some((ca, cb)));
            }
        }
    }
    let (separation, axis, witness) = best;
    let (point_a, point_b) = match witness {
        Witness::CornerOfA(k) => (pa.corners[k], pa.corners[k] + axis * separation),
        Witness::CornerOfB(k) => (pb.corners[k] - axis * separation, pb.corners[k]),
        Witness::Edges(i, j, k, l) => {
            let (on_a, on_b, ..) = edge_pair(pa, (i, j), pb, (k, l));
            (on_a, on_b)
        }
    };
    (separation, axis, point_a, point_b)
}
