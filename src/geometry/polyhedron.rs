//! Convex polyhedra given by points: the hull (its vertices, faces and
//! edges), the mass properties of the uniform solid, the Minkowski
//! functionals that the excluded volume of a pair is made of, and the
//! support mapping.
//!
//! The hull of at most [`MAX_VERTICES`] points is found by testing every
//! plane through three of them as a supporting plane (O(n⁴), a few
//! milliseconds at the bound, once per shape); coplanar points merge into
//! one face. Lengths within [`PLANE_TOLERANCE`] of the hull's size count
//! as on a plane.

use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;

mod convex;
mod swept;

pub use convex::ConvexPolyhedron;

/// The most points a polyhedron may be given.
pub const MAX_VERTICES: usize = 64;

/// Distances from a plane below this fraction of the points' largest
/// distance from the origin count as lying on it.
pub const PLANE_TOLERANCE: f64 = 1e-9;

/// Why points do not make a convex polyhedron.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolyhedronError {
    /// Fewer than four points, or more than [`MAX_VERTICES`].
    #[error("a convex polyhedron needs 4 to {MAX_VERTICES} vertices, got {0}")]
    VertexCount(usize),
    /// A coordinate that is not finite.
    #[error("vertex {index} is not finite: ({}, {}, {})", .point[0], .point[1], .point[2])]
    NonFinite {
        /// Which vertex, from 0.
        index: usize,
        /// Its coordinates.
        point: [f64; 3],
    },
    /// Two points at the same place.
    #[error("vertices {first} and {second} are the same point")]
    Repeated {
        /// The first of the two, from 0.
        first: usize,
        /// The second.
        second: usize,
    },
    /// All points on one plane: the hull has no volume.
    #[error("the vertices all lie on one plane (the polyhedron would be flat)")]
    Flat,
    /// A named solid's edge length that is not finite and > 0.
    #[error("edge must be a finite number > 0, got {0}")]
    Edge(f64),
    /// Points so near a lower-dimensional arrangement (a sliver, a needle)
    /// that their faces, found to within the plane tolerance, do not close
    /// into a solid.
    #[error(
        "the hull of the vertices does not close into a solid at a tolerance of {tolerance:e} (a face or edge thinner than that): spread the vertices or drop the ones that nearly coincide"
    )]
    Degenerate {
        /// The plane tolerance used (relative to the size, times it).
        tolerance: f64,
    },
    /// The body origin is not strictly inside the hull.
    #[error(
        "the body origin (0, 0, 0) must lie inside the hull of the vertices; \
         centre them on the body (their centroid is ({}, {}, {}))",
        .centroid[0], .centroid[1], .centroid[2]
    )]
    OriginOutside {
        /// The centroid of the solid the points span.
        centroid: [f64; 3],
    },
}

/// One face of the hull: its outward unit normal, its distance from the
/// origin (n·x = offset on the face), and its vertices (indices into the
/// hull's vertices) counter-clockwise seen from outside.
#[derive(Debug, Clone, PartialEq)]
pub struct Face {
    /// Outward unit normal.
    pub normal: V3,
    /// n·x on the face (> 0: the origin is inside).
    pub offset: f64,
    /// The face's corners, counter-clockwise about `normal`.
    pub vertices: Vec<usize>,
}

impl Face {
    /// Whether the edge between corners `a` and `b` (either way round) is
    /// one of this face's.
    pub fn has_edge(&self, a: usize, b: usize) -> bool {
        let n = self.vertices.len();
        (0..n).any(|k| {
            let (p, q) = (self.vertices[k], self.vertices[(k + 1) % n]);
            (p, q) == (a, b) || (p, q) == (b, a)
        })
    }
}

