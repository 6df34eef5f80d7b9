//! GJK on support mappings: the exact convex distance for pairs with a
//! cuboid, the overlap test for pairs with a superellipsoid, and an
//! independent second method for the others. EPA extends it to a penetration
//! depth for slightly overlapping bodies.
//!
//! Both bodies are given in one common frame (the pair's relative frame), as
//! support functions. The Minkowski difference is M = A − B; the bodies
//! overlap iff the origin lies in M, and their distance is the distance from
//! the origin to M.

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// A vertex of the simplex: a point of M with the support points that made it.
#[derive(Debug, Clone, Copy)]
pub struct Vertex {
    /// The point a − b of M.
    pub w: V3,
    /// Support point of A.
    pub a: V3,
    /// Support point of B.
    pub b: V3,
}

/// How a GJK query ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GjkOutcome {
    /// The bodies are apart; the distance is accurate to the tolerance.
    Separated,
    /// The origin lies in the Minkowski difference: the bodies overlap.
    Overlapping,
    /// Iteration cap reached before either could be established.
    IterationCap,
}

/// Result of [`gjk_distance`].
#[derive(Debug, Clone, Copy)]
pub struct GjkDistance {
    /// How it ended.
    pub outcome: GjkOutcome,
    /// Upper bound on the distance (‖v‖); 0 when overlapping.
    pub distance: f64,
    /// Lower bound on the distance established by a separating plane.
    pub lower_bound: f64,
    /// Closest point of A.
    pub point_a: V3,
    /// Closest point of B.
    pub point_b: V3,
    /// Support-function calls per body.
    pub iterations: usize,
    /// The final simplex (a tetrahedron enclosing the origin when
    /// overlapping with 4 vertices): EPA starts from it.
    pub simplex: [Vertex; 4],
    /// Vertices used in `simplex`.
    pub simplex_len: usize,
}

/// GJK distance between A and B (van den Bergen's algorithm with Ericson's
/// Voronoi-region closest-point routines).
///
/// `tolerance` is absolute: it stops when the gap between the upper bound
/// ‖v‖ and the lower bound v·w/‖v‖ is below it. `initial` is a first search
/// direction from A towards B (e.g. the centre-to-centre vector).
pub fn gjk_distance(
    support_a: impl Fn(&V3) -> V3,
    support_b: impl Fn(&V3) -> V3,
    initial: V3,
    tolerance: f64,
    max_iterations: usize,
) -> GjkDistance {
    let support = |d: &V3| {
        // Support of M = A − B in direction d.
        let a = support_a(d);
        let b = support_b(&-d);
        Vertex { w: a - b, a, b }
    };
    let dir = if initial.norm_squared() > 0.0 {
        -initial
    } else {
        V3::x()
    };
    let first = support(&dir);
    let mut simplex = Simplex::new(first);
    let mut v = first.w;
    // The best bound −h_M(−v̂) ≤ signed distance so far: negative until a
    // plane separates (not clamped at 0: a pair overlapping by 1e-10, with
    // v within the tolerance of the origin, must not pass for apart).
    let mut lower = f64::NEG_INFINITY;
    for it in 1..=max_iterations {
        let vv = v.norm_squared();
        if vv <= (1e-3 * tolerance).powi(2) {
            return simplex.finish(GjkOutcome::Overlapping, 0.0, lower, it);
        }
        let vertex = support(&-v);
        let vw = v.dot(&vertex.w);
        let vn = vv.sqrt();
        lower = lower.max(vw / vn);
        if vn - lower <= tolerance {
            return simplex.finish(GjkOutcome::Separated, vn, lower, it);
        }
        // No new support point: converged as far as it goes; apart if the
        // bound says so, else undecided (within rounding of touching, or
        // overlapping by less than the simplex can resolve).
        let stalled = |simplex: &Simplex| {
            let outcome = if lower >= -tolerance {
                GjkOutcome::Separated
            } else {
                GjkOutcome::IterationCap
            };
            simplex.finish(outcome, vn, lower, it)
        };
        if simplex.contains(&vertex.w) {
            return stalled(&simplex);
        }
        simplex.push(vertex);
        match simplex.reduce() {
            Some(closest) => v = closest,
            None => return simplex.finish(GjkOutcome::Overlapping, 0.0, lower, it),
        }
        if v.norm_squared() >= vv {
            // No progress (rounding): the previous v is the answer.
            return stalled(&simplex);
        }
    }
    let d = v.norm();
    simplex.finish(GjkOutcome::IterationCap, d, lower, max_iterations)
}

