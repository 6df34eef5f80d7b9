//! The moments of a spheropolyhedron: a hull swept by a ball, split into
//! the hull and the slabs, wedges and sectors the rounding adds.

use nalgebra::Matrix3;

use super::{Polyhedron, V3};

impl Polyhedron {
    /// Volume, first moment ∫ x dV and second moment ∫ x xᵀ dV about the
    /// origin of the hull at `scale` swept by a ball of radius `r` (the
    /// spheropolyhedron; r = 0 the hull). The swept solid is the hull and,
    /// disjoint, the points whose nearest point of the hull lies inside a
    /// face (a slab of thickness r on it), inside an edge (a wedge of the
    /// cylinder of radius r about it, its angle the exterior dihedral angle)
    /// or at a corner (the ball's sector over the corner's normal cone).
    pub fn swept_moments(&self, scale: f64, r: f64) -> (f64, V3, Matrix3<f64>) {
        let s = scale;
        let (s3, s5) = (s.powi(3), s.powi(5));
        let (mut volume, mut first, mut second) =
            (self.volume * s3, V3::zeros(), self.second_moment * s5);
        if r == 0.0 {
            return (volume, first, second);
        }
        let outer = |a: &V3, b: &V3| a * b.transpose() + b * a.transpose();
        let corner = |k: usize| self.vertices[k] * s;
        // Faces: ∫ over t ∈ [0, r] and the face F of (x + t n)(x + t n)ᵀ,
        // with ∫_F x xᵀ dA by the triangles (a, b, c) of its fan, each
        // A/12 (a aᵀ + b bᵀ + c cᵀ + g gᵀ), g = a + b + c.
        for f in &self.faces {
            let (mut area, mut m1, mut m2) = (0.0, V3::zeros(), Matrix3::zeros());
            for k in 1..f.vertices.len() - 1 {
                let (a, b, c) = (
                    corner(f.vertices[0]),
                    corner(f.vertices[k]),
                    corner(f.vertices[k + 1]),
                );
                let t = 0.5 * (b - a).cross(&(c - a)).dot(&f.normal);
                let g = a + b + c;
                area += t;
                m1 += g * (t / 3.0);
                m2 +=
                    (a * a.transpose() + b * b.transpose() + c * c.transpose() + g * g.transpose())
                        * (t / 12.0);
            }
            let n = f.normal;
            volume += area * r;
            first += m1 * r + n * (area * r * r / 2.0);
            second += m2 * r
                + outer(&m1, &n) * (r * r / 2.0)
                + n * n.transpose() * (area * r.powi(3) / 3.0);
        }
        // Edges: the points p + σ e + ρ d(φ), σ ∈ [0, L], ρ ∈ [0, r], the
        // unit d(φ) = cos φ u + sin φ w turning from one face's normal u to
        // the other's over the exterior angle α (volume element ρ dρ dφ dσ).
        for &(i, j) in &self.edges {
            let (u, n2) = self.edge_normals(i, j);
            let (p, q) = (corner(i), corner(j));
            let length = (q - p).norm();
            let e = (q - p) / length;
            let alpha = u.dot(&n2).clamp(-1.0, 1.0).acos();
            let w = (n2 - u * alpha.cos()) / alpha.sin();
            let d1 = u * alpha.sin() + w * (1.0 - alpha.cos());
            let (c2, s2) = ((2.0 * alpha).sin() / 4.0, alpha.sin().powi(2) / 2.0);
            let d2 = u * u.transpose() * (alpha / 2.0 + c2)
                + w * w.transpose() * (alpha / 2.0 - c2)
                + outer(&u, &w) * s2;
            let m1 = p * length + e * (length * length / 2.0);
            let m2 = p * p.transpose() * length
                + outer(&p, &e) * (length * length / 2.0)
                + e * e.transpose() * (length.powi(3) / 3.0);
            volume += r * r / 2.0 * alpha * length;
            first += m1 * (r * r / 2.0 * alpha) + d1 * (r.powi(3) / 3.0 * length);
            second += m2 * (r * r / 2.0 * alpha)
                + outer(&m1, &d1) * (r.powi(3) / 3.0)
                + d2 * (r.powi(4) / 4.0 * length);
        }
        // Corners: v + ρ u over u in the normal cone C (a spherical polygon
        // of solid angle Ω = 2π − the face angles at v). By the divergence
        // theorem on the sphere (x and the traceless x xᵀ − |x|²/3 are
        // harmonics of degree 1 and 2, Δ = −2 and −6 there), with each
        // boundary arc's outward conormal the edge direction ê from v and
        // its arc ∫ u ds = tan(α/2)(n₁ + n₂):
        // ∫_C u dΩ = −½ Σ α ê, ∫_C u uᵀ dΩ = Ω/3 I − ⅙ Σ (ê Uᵀ + U êᵀ).
        for (k, v) in self.vertices.iter().enumerate() {
            let v = v * s;
            let mut omega = std::f64::consts::TAU;
            for f in self.faces.iter().filter(|f| f.vertices.contains(&k)) {
                let m = f.vertices.len();
                let at = f.vertices.iter().position(|&x| x == k).unwrap();
                let (prev, next) = (
                    corner(f.vertices[(at + m - 1) % m]),
                    corner(f.vertices[(at + 1) % m]),
                );
                omega -= (prev - v).angle(&(next - v));
            }
            let (mut j1, mut j2) = (V3::zeros(), Matrix3::identity() * (omega / 3.0));
            for &(i, j) in self.edges.iter().filter(|&&(i, j)| i == k || j == k) {
                let other = if i == k { j } else { i };
                let e = (corner(other) - v).normalize();
                let (n1, n2) = self.edge_normals(i, j);
                let alpha = n1.dot(&n2).clamp(-1.0, 1.0).acos();
                j1 -= e * (alpha / 2.0);
                j2 -= outer(&e, &((n1 + n2) * (alpha / 2.0).tan())) / 6.0;
            }
            volume += r.powi(3) / 3.0 * omega;
            first += v * (r.powi(3) / 3.0 * omega) + j1 * (r.powi(4) / 4.0);
            second += v * v.transpose() * (r.powi(3) / 3.0 * omega)
                + outer(&v, &j1) * (r.powi(4) / 4.0)
                + j2 * (r.powi(5) / 5.0);
        }
        (volume, first, second)
    }