/// The classes of parallel edges of a hull with corners `vertices`: per
/// edge its class, and per class its first edge. Edges are parallel where
/// the sine of their angle is below 1e-12 (a solid's exact parallels
/// differ by rounding only).
fn parallel_classes(vertices: &[V3], edges: &[(usize, usize)]) -> (Vec<usize>, Vec<usize>) {
    let direction = |&(a, b): &(usize, usize)| (vertices[b] - vertices[a]).normalize();
    let mut classes = Vec::with_capacity(edges.len());
    let mut firsts: Vec<usize> = Vec::new();
    for e in edges {
        let u = direction(e);
        match firsts
            .iter()
            .position(|&f| u.cross(&direction(&edges[f])).norm() < 1e-12)
        {
            Some(class) => classes.push(class),
            None => {
                classes.push(firsts.len());
                firsts.push(classes.len() - 1);
            }
        }
    }
    (classes, firsts)
}

/// A convex polyhedron, the uniform solid hull of its vertices, with the
/// body origin at its centroid (the points given are shifted by their
/// solid's centroid; see [`Polyhedron::shift`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Polyhedron {
    /// The points as given (what the shape is written as).
    given: Vec<V3>,
    /// The named solid and edge length the points are the corners of,
    /// where the shape was given so.
    named: Option<(super::solids::Solid, f64)>,
    vertices: Vec<V3>,
    faces: Vec<Face>,
    edges: Vec<(usize, usize)>,
    /// Per edge, the index of its direction among the hull's distinct
    /// edge directions (parallel edges share one: a cube's twelve have
    /// three), and per direction its first edge.
    edge_directions: Vec<usize>,
    direction_edges: Vec<usize>,
    shift: V3,
    volume: f64,
    area: f64,
    mean_curvature: f64,
    /// ∫ x xᵀ dV of the solid about its centroid.
    second_moment: Matrix3<f64>,
    /// The farthest corner's distance and the corners' largest extents
    /// along the body axes (asked for at every overlap test).
    circumradius: f64,
    half_extents: V3,
}

