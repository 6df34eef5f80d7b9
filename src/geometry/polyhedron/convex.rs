//! The convex polyhedron shape: an interned hull at a scale, with a
//! rounding for spheropolyhedra.

use nalgebra::Matrix3;

use super::{Polyhedron, PolyhedronError, V3, intern};

/// The convex polyhedron shape: a hull kept for the life of the program
/// (so that the shape stays a small `Copy` value, as every shape is), at
/// a scale (a growing body's), swept by a ball of radius `rounding` (a
/// spheropolyhedron; 0 for the polyhedron itself).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConvexPolyhedron {
    hull: &'static Polyhedron,
    scale: f64,
    rounding: f64,
}

impl ConvexPolyhedron {
    /// The polyhedron of `points` at scale 1 ([`Polyhedron::new`]'s
    /// refusals). Polyhedra of the same points share one hull.
    pub fn new(points: &[V3]) -> Result<Self, PolyhedronError> {
        Ok(Self {
            hull: intern(points, None)?,
            scale: 1.0,
            rounding: 0.0,
        })
    }

    /// The named solid of edge length `edge` (> 0), centred on its centroid.
    pub fn solid(
        solid: crate::geometry::solids::Solid,
        edge: f64,
    ) -> Result<Self, PolyhedronError> {
        if !(edge.is_finite() && edge > 0.0) {
            return Err(PolyhedronError::Edge(edge));
        }
        Ok(Self {
            hull: intern(&solid.corners(edge), Some((solid, edge)))?,
            scale: 1.0,
            rounding: 0.0,
        })
    }

    /// This polyhedron swept by a ball of radius `radius` (finite, ≥ 0;
    /// the constructors of shapes check it): the spheropolyhedron whose
    /// core it is.
    pub fn rounded(&self, radius: f64) -> Self {
        Self {
            rounding: radius,
            ..*self
        }
    }

    /// The radius of the ball the hull is swept by (0: a polyhedron).
    #[inline]
    pub fn rounding(&self) -> f64 {
        self.rounding
    }

    /// The polyhedron without its rounding.
    #[inline]
    pub fn core(&self) -> Self {
        self.rounded(0.0)
    }

    /// The hull at scale 1.
    pub fn hull(&self) -> &'static Polyhedron {
        self.hull
    }

    /// The factor every length of the hull is multiplied by.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The same body `factor` times larger: the polyhedron of its corners
    /// scaled (so that it is, to the bit, the shape its record reads back
    /// to; each new size is a new hull kept for the program's life), and
    /// its rounding scaled.
    pub fn scaled(&self, factor: f64) -> Self {
        let scale = self.scale * factor;
        let rounding = self.rounding * factor;
        let corners: Vec<V3> = self.hull.vertices.iter().map(|v| v * scale).collect();
        match intern(&corners, None) {
            Ok(hull) => Self {
                hull,
                scale: 1.0,
                rounding,
            },
            // Sizes so far from 1 that the corners underflow or overflow.
            Err(_) => Self {
                hull: self.hull,
                scale,
                rounding,
            },
        }
    }

    /// The point farthest along `dir`: the core's corner, moved by the
    /// rounding along `dir`.
    #[inline]
    pub fn support(&self, dir: &V3) -> V3 {
        let corner = self.hull.support(dir) * self.scale;
        if self.rounding == 0.0 {
            return corner;
        }
        let n = dir.norm();
        if n > 0.0 {
            corner + dir * (self.rounding / n)
        } else {
            corner
        }
    }

    /// The core's corners at the body's scale, about its centroid.
    pub fn corners(&self) -> impl Iterator<Item = V3> + '_ {
        self.hull.vertices.iter().map(|v| v * self.scale)
    }

    /// The volume (Steiner: V + S r + M r² + 4πr³/3 with the core's
    /// volume V, area S and mean-curvature integral M).
    pub fn volume(&self) -> f64 {
        let (s, r) = (self.scale, self.rounding);
        let h = self.hull;
        h.volume * s.powi(3)
            + h.area * s * s * r
            + h.mean_curvature * s * r * r
            + 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)
    }

    /// The surface area (S + 2 M r + 4πr²).
    pub fn surface_area(&self) -> f64 {
        let (s, r) = (self.scale, self.rounding);
        self.hull.area * s * s
            + 2.0 * self.hull.mean_curvature * s * r
            + 4.0 * std::f64::consts::PI * r * r
    }

    /// The mean-curvature integral (M + 4πr).
    pub fn mean_curvature_integral(&self) -> f64 {
        self.hull.mean_curvature * self.scale + 4.0 * std::f64::consts::PI * self.rounding
    }

    /// The inertia tensor of the uniform solid of unit mass about the body
    /// origin (the core's centroid; the swept solid's centroid too for a
    /// core with a centre of symmetry or a regular one), in the body frame.
    pub fn inertia(&self) -> Matrix3<f64> {
        let (volume, _, second) = self.hull.swept_moments(self.scale, self.rounding);
        let c = second / volume;
        Matrix3::identity() * c.trace() - c
    }

    /// How the core's support value h(u + u̇τ) = max over corners v of
    /// v·u + (v·u̇) τ, a convex broken line in τ, is bounded by two of its
    /// lines: (h, b₀, h₂, b_max) with h = h(u) reached at the corner v₀,
    /// b₀ = v₀·u̇, h₂ the largest v·u of the other corners and b_max the
    /// largest v·u̇ of any, so that h(u + u̇τ) ≤ max(h + b₀τ, h₂ + b_maxτ)
    /// for τ ≥ 0.
    pub fn support_lines(&self, u: &V3, u_dot: &V3) -> (f64, f64, f64, f64) {
        let corners = &self.hull.vertices;
        let (mut h, mut b0) = (f64::NEG_INFINITY, 0.0);
        let (mut h2, mut b_max) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for v in corners {
            let (a, b) = (v.dot(u), v.dot(u_dot));
            if a > h {
                h2 = h;
                (h, b0) = (a, b);
            } else if a > h2 {
                h2 = a;
            }
            b_max = b_max.max(b);
        }
        let s = self.scale;
        (h * s, b0 * s, h2 * s, b_max * s)
    }

    /// The farthest point from the body origin: the bounding radius.
    #[inline]
    pub fn bounding_radius(&self) -> f64 {
        self.hull.circumradius * self.scale + self.rounding
    }

    /// The half-extents of the box along the body axes that holds the body.
    #[inline]
    pub fn half_extents(&self) -> V3 {
        self.hull.half_extents * self.scale + V3::repeat(self.rounding)
    }
}