    /// The outward normals of the two faces that meet at the edge between
    /// corners `a` and `b`.
    fn edge_normals(&self, a: usize, b: usize) -> (V3, V3) {
        let mut two = self.faces.iter().filter(|f| f.has_edge(a, b));
        let (f, g) = (two.next().unwrap(), two.next().unwrap());
        (f.normal, g.normal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn points(p: &[[f64; 3]]) -> Vec<V3> {
        p.iter().map(|&[x, y, z]| V3::new(x, y, z)).collect()
    }

    /// The distance from `x` to the hull (0 inside), by brute force over
    /// its faces: the nearest point of a face polygon is the projection
    /// where that falls inside it, else the nearest point of an edge.
    fn distance_to_hull(h: &Polyhedron, scale: f64, x: &V3) -> f64 {
        let segment = |p: V3, q: V3| {
            let t = ((x - p).dot(&(q - p)) / (q - p).norm_squared()).clamp(0.0, 1.0);
            (x - (p + (q - p) * t)).norm()
        };
        if h.faces.iter().all(|f| f.normal.dot(x) <= f.offset * scale) {
            return 0.0;
        }
        let mut best = f64::INFINITY;
        for f in &h.faces {
            let corner = |k: usize| h.vertices[f.vertices[k % f.vertices.len()]] * scale;
            let height = f.normal.dot(x) - f.offset * scale;
            let y = x - f.normal * height;
            let inside = (0..f.vertices.len()).all(|k| {
                (corner(k + 1) - corner(k))
                    .cross(&(y - corner(k)))
                    .dot(&f.normal)
                    >= 0.0
            });
            best = best.min(if inside {
                height.abs()
            } else {
                (0..f.vertices.len())
                    .map(|k| segment(corner(k), corner(k + 1)))
                    .fold(f64::INFINITY, f64::min)
            });
        }
        best
    }

    /// The swept solid's volume and moments against an independent route:
    /// Monte Carlo over its bounding box with membership by the brute-force
    /// distance to the hull (an irregular tetrahedron, whose moments have no
    /// symmetry to hide behind); its volume against Steiner's formula to
    /// round-off; the core alone at r = 0; a tiny core as the ball.
    #[test]
    fn swept_moments_are_those_of_the_points_within_the_rounding() {
        let hull = Polyhedron::new(&points(&[
            [1.1, 0.2, -0.3],
            [-0.4, 0.9, 0.1],
            [-0.5, -0.7, 0.6],
            [0.1, -0.2, -1.0],
        ]))
        .unwrap();
        let (scale, r) = (0.8, 0.3);
        let (volume, first, second) = hull.swept_moments(scale, r);
        let steiner = hull.volume * scale.powi(3)
            + hull.area * scale * scale * r
            + hull.mean_curvature * scale * r * r
            + 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        assert!(
            (volume - steiner).abs() < 1e-12 * steiner,
            "{volume} {steiner}"
        );
        let half = hull.circumradius * scale + r;
        let n = 400_000;
        let mut rng = Pcg64::seed_from_u64(5);
        let (mut hits, mut m1, mut m2) = (0usize, V3::zeros(), Matrix3::zeros());
        let (mut m1_sq, mut m2_sq) = (V3::zeros(), Matrix3::<f64>::zeros());
        for _ in 0..n {
            let x = V3::from_fn(|_, _| (rng.r#gen::<f64>() * 2.0 - 1.0) * half);
            if distance_to_hull(&hull, scale, &x) <= r {
                hits += 1;
                let xx = x * x.transpose();
                m1 += x;
                m2 += xx;
                m1_sq += x.component_mul(&x);
                m2_sq += xx.component_mul(&xx);
            }
        }
        let cell = (2.0 * half).powi(3) / n as f64;
        let p = hits as f64 / n as f64;
        let v_mc = p * cell * n as f64;
        let v_err = cell * (n as f64 * p * (1.0 - p)).sqrt();
        assert!(
            (v_mc - volume).abs() < 4.0 * v_err,
            "{v_mc} ± {v_err} vs {volume}"
        );
        // Each component's estimate is cell Σ g over hits, its variance
        // cell² (Σ g² − (Σ g)²/n).
        let check = |mc: f64, sq: f64, exact: f64, what: &str| {
            let err = cell * (sq - mc * mc / n as f64).max(0.0).sqrt();
            assert!(
                (mc * cell - exact).abs() < 4.0 * err + 1e-12,
                "{what}: {} ± {err} vs {exact}",
                mc * cell
            );
        };
        for k in 0..3 {
            check(m1[k], m1_sq[k], first[k], "first moment");
            for l in 0..3 {
                check(m2[(k, l)], m2_sq[(k, l)], second[(k, l)], "second moment");
            }
        }
        // The off-diagonal moments are not all small: the test can fail.
        let off_err = cell * (m2_sq[(0, 1)] - m2[(0, 1)].powi(2) / n as f64).sqrt();
        assert!(
            second[(0, 1)].abs() > 10.0 * off_err,
            "{} ± {off_err}",
            second[(0, 1)]
        );
        let (v0, f0, s0) = hull.swept_moments(scale, 0.0);
        assert_eq!(v0, hull.volume * scale.powi(3));
        assert_eq!(f0, V3::zeros());
        assert_eq!(s0, hull.second_moment * scale.powi(5));
        let (vb, fb, sb) = hull.swept_moments(1e-7, 1.0);
        let ball = 4.0 / 3.0 * std::f64::consts::PI;
        assert!((vb - ball).abs() < 1e-5 && fb.norm() < 1e-5, "{vb} {fb}");
        assert!(
            (sb - Matrix3::identity() * (ball / 5.0)).norm() < 1e-5,
            "{sb}"
        );
    }
}