impl Polyhedron {
    /// The hull of `points`, refused when it is not a solid with the body
    /// origin strictly inside.
    pub fn new(points: &[V3]) -> Result<Self, PolyhedronError> {
        if !(4..=MAX_VERTICES).contains(&points.len()) {
            return Err(PolyhedronError::VertexCount(points.len()));
        }
        if let Some(index) = points.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
            let p = points[index];
            return Err(PolyhedronError::NonFinite {
                index,
                point: [p.x, p.y, p.z],
            });
        }
        let size = points.iter().map(|p| p.norm()).fold(0.0, f64::max);
        let tol = PLANE_TOLERANCE * size.max(f64::MIN_POSITIVE);
        for (first, p) in points.iter().enumerate() {
            if let Some(k) = points[first + 1..]
                .iter()
                .position(|q| (p - q).norm() <= tol)
            {
                return Err(PolyhedronError::Repeated {
                    first,
                    second: first + 1 + k,
                });
            }
        }
        let planes = supporting_planes(points, tol);
        if planes.len() < 4 {
            return Err(PolyhedronError::Flat);
        }
        // The hull's vertices: the points on some face that are corners
        // of it (a point inside an edge or a face is dropped).
        let mut on_hull: Vec<usize> = Vec::new();
        let mut faces = Vec::with_capacity(planes.len());
        for (normal, offset) in planes {
            let corners = face_corners(points, &normal, offset, tol);
            for &c in &corners {
                if !on_hull.contains(&c) {
                    on_hull.push(c);
                }
            }
            faces.push((normal, offset, corners));
        }
        on_hull.sort_unstable();
        let index_of = |p: usize| on_hull.iter().position(|&q| q == p).unwrap();
        let given: Vec<V3> = on_hull.iter().map(|&i| points[i]).collect();
        let faces: Vec<Face> = faces
            .into_iter()
            .map(|(normal, offset, corners)| Face {
                normal,
                offset,
                vertices: corners.into_iter().map(index_of).collect(),
            })
            .collect();
        let mut edges: Vec<(usize, usize)> = Vec::new();
        for f in &faces {
            for (k, &a) in f.vertices.iter().enumerate() {
                let b = f.vertices[(k + 1) % f.vertices.len()];
                let e = (a.min(b), a.max(b));
                if !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        // A closed solid: every edge on exactly two faces, and Euler's
        // V - E + F = 2.
        let faces_on = |&(a, b): &(usize, usize)| faces.iter().filter(|f| f.has_edge(a, b)).count();
        let closed = edges.iter().all(|e| faces_on(e) == 2)
            && given.len() + faces.len() == edges.len() + 2
            && faces.iter().all(|f| f.vertices.len() >= 3);
        if !closed {
            return Err(PolyhedronError::Degenerate { tolerance: tol });
        }
        let (volume, centroid) = volume_and_centroid(&given, &faces);
        if faces.iter().any(|f| f.offset <= tol) {
            return Err(PolyhedronError::OriginOutside {
                centroid: [centroid.x, centroid.y, centroid.z],
            });
        }
        // Points centred already (within rounding) are kept as given, so
        // that a hull's own corners give back the same hull to the bit.
        let centroid = if centroid.norm() <= tol {
            V3::zeros()
        } else {
            centroid
        };
        let vertices: Vec<V3> = given.iter().map(|v| v - centroid).collect();
        let faces: Vec<Face> = faces
            .into_iter()
            .map(|f| Face {
                offset: f.offset - f.normal.dot(&centroid),
                ..f
            })
            .collect();
        let (edge_directions, direction_edges) = parallel_classes(&vertices, &edges);
        let mut polyhedron = Self {
            given: points.to_vec(),
            named: None,
            vertices,
            faces,
            edges,
            edge_directions,
            direction_edges,
            shift: -centroid,
            volume,
            area: 0.0,
            mean_curvature: 0.0,
            second_moment: Matrix3::zeros(),
            circumradius: 0.0,
            half_extents: V3::zeros(),
        };
        polyhedron.circumradius = (polyhedron.vertices.iter())
            .map(|v| v.norm())
            .fold(0.0, f64::max);
        polyhedron.half_extents =
            (polyhedron.vertices.iter()).fold(V3::zeros(), |h, v| h.zip_map(&v.abs(), f64::max));
        polyhedron.area = polyhedron
            .faces
            .iter()
            .map(|f| polyhedron.face_area(f))
            .sum();
        polyhedron.mean_curvature = polyhedron.integral_mean_curvature();
        polyhedron.second_moment = polyhedron.second_moment_about_origin();
        Ok(polyhedron)
    }

    /// The named solid and its edge length, where the shape was given so.
    pub fn named(&self) -> Option<(super::solids::Solid, f64)> {
        self.named
    }

    /// The points as given, before the hull and the shift.
    pub fn given(&self) -> &[V3] {
        &self.given
    }

    /// The hull's corners, about the centroid.
    pub fn vertices(&self) -> &[V3] {
        &self.vertices
    }

    /// The hull's faces.
    pub fn faces(&self) -> &[Face] {
        &self.faces
    }

    /// The hull's edges, as pairs of vertex indices (smaller first).
    pub fn edges(&self) -> &[(usize, usize)] {
        &self.edges
    }

    /// Per edge, the index of its direction among the hull's distinct
    /// edge directions (edges parallel to 1e-12 share one).
    pub fn edge_directions(&self) -> &[usize] {
        &self.edge_directions
    }

    /// Per distinct edge direction, the first edge along it.
    pub fn direction_edges(&self) -> &[usize] {
        &self.direction_edges
    }

    /// What was added to the points given to put the centroid at the
    /// origin.
    pub fn shift(&self) -> V3 {
        self.shift
    }

    /// The solid's volume.
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// The surface area.
    pub fn surface_area(&self) -> f64 {
        self.area
    }

    /// The integral of the mean curvature over the surface, for a
    /// polyhedron ½ Σ over edges of length × the angle between the two
    /// faces' normals (Hadwiger's M: 4πR for a ball of radius R).
    pub fn mean_curvature_integral(&self) -> f64 {
        self.mean_curvature
    }

    /// The inertia tensor of the uniform solid of unit mass about its
    /// centroid, in the body frame.
    pub fn inertia(&self) -> Matrix3<f64> {
        let c = self.second_moment / self.volume;
        Matrix3::identity() * c.trace() - c
    }

    /// The farthest corner from the centroid: the bounding radius.
    #[inline]
    pub fn circumradius(&self) -> f64 {
        self.circumradius
    }

    /// The half-extents of the box along the body axes that holds the
    /// hull.
    #[inline]
    pub fn half_extents(&self) -> V3 {
        self.half_extents
    }

    /// The nearest face to the centroid: the inscribed radius about it.
    pub fn inradius(&self) -> f64 {
        self.faces
            .iter()
            .map(|f| f.offset)
            .fold(f64::INFINITY, f64::min)
    }

    /// The corner farthest along `dir` (the support mapping).
    #[inline]
    pub fn support(&self, dir: &V3) -> V3 {
        farthest(&self.vertices, dir)
    }

    fn face_area(&self, f: &Face) -> f64 {
        let p = |k: usize| self.vertices[f.vertices[k]];
        (1..f.vertices.len() - 1)
            .map(|k| (p(k) - p(0)).cross(&(p(k + 1) - p(0))).dot(&f.normal))
            .sum::<f64>()
            * 0.5
    }

    fn integral_mean_curvature(&self) -> f64 {
        let faces_of = |a: usize, b: usize| self.faces.iter().filter(move |f| f.has_edge(a, b));
        self.edges
            .iter()
            .map(|&(a, b)| {
                let mut two = faces_of(a, b);
                let (f, g) = (two.next().unwrap(), two.next().unwrap());
                let turn = f.normal.dot(&g.normal).clamp(-1.0, 1.0).acos();
                0.5 * (self.vertices[a] - self.vertices[b]).norm() * turn
            })
            .sum()
    }

    /// ∫ x xᵀ dV by the tetrahedra joining the origin to each face's fan:
    /// for the tetrahedron (0, a, b, c) of volume V it is
    /// V/20 (a aᵀ + b bᵀ + c cᵀ + s sᵀ), s = a + b + c.
    fn second_moment_about_origin(&self) -> Matrix3<f64> {
        let mut sum = Matrix3::zeros();
        for (a, b, c) in fans(&self.vertices, &self.faces) {
            let v = a.dot(&b.cross(&c)) / 6.0;
            let s = a + b + c;
            sum += (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose())
                * (v / 20.0);
        }
        sum
    }
}

/// The point of `points` (not empty) farthest along `dir`: the support
/// mapping of their hull.
#[inline]
pub fn farthest(points: &[V3], dir: &V3) -> V3 {
    let mut best = points[0];
    let mut reach = best.dot(dir);
    for v in &points[1..] {
        let r = v.dot(dir);
        if r > reach {
            (best, reach) = (*v, r);
        }
    }
    best
}

/// The hull of `points`, built once per distinct set of points (compared
/// bit for bit) and kept for the life of the program.
fn intern(
    points: &[V3],
    named: Option<(super::solids::Solid, f64)>,
) -> Result<&'static Polyhedron, PolyhedronError> {
    static HULLS: std::sync::Mutex<Vec<&'static Polyhedron>> = std::sync::Mutex::new(Vec::new());
    let same = |p: &Polyhedron| {
        p.named.map(|(s, e)| (s, e.to_bits())) == named.map(|(s, e)| (s, e.to_bits()))
            && p.given.len() == points.len()
            && (p.given.iter().zip(points)).all(|(a, b)| {
                a.iter()
                    .zip(b.iter())
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            })
    };
    let mut hulls = HULLS
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(known) = hulls.iter().find(|p| same(p)) {
        return Ok(known);
    }
    let hull: &'static Polyhedron = Box::leak(Box::new(Polyhedron {
        named,
        ..Polyhedron::new(points)?
    }));
    hulls.push(hull);
    Ok(hull)
}