/// GJK overlap test: `Some(false)` when a separating plane is found,
/// `Some(true)` when a simplex of M encloses the origin, `None` when neither
/// within `max_iterations` (the bodies are within rounding of touching).
pub fn gjk_intersect(
    support_a: impl Fn(&V3) -> V3,
    support_b: impl Fn(&V3) -> V3,
    initial: V3,
    max_iterations: usize,
) -> Option<bool> {
    match gjk_enclose(support_a, support_b, initial, max_iterations) {
        Enclosure::Separated => Some(false),
        Enclosure::Enclosed(_) => Some(true),
        Enclosure::Undecided => None,
    }
}

/// How [`gjk_enclose`] ended.
#[derive(Debug, Clone, Copy)]
#[allow(clippy::large_enum_variant)] // returned once per call, on the stack
pub enum Enclosure {
    /// A plane separates the origin from M.
    Separated,
    /// The origin is in M: the tetrahedron of M enclosing it, or `None`
    /// when it lies on a lower simplex (touching to rounding).
    Enclosed(Option<[Vertex; 4]>),
    /// Neither within the iterations (within rounding of touching).
    Undecided,
}

/// The boolean GJK, keeping the tetrahedron that encloses the origin (a
/// start for EPA when the distance GJK could not decide).
pub fn gjk_enclose(
    support_a: impl Fn(&V3) -> V3,
    support_b: impl Fn(&V3) -> V3,
    initial: V3,
    max_iterations: usize,
) -> Enclosure {
    let support = |d: &V3| {
        let a = support_a(d);
        let b = support_b(&-d);
        Vertex { w: a - b, a, b }
    };
    let dir = if initial.norm_squared() > 0.0 {
        -initial
    } else {
        V3::x()
    };
    let first = support(&dir);
    let mut simplex = Simplex::new(first);
    let mut v = first.w;
    for _ in 0..max_iterations {
        let vertex = support(&-v);
        if v.dot(&vertex.w) > 0.0 {
            return Enclosure::Separated; // the plane v·x = v·w separates origin from M
        }
        if simplex.contains(&vertex.w) {
            return Enclosure::Undecided;
        }
        simplex.push(vertex);
        match simplex.reduce() {
            Some(closest) => {
                if closest.norm_squared() >= v.norm_squared() {
                    return Enclosure::Undecided;
                }
                v = closest;
            }
            None => {
                return Enclosure::Enclosed((simplex.len == 4).then_some(simplex.verts));
            }
        }
        if v.norm_squared() == 0.0 {
            return Enclosure::Enclosed(None);
        }
    }
    Enclosure::Undecided
}

/// The simplex (1–4 vertices) with the barycentric weights of its closest
/// point to the origin.
struct Simplex {
    verts: [Vertex; 4],
    weights: [f64; 4],
    len: usize,
}