/// The triangles (a, b, c) of each face's fan, counter-clockwise seen
/// from outside.
fn fans<'a>(vertices: &'a [V3], faces: &'a [Face]) -> impl Iterator<Item = (V3, V3, V3)> + 'a {
    faces.iter().flat_map(move |f| {
        let p = move |k: usize| vertices[f.vertices[k]];
        (1..f.vertices.len() - 1).map(move |k| (p(0), p(k), p(k + 1)))
    })
}

/// The solid's volume and centroid, by the tetrahedra joining the origin
/// to the faces' fans (signed, so the origin may lie anywhere).
fn volume_and_centroid(vertices: &[V3], faces: &[Face]) -> (f64, V3) {
    let (mut volume, mut moment) = (0.0, V3::zeros());
    for (a, b, c) in fans(vertices, faces) {
        let v = a.dot(&b.cross(&c)) / 6.0;
        volume += v;
        moment += (a + b + c) * (v / 4.0);
    }
    (volume, moment / volume)
}

/// Every distinct plane through three of `points` that has all of them on
/// its inner side: (outward unit normal, offset).
fn supporting_planes(points: &[V3], tol: f64) -> Vec<(V3, f64)> {
    let n = points.len();
    let mut planes: Vec<(V3, f64)> = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let cross = (points[j] - points[i]).cross(&(points[k] - points[i]));
                let Some(normal) = cross.try_normalize(tol * tol) else {
                    continue;
                };
                let offset = normal.dot(&points[i]);
                let (mut above, mut below) = (false, false);
                for p in points {
                    let s = normal.dot(p) - offset;
                    above |= s > tol;
                    below |= s < -tol;
                    if above && below {
                        break;
                    }
                }
                let plane = match (above, below) {
                    (false, true) => (normal, offset),
                    (true, false) => (-normal, -offset),
                    // Every point on the plane: flat.
                    (false, false) => return Vec::new(),
                    (true, true) => continue,
                };
                let known = planes
                    .iter()
                    .any(|(m, o)| (m - plane.0).norm() <= 1e-9 && (o - plane.1).abs() <= tol);
                if !known {
                    planes.push(plane);
                }
            }
        }
    }
    planes
}