impl Simplex {
    fn new(first: Vertex) -> Self {
        Self {
            verts: [first; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
            len: 1,
        }
    }

    fn contains(&self, w: &V3) -> bool {
        self.verts[..self.len].iter().any(|v| v.w == *w)
    }

    fn push(&mut self, v: Vertex) {
        self.verts[self.len] = v;
        self.len += 1;
    }

    fn finish(
        &self,
        outcome: GjkOutcome,
        distance: f64,
        lower: f64,
        iterations: usize,
    ) -> GjkDistance {
        let mut point_a = V3::zeros();
        let mut point_b = V3::zeros();
        for i in 0..self.len {
            point_a += self.verts[i].a * self.weights[i];
            point_b += self.verts[i].b * self.weights[i];
        }
        GjkDistance {
            outcome,
            distance,
            lower_bound: lower.max(0.0),
            point_a,
            point_b,
            iterations,
            simplex: self.verts,
            simplex_len: self.len,
        }
    }

    /// Replaces the simplex by the smallest sub-simplex holding its closest
    /// point to the origin and returns that point; `None` if the origin is
    /// inside a (full) tetrahedron.
    fn reduce(&mut self) -> Option<V3> {
        let (keep, weights): (Vec4Idx, [f64; 4]) = match self.len {
            1 => (Vec4Idx::new(&[0]), [1.0, 0.0, 0.0, 0.0]),
            2 => closest_segment(self.verts[0].w, self.verts[1].w, [0, 1]),
            3 => closest_triangle(self.verts[0].w, self.verts[1].w, self.verts[2].w, [0, 1, 2]),
            4 => closest_tetrahedron(&self.verts)?,
            _ => unreachable!(),
        };
        let old = self.verts;
        let mut point = V3::zeros();
        for k in 0..keep.len {
            self.verts[k] = old[keep.idx[k]];
            self.weights[k] = weights[k];
            point += old[keep.idx[k]].w * weights[k];
        }
        self.len = keep.len;
        Some(point)
    }
}

/// Up to four indices into the old simplex.
#[derive(Clone, Copy)]
struct Vec4Idx {
    idx: [usize; 4],
    len: usize,
}

impl Vec4Idx {
    fn new(ids: &[usize]) -> Self {
        let mut idx = [0; 4];
        idx[..ids.len()].copy_from_slice(ids);
        Self {
            idx,
            len: ids.len(),
        }
    }
}

/// Closest point of segment [a, b] to the origin: kept vertices, weights.
fn closest_segment(a: V3, b: V3, ids: [usize; 2]) -> (Vec4Idx, [f64; 4]) {
    let ab = b - a;
    let denom = ab.norm_squared();
    let t = if denom > 0.0 {
        -a.dot(&ab) / denom
    } else {
        0.0
    };
    if t <= 0.0 {
        (Vec4Idx::new(&[ids[0]]), [1.0, 0.0, 0.0, 0.0])
    } else if t >= 1.0 {
        (Vec4Idx::new(&[ids[1]]), [1.0, 0.0, 0.0, 0.0])
    } else {
        (Vec4Idx::new(&ids), [1.0 - t, t, 0.0, 0.0])
    }
}

/// Closest point of triangle abc to the origin (Ericson, RTCD 5.1.5).
fn closest_triangle(a: V3, b: V3, c: V3, ids: [usize; 3]) -> (Vec4Idx, [f64; 4]) {
    let ab = b - a;
    let ac = c - a;
    let ap = -a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (Vec4Idx::new(&[ids[0]]), [1.0, 0.0, 0.0, 0.0]);
    }
    let bp = -b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (Vec4Idx::new(&[ids[1]]), [1.0, 0.0, 0.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (Vec4Idx::new(&[ids[0], ids[1]]), [1.0 - v, v, 0.0, 0.0]);
    }
    let cp = -c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (Vec4Idx::new(&[ids[2]]), [1.0, 0.0, 0.0, 0.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (Vec4Idx::new(&[ids[0], ids[2]]), [1.0 - w, w, 0.0, 0.0]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (Vec4Idx::new(&[ids[1], ids[2]]), [1.0 - w, w, 0.0, 0.0]);
    }
    let sum = va + vb + vc;
    if sum.abs() <= f64::MIN_POSITIVE || !sum.is_finite() {
        // Degenerate (collinear) triangle: best of its edges.
        return best_of(
            &[
                closest_segment(a, b, [ids[0], ids[1]]),
                closest_segment(a, c, [ids[0], ids[2]]),
                closest_segment(b, c, [ids[1], ids[2]]),
            ],
            &[a, b, c],
            &ids,
        );
    }
    let v = vb / sum;
    let w = vc / sum;
    (Vec4Idx::new(&ids), [1.0 - v - w, v, w, 0.0])
}

/// Of several candidate sub-simplices, the one whose point is closest.
fn best_of(cands: &[(Vec4Idx, [f64; 4])], pts: &[V3], ids: &[usize]) -> (Vec4Idx, [f64; 4]) {
    let point = |c: &(Vec4Idx, [f64; 4])| {
        let mut p = V3::zeros();
        for k in 0..c.0.len {
            let local = ids.iter().position(|&i| i == c.0.idx[k]).unwrap();
            p += pts[local] * c.1[k];
        }
        p.norm_squared()
    };
    *cands
        .iter()
        .min_by(|x, y| point(x).total_cmp(&point(y)))
        .unwrap()
}

/// Closest point of the tetrahedron to the origin, or `None` if the origin is
/// inside it (Ericson, RTCD 5.1.6).
fn closest_tetrahedron(v: &[Vertex; 4]) -> Option<(Vec4Idx, [f64; 4])> {
    let p = [v[0].w, v[1].w, v[2].w, v[3].w];
    // Faces with the vertex opposite each.
    let faces = [
        ([0, 1, 2], 3),
        ([0, 2, 3], 1),
        ([0, 3, 1], 2),
        ([1, 3, 2], 0),
    ];
    let scale = (p[1] - p[0]).norm() * (p[2] - p[0]).norm() * (p[3] - p[0]).norm();
    let mut best: Option<((Vec4Idx, [f64; 4]), f64)> = None;
    for (f, opp) in faces {
        let (a, b, c) = (p[f[0]], p[f[1]], p[f[2]]);
        let n = (b - a).cross(&(c - a));
        let sign_origin = -a.dot(&n);
        let sign_opp = (p[opp] - a).dot(&n);
        // A flat tetrahedron cannot enclose the origin: look at every face.
        let degenerate = sign_opp.abs() <= 1e-14 * scale;
        if degenerate || sign_origin * sign_opp < 0.0 {
            let cand = closest_triangle(a, b, c, f);
            let mut q = V3::zeros();
            for k in 0..cand.0.len {
                q += p[cand.0.idx[k]] * cand.1[k];
            }
            let d = q.norm_squared();
            if best.as_ref().is_none_or(|(_, bd)| d < *bd) {
                best = Some((cand, d));
            }
        }
    }
    best.map(|(cand, _)| cand)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(h: f64, c: V3) -> impl Fn(&V3) -> V3 {
        move |d: &V3| c + V3::new(h.copysign(d.x), h.copysign(d.y), h.copysign(d.z))
    }
    fn ball(r: f64, c: V3) -> impl Fn(&V3) -> V3 {
        move |d: &V3| c + d.normalize() * r
    }

    #[test]
    fn cube_cube_distances_are_exact() {
        // Face–face.
        let g = gjk_distance(
            cube(0.5, V3::zeros()),
            cube(0.5, V3::new(3.0, 0.2, 0.1)),
            V3::x(),
            1e-12,
            100,
        );
        assert_eq!(g.outcome, GjkOutcome::Separated);
        assert!((g.distance - 2.0).abs() < 1e-12);
        // Vertex–vertex along the diagonal.
        let g = gjk_distance(
            cube(0.5, V3::zeros()),
            cube(0.5, V3::repeat(2.0)),
            V3::x(),
            1e-12,
            100,
        );
        assert!((g.distance - 3f64.sqrt()).abs() < 1e-12, "{}", g.distance);
        assert!((g.point_a - V3::repeat(0.5)).norm() < 1e-12);
        assert!((g.point_b - V3::repeat(1.5)).norm() < 1e-12);
        // Overlap.
        let g = gjk_distance(
            cube(0.5, V3::zeros()),
            cube(0.5, V3::new(0.9, 0.0, 0.0)),
            V3::x(),
            1e-12,
            100,
        );
        assert_eq!(g.outcome, GjkOutcome::Overlapping);
    }

    #[test]
    fn ball_ball_distance_converges() {
        let c = V3::new(1.0, 2.0, -0.5);
        let g = gjk_distance(ball(0.5, V3::zeros()), ball(0.7, c), c, 1e-12, 200);
        assert_eq!(g.outcome, GjkOutcome::Separated);
        assert!(
            (g.distance - (c.norm() - 1.2)).abs() < 1e-10,
            "{}",
            g.distance
        );
    }

    #[test]
    fn intersect_agrees_near_contact() {
        for &(x, expect) in &[(1.2 + 1e-7, false), (1.2 - 1e-7, true)] {
            let c = V3::new(x, 0.0, 0.0);
            let r = gjk_intersect(
                ball(0.5, V3::zeros()),
                ball(0.7, c),
                V3::new(1.0, 0.3, 0.2),
                200,
            );
            assert_eq!(r, Some(expect), "at {x}");
        }
    }
}

/// Result of [`epa`].
#[derive(Debug, Clone, Copy)]
pub struct Penetration {
    /// Penetration depth (≥ 0): the shortest translation that separates.
    pub depth: f64,
    /// Unit direction of that translation for B (from A towards B).
    pub normal: V3,
    /// Deepest point of A along the normal.
    pub point_a: V3,
    /// Deepest point of B against the normal.
    pub point_b: V3,
    /// Whether the gap between bounds fell below the tolerance.
    pub converged: bool,
    /// Iterations used.
    pub iterations: usize,
}

/// Expanding Polytope Algorithm: the penetration depth of overlapping bodies,
/// starting from a GJK tetrahedron that encloses the origin. Returns `None`
/// when the start is not such a tetrahedron.
pub fn epa(
    support_a: impl Fn(&V3) -> V3,
    support_b: impl Fn(&V3) -> V3,
    start: &[Vertex; 4],
    tolerance: f64,
    max_iterations: usize,
) -> Option<Penetration> {
    let support = |d: &V3| {
        let a = support_a(d);
        let b = support_b(&-d);
        Vertex { w: a - b, a, b }
    };
    let mut verts: Vec<Vertex> = start.to_vec();
    // A point inside the polytope, which only grows: the centroid of the
    // start. Faces are turned to face away from it, not from the origin,
    // which may lie on a face to rounding (bodies touching to within
    // rounding): turned by the sign of its own plane distance, such a face
    // can point inwards, and the expansion then ends on a wrong face (two
    // touching tetrahedra came out overlapping by a tenth of their edge).
    let inside = start.iter().map(|v| v.w).sum::<V3>() / 4.0;
    // Faces as vertex triples with outward unit normal and plane distance
    // (negative where the origin is outside the face's plane, to rounding).
    struct Face {
        v: [usize; 3],
        n: V3,
        d: f64,
    }
    let make = |verts: &[Vertex], v: [usize; 3]| -> Option<Face> {
        let (a, b, c) = (verts[v[0]].w, verts[v[1]].w, verts[v[2]].w);
        let n = (b - a).cross(&(c - a));
        let len = n.norm();
        if len.is_nan() || len <= 0.0 {
            return None;
        }
        let n = n / len;
        Some(if n.dot(&(a - inside)) < 0.0 {
            Face {
                v: [v[0], v[2], v[1]],
                n: -n,
                d: -n.dot(&a),
            }
        } else {
            Face { v, n, d: n.dot(&a) }
        })
    };
    let mut faces = Vec::with_capacity(64);
    for f in [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]] {
        faces.push(make(&verts, f)?);
    }
    let mut best = 0;
    for it in 1..=max_iterations {
        best = (0..faces.len())
            .min_by(|&i, &j| faces[i].d.total_cmp(&faces[j].d))
            .unwrap();
        let n = faces[best].n;
        let w = support(&n);
        let gap = w.w.dot(&n) - faces[best].d;
        if gap <= tolerance {
            return Some(penetration(
                &verts,
                &faces[best].v,
                n,
                faces[best].d,
                true,
                it,
            ));
        }
        // Remove faces that see w; keep the horizon edges.
        let wi = verts.len();
        verts.push(w);
        let mut horizon: Vec<(usize, usize)> = Vec::new();
        let mut k = 0;
        while k < faces.len() {
            let f = &faces[k];
            if f.n.dot(&(w.w - verts[f.v[0]].w)) > 0.0 {
                for e in [(f.v[0], f.v[1]), (f.v[1], f.v[2]), (f.v[2], f.v[0])] {
                    // Edges shared by two removed faces are interior. Match
                    // them undirected: `make` may flip a face's winding to
                    // keep its normal outward.
                    if let Some(p) = horizon
                        .iter()
                        .position(|&(x, y)| (x == e.1 && y == e.0) || (x == e.0 && y == e.1))
                    {
                        horizon.swap_remove(p);
                    } else {
                        horizon.push(e);
                    }
                }
                faces.swap_remove(k);
            } else {
                k += 1;
            }
        }
        for (x, y) in horizon {
            if let Some(f) = make(&verts, [x, y, wi]) {
                faces.push(f);
            }
        }
        if faces.is_empty() {
            return None;
        }
        if it == max_iterations {
            best = (0..faces.len())
                .min_by(|&i, &j| faces[i].d.total_cmp(&faces[j].d))
                .unwrap();
        }
    }
    let f = &faces[best];
    Some(penetration(&verts, &f.v, f.n, f.d, false, max_iterations))
}

/// Contact data from the EPA face closest to the origin: the origin's
/// projection onto the face, in barycentric weights, mapped to A and B.
fn penetration(
    verts: &[Vertex],
    v: &[usize; 3],
    n: V3,
    d: f64,
    converged: bool,
    iterations: usize,
) -> Penetration {
    let (a, b, c) = (verts[v[0]], verts[v[1]], verts[v[2]]);
    let p = n * d;
    let (v0, v1, v2) = (b.w - a.w, c.w - a.w, p - a.w);
    let (d00, d01, d11) = (v0.dot(&v0), v0.dot(&v1), v1.dot(&v1));
    let (d20, d21) = (v2.dot(&v0), v2.dot(&v1));
    let den = d00 * d11 - d01 * d01;
    let (l1, l2) = if den > 0.0 {
        ((d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den)
    } else {
        (0.0, 0.0)
    };
    let l0 = 1.0 - l1 - l2;
    Penetration {
        depth: d,
        // M = A − B: translating B by u turns M into M − u, which excludes
        // the origin once u leaves M; the shortest such u is n·d, so B
        // separates along +n.
        normal: n,
        point_a: a.a * l0 + b.a * l1 + c.a * l2,
        point_b: a.b * l0 + b.b * l1 + c.b * l2,
        converged,
        iterations,
    }
}