/// The corners of the face on the plane (`normal`, `offset`): the points
/// on it that are extreme in it, counter-clockwise about `normal`.
fn face_corners(points: &[V3], normal: &V3, offset: f64, tol: f64) -> Vec<usize> {
    let on: Vec<usize> = (0..points.len())
        .filter(|&i| (normal.dot(&points[i]) - offset).abs() <= tol)
        .collect();
    let centre = on.iter().map(|&i| points[i]).sum::<V3>() / on.len() as f64;
    let u = (points[on[0]] - centre).normalize();
    let w = normal.cross(&u);
    let angle = |i: usize| {
        let d = points[i] - centre;
        d.dot(&w).atan2(d.dot(&u))
    };
    let mut ring = on.clone();
    ring.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)));
    // Drop points inside an edge of the face (not corners).
    let n = ring.len();
    let corner = |k: usize| {
        let (p, q, r) = (
            points[ring[(k + n - 1) % n]],
            points[ring[k]],
            points[ring[(k + 1) % n]],
        );
        (q - p).cross(&(r - q)).dot(normal) > tol * tol
    };
    (0..n).filter(|&k| corner(k)).map(|k| ring[k]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::gjk::gjk_intersect;
    use nalgebra::UnitQuaternion;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn points(p: &[[f64; 3]]) -> Vec<V3> {
        p.iter().map(|&[x, y, z]| V3::new(x, y, z)).collect()
    }

    /// A regular tetrahedron of edge 2√2 (alternate corners of a cube).
    fn tetrahedron() -> Polyhedron {
        Polyhedron::new(&points(&[
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ]))
        .unwrap()
    }

    fn cube(half: f64) -> Polyhedron {
        let corners: Vec<V3> = (0..8)
            .map(|k| V3::from_fn(|a, _| if k >> a & 1 == 1 { half } else { -half }))
            .collect();
        Polyhedron::new(&corners).unwrap()
    }

    /// A regular octahedron of edge √2.
    fn octahedron() -> Polyhedron {
        Polyhedron::new(&points(&[
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ]))
        .unwrap()
    }

    fn close(a: f64, b: f64, what: &str) {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
            "{what}: {a} against {b}"
        );
    }

    /// The hull's counts (Euler: V − E + F = 2), volume, area, mean
    /// curvature and inertia against the closed forms of the regular
    /// solids: tetrahedron of edge a, V = a³/(6√2), I = V a²/20 per unit
    /// mass·volume; cube of edge a, I = a²/6; octahedron of edge a,
    /// V = √2 a³/3, I = a²/10.
    fn counts(p: &Polyhedron) -> (usize, usize, usize) {
        (p.vertices().len(), p.edges().len(), p.faces().len())
    }

    #[test]
    fn the_regular_solids_have_their_closed_forms() {
        let t = tetrahedron();
        let a = 8f64.sqrt();
        assert_eq!(counts(&t), (4, 6, 4));
        close(
            t.volume(),
            a.powi(3) / (6.0 * 2f64.sqrt()),
            "tetrahedron volume",
        );
        close(t.surface_area(), 3f64.sqrt() * a * a, "tetrahedron area");
        let exterior = std::f64::consts::PI - (1.0f64 / 3.0).acos();
        close(
            t.mean_curvature_integral(),
            0.5 * 6.0 * a * exterior,
            "tetrahedron M",
        );
        for k in 0..3 {
            close(t.inertia()[(k, k)], a * a / 20.0, "tetrahedron inertia");
        }
        let c = cube(0.5);
        assert_eq!(counts(&c), (8, 12, 6));
        close(c.volume(), 1.0, "cube volume");
        close(c.surface_area(), 6.0, "cube area");
        close(
            c.mean_curvature_integral(),
            3.0 * std::f64::consts::PI,
            "cube M",
        );
        close(c.inertia()[(0, 0)], 1.0 / 6.0, "cube inertia");
        close(c.inradius(), 0.5, "cube inradius");
        close(c.circumradius(), 0.75f64.sqrt(), "cube circumradius");
        let o = octahedron();
        let a = 2f64.sqrt();
        assert_eq!(counts(&o), (6, 12, 8));
        close(
            o.volume(),
            2f64.sqrt() * a.powi(3) / 3.0,
            "octahedron volume",
        );
        close(o.inertia()[(1, 1)], a * a / 10.0, "octahedron inertia");
        for p in [&t, &c, &o] {
            let inertia = p.inertia();
            assert!((inertia - inertia.transpose()).norm() < 1e-14);
            close(
                inertia[(0, 1)].abs() + inertia[(1, 2)].abs(),
                0.0,
                "off-diagonal",
            );
        }
    }

    /// Points inside the hull, on its edges or on its faces are not
    /// corners; a box given off-centre is shifted to its centroid, and a
    /// turned box has the turned inertia.
    #[test]
    fn points_that_are_not_corners_are_dropped_and_the_centroid_moves_to_the_origin() {
        let mut p: Vec<V3> = cube(0.5).vertices().to_vec();
        p.extend(points(&[
            [0.1, 0.2, -0.1],
            [0.5, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.0, 0.0, -0.5],
        ]));
        let c = Polyhedron::new(&p).unwrap();
        assert_eq!(counts(&c), (8, 12, 6));
        let off = V3::new(0.05, -0.03, 0.02);
        let q = UnitQuaternion::from_euler_angles(0.3, -1.1, 0.7);
        let brick: Vec<V3> = (0..8)
            .map(|k| {
                let h = V3::new(1.0, 0.5, 0.25);
                q * V3::from_fn(|a, _| if k >> a & 1 == 1 { h[a] } else { -h[a] }) + off
            })
            .collect();
        let b = Polyhedron::new(&brick).unwrap();
        assert!((b.shift() + off).norm() < 1e-12, "{:?}", b.shift());
        close(b.volume(), 1.0, "brick volume");
        let r = q.to_rotation_matrix().into_inner();
        let own = Matrix3::from_diagonal(&V3::new(0.25 + 0.0625, 1.0 + 0.0625, 1.25)) / 3.0;
        assert!((b.inertia() - r * own * r.transpose()).norm() < 1e-12);
    }

    /// The support mapping is the farthest point given, in every direction.
    #[test]
    fn the_support_is_the_farthest_point_given() {
        let mut rng = Pcg64::seed_from_u64(5);
        let given: Vec<V3> = (0..40)
            .map(|_| V3::from_fn(|_, _| rng.r#gen::<f64>() - 0.5))
            .chain(octahedron().given().iter().copied())
            .collect();
        let p = Polyhedron::new(&given).unwrap();
        assert_eq!(
            p.vertices().len() - p.edges().len() + p.faces().len(),
            2,
            "Euler"
        );
        for _ in 0..2000 {
            let d = V3::from_fn(|_, _| rng.r#gen::<f64>() - 0.5);
            let best = given.iter().map(|v| v.dot(&d)).fold(f64::MIN, f64::max);
            let s = p.support(&d) - p.shift();
            assert!((s.dot(&d) - best).abs() < 1e-12);
        }
    }

    /// Isihara–Hadwiger: two convex bodies of volume V, area S and mean
    /// curvature integral M, turned at random, exclude 2V + S M / (2π)
    /// (orientational average); the overlap fraction of random placements
    /// in a box, decided by GJK on the support mappings, agrees within
    /// four standard errors, for the tetrahedron and the cube.
    #[test]
    fn random_pairs_exclude_the_isihara_hadwiger_volume() {
        let mut rng = Pcg64::seed_from_u64(11);
        for p in [tetrahedron(), cube(0.5)] {
            let expected = 2.0 * p.volume()
                + p.surface_area() * p.mean_curvature_integral() / (2.0 * std::f64::consts::PI);
            let side = 4.0 * p.circumradius();
            let tries = 200_000;
            let mut hits = 0u32;
            for _ in 0..tries {
                let d = V3::from_fn(|_, _| (rng.r#gen::<f64>() - 0.5) * side);
                let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    rng.sample::<f64, _>(rand_distr::StandardNormal),
                    rng.sample(rand_distr::StandardNormal),
                    rng.sample(rand_distr::StandardNormal),
                    rng.sample(rand_distr::StandardNormal),
                ));
                let sb = |dir: &V3| q * p.support(&q.inverse_transform_vector(dir)) + d;
                if gjk_intersect(|dir: &V3| p.support(dir), sb, d, 64).unwrap_or(true) {
                    hits += 1;
                }
            }
            let f = hits as f64 / tries as f64;
            let measured = f * side.powi(3);
            let error = side.powi(3) * (f * (1.0 - f) / tries as f64).sqrt();
            assert!(
                (measured - expected).abs() < 4.0 * error,
                "{measured} ± {error} against {expected}"
            );
        }
    }

    /// Bad points are refused by name.
    #[test]
    fn bad_points_are_refused() {
        let t = tetrahedron().vertices().to_vec();
        assert_eq!(
            Polyhedron::new(&t[..3]),
            Err(PolyhedronError::VertexCount(3))
        );
        let mut nan = t.clone();
        nan[2].y = f64::NAN;
        assert!(matches!(
            Polyhedron::new(&nan),
            Err(PolyhedronError::NonFinite { index: 2, .. })
        ));
        let mut twice = t.clone();
        twice.push(t[1]);
        assert_eq!(
            Polyhedron::new(&twice),
            Err(PolyhedronError::Repeated {
                first: 1,
                second: 4
            })
        );
        let flat = points(&[
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
        ]);
        assert_eq!(Polyhedron::new(&flat), Err(PolyhedronError::Flat));
        let shifted: Vec<V3> = t.iter().map(|v| v + V3::new(3.0, 0.0, 0.0)).collect();
        assert!(matches!(
            Polyhedron::new(&shifted),
            Err(PolyhedronError::OriginOutside { .. })
        ));
        // A needle with two corners 1e-2 apart at its base, on planes
        // found to 6.6e-5: the faces near them do not close (a fuzzed
        // scene's; an edge on one face only once panicked here).
        let sliver = points(&[
            [1.0, 65536.0, 1.0],
            [1.01, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, -1.0],
        ]);
        assert!(matches!(
            Polyhedron::new(&sliver),
            Err(PolyhedronError::Degenerate { .. })
        ));
    }
}
