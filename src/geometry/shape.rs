//! The six convex shapes: sphere, triaxial ellipsoid, superellipsoid, cuboid,
//! spherocylinder, convex polyhedron (built in [`super::polyhedron`]).
//!
//! Every shape is centred at its body origin with its semi-axes along body
//! x, y, z (docs/CONVENTIONS.md). Constructors validate their
//! arguments, so a shape with a zero, negative or non-finite size cannot be
//! built (HOOMD-blue once let an ellipsoid with a zero axis silently never
//! overlap).

use nalgebra::{Matrix3, Vector3};
use statrs::function::gamma::ln_gamma;

use super::roots::brent_minimize;

mod support;
pub use super::polyhedron::ConvexPolyhedron;
pub use support::Support;

/// A shape that cannot be built, with the parameter at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A length (radius, semi-axis, half-length) that is not finite and > 0.
    #[error("{shape}: {field} must be a finite number > 0, got {value}")]
    NonPositiveLength {
        /// Shape kind, as spelled in a scene.
        shape: &'static str,
        /// Parameter name, as spelled in a scene.
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// A superellipsoid exponent below 2 (the body would not be smooth and
    /// convex) or not finite.
    #[error("Superellipsoid: exponent {field} must be a finite number >= 2, got {value}")]
    BadExponent {
        /// Which exponent (`n`, `m` or `p`).
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// Points that are not a convex polyhedron holding the body origin.
    #[error("ConvexPolyhedron: {0}")]
    Polyhedron(#[from] super::polyhedron::PolyhedronError),
}

pub(super) fn positive(
    shape: &'static str,
    field: &'static str,
    value: f64,
) -> Result<f64, ShapeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::NonPositiveLength {
            shape,
            field,
            value,
        })
    }
}

/// A sphere of the given radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    radius: f64,
}

impl Sphere {
    /// A sphere of radius `radius` (> 0).
    pub fn new(radius: f64) -> Result<Self, ShapeError> {
        Ok(Self {
            radius: positive("Sphere", "radius", radius)?,
        })
    }
    /// Radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
}

/// A triaxial ellipsoid (x/a)² + (y/b)² + (z/c)² ≤ 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    semi_axes: Vector3<f64>,
}

impl Ellipsoid {
    /// An ellipsoid with semi-axes `a`, `b`, `c` along body x, y, z.
    pub fn new(a: f64, b: f64, c: f64) -> Result<Self, ShapeError> {
        Ok(Self {
            semi_axes: Vector3::new(
                positive("Ellipsoid", "a", a)?,
                positive("Ellipsoid", "b", b)?,
                positive("Ellipsoid", "c", c)?,
            ),
        })
    }
    /// Semi-axes (a, b, c).
    pub fn semi_axes(&self) -> Vector3<f64> {
        self.semi_axes
    }
}

/// A superellipsoid |x/a|ⁿ + |y/b|ᵐ + |z/c|ᵖ ≤ 1 with exponents ≥ 2
/// (De Michele eq. 77).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Superellipsoid {
    semi_axes: Vector3<f64>,
    exponents: Vector3<f64>,
    /// Cached: the search over the surface costs ~10⁴ evaluations.
    bounding_radius: f64,
}

impl Superellipsoid {
    /// A superellipsoid with semi-axes `a, b, c` and exponents `(n, m, p)`.
    pub fn new(a: f64, b: f64, c: f64, exponents: (f64, f64, f64)) -> Result<Self, ShapeError> {
        let check = |field, value: f64| {
            if value.is_finite() && value >= 2.0 {
                Ok(value)
            } else {
                Err(ShapeError::BadExponent { field, value })
            }
        };
        let semi_axes = Vector3::new(
            positive("Superellipsoid", "a", a)?,
            positive("Superellipsoid", "b", b)?,
            positive("Superellipsoid", "c", c)?,
        );
        let exponents = Vector3::new(
            check("n", exponents.0)?,
            check("m", exponents.1)?,
            check("p", exponents.2)?,
        );
        Ok(Self {
            semi_axes,
            exponents,
            bounding_radius: superellipsoid_bounding_radius(&semi_axes, &exponents),
        })
    }
    /// Semi-axes (a, b, c).
    pub fn semi_axes(&self) -> Vector3<f64> {
        self.semi_axes
    }
    /// Exponents (n, m, p).
    pub fn exponents(&self) -> Vector3<f64> {
        self.exponents
    }
}

/// A rectangular cuboid with half-lengths `a, b, c` along body x, y, z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cuboid {
    half_extents: Vector3<f64>,
}

impl Cuboid {
    /// A cuboid with half-lengths `a`, `b`, `c`.
    pub fn new(a: f64, b: f64, c: f64) -> Result<Self, ShapeError> {
        Ok(Self {
            half_extents: Vector3::new(
                positive("Cuboid", "a", a)?,
                positive("Cuboid", "b", b)?,
                positive("Cuboid", "c", c)?,
            ),
        })
    }
    /// Half-lengths (a, b, c).
    pub fn half_extents(&self) -> Vector3<f64> {
        self.half_extents
    }
}

/// A spherocylinder: the points within `radius` of the segment of length
/// `length` along the body z axis through the centre (a cylinder capped
/// by two hemispheres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spherocylinder {
    radius: f64,
    half_length: f64,
}

impl Spherocylinder {
    /// A spherocylinder of radius `radius` whose axis segment (the
    /// cylinder's length) is `length`, both > 0.
    pub fn new(radius: f64, length: f64) -> Result<Self, ShapeError> {
        Ok(Self {
            radius: positive("Spherocylinder", "radius", radius)?,
            half_length: positive("Spherocylinder", "length", length)? / 2.0,
        })
    }
    /// Radius of the caps and the cylinder.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Half the length of the axis segment.
    pub fn half_length(&self) -> f64 {
        self.half_length
    }
}

/// One of the six shapes. The set is closed: the pair dispatch matches on
/// every combination, so an unhandled pair is a compile error. It is
/// written and read as its [`super::spec::ShapeSpec`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A sphere.
    Sphere(Sphere),
    /// A triaxial ellipsoid.
    Ellipsoid(Ellipsoid),
    /// A superellipsoid.
    Superellipsoid(Superellipsoid),
    /// A cuboid.
    Cuboid(Cuboid),
    /// A spherocylinder along the body z axis.
    Spherocylinder(Spherocylinder),
    /// A convex polyhedron, or a spheropolyhedron (one swept by a ball:
    /// [`ConvexPolyhedron::rounding`] > 0).
    ConvexPolyhedron(ConvexPolyhedron),
}

/// ∫ |x|^{k_x} |y|^{k_y} |z|^{k_z} dV over |x/a|ⁿ + |y/b|ᵐ + |z/c|ᵖ ≤ 1, by
/// the Dirichlet–Liouville integral: 8 Π aᵢ^{kᵢ+1} Γ((kᵢ+1)/pᵢ)/pᵢ
/// ÷ Γ(1 + Σ (kᵢ+1)/pᵢ).
fn superellipsoid_moment(semi: &Vector3<f64>, exps: &Vector3<f64>, k: [f64; 3]) -> f64 {
    let mut log_num = 0.0;
    let mut sum = 0.0;
    for i in 0..3 {
        let alpha = k[i] + 1.0;
        log_num += alpha * semi[i].ln() + ln_gamma(alpha / exps[i]) - exps[i].ln();
        sum += alpha / exps[i];
    }
    8.0 * (log_num - ln_gamma(1.0 + sum)).exp()
}

/// Bounds on a turning body's support value along a fixed lab direction
/// (see [`Shape::support_growth`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportGrowth {
    /// h(u(0)).
    pub value: f64,
    /// Linear coefficient of the bound.
    pub slope: f64,
    /// Kinks (weight w, c, rate r): each adds w (|c + rτ| − |c|) to the
    /// bound (cuboids: h = Σ aₖ|uₖ|; weight 0 for the other shapes).
    pub kinks: [(f64, f64, f64); 3],
    /// Quadratic coefficient (× ½ τ²) of the quadratic bound.
    pub curvature: f64,
    /// A bound on |ḣ| over all τ (the linear bound's coefficient).
    pub lipschitz: f64,
}

impl SupportGrowth {
    /// The bound for the body scaled by `scale` and growing from there at
    /// `rate` (d scale/dτ), of a body whose support values are at most
    /// `reach` (its bounding radius): (s + ṡτ) h(τ) ≤ s · bound(τ) + ṡ
    /// reach τ.
    pub fn grown(&self, scale: f64, rate: f64, reach: f64) -> SupportGrowth {
        SupportGrowth {
            value: self.value * scale,
            slope: self.slope * scale + rate * reach,
            kinks: self.kinks.map(|(w, c, r)| (w * scale, c, r)),
            curvature: self.curvature * scale,
            lipschitz: self.lipschitz * scale + rate * reach,
        }
    }
}

impl Shape {
    /// Short lowercase name of the shape kind (`sphere`, `ellipsoid`, ...).
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Sphere(_) => "sphere",
            Shape::Ellipsoid(_) => "ellipsoid",
            Shape::Superellipsoid(_) => "superellipsoid",
            Shape::Cuboid(_) => "cuboid",
            Shape::Spherocylinder(_) => "spherocylinder",
            Shape::ConvexPolyhedron(p) if p.rounding() > 0.0 => "spheropolyhedron",
            Shape::ConvexPolyhedron(_) => "convex_polyhedron",
        }
    }

    /// Volume of the body.
    pub fn volume(&self) -> f64 {
        use std::f64::consts::PI;
        match self {
            Shape::Sphere(s) => 4.0 / 3.0 * PI * s.radius.powi(3),
            Shape::Ellipsoid(e) => 4.0 / 3.0 * PI * e.semi_axes.product(),
            Shape::Superellipsoid(s) => superellipsoid_moment(&s.semi_axes, &s.exponents, [0.0; 3]),
            Shape::Cuboid(c) => 8.0 * c.half_extents.product(),
            Shape::Spherocylinder(s) => {
                let (r, h) = (s.radius, s.half_length);
                PI * r * r * (2.0 * h + 4.0 / 3.0 * r)
            }
            Shape::ConvexPolyhedron(p) => p.volume(),
        }
    }

    /// Second moments ∫ x² dV, ∫ y² dV, ∫ z² dV in the body frame.
    fn second_moments(&self) -> Vector3<f64> {
        match self {
            Shape::Sphere(s) => {
                let v = self.volume();
                Vector3::repeat(v * s.radius * s.radius / 5.0)
            }
            Shape::Ellipsoid(e) => {
                let v = self.volume();
                e.semi_axes.map(|a| v * a * a / 5.0)
            }
            Shape::Superellipsoid(s) => Vector3::new(
                superellipsoid_moment(&s.semi_axes, &s.exponents, [2.0, 0.0, 0.0]),
                superellipsoid_moment(&s.semi_axes, &s.exponents, [0.0, 2.0, 0.0]),
                superellipsoid_moment(&s.semi_axes, &s.exponents, [0.0, 0.0, 2.0]),
            ),
            Shape::Cuboid(c) => {
                let v = self.volume();
                c.half_extents.map(|a| v * a * a / 3.0)
            }
            Shape::Spherocylinder(s) => {
                use std::f64::consts::PI;
                // The cylinder (length 2h) and the two caps, each a
                // hemisphere whose flat face is at z = ±h: ∫x² over the
                // cylinder is V_c r²/4, over a ball 4πr⁵/15; ∫z² over the
                // cylinder V_c h²/3, over the two caps (shifted by h)
                // 4πr⁵/15 + 2h·(3r/8)·(2πr³/3)·2 + h²·(4πr³/3).
                let (r, h) = (s.radius, s.half_length);
                let cylinder = PI * r * r * 2.0 * h;
                let ball = 4.0 / 3.0 * PI * r.powi(3);
                let across = cylinder * r * r / 4.0 + ball * r * r / 5.0;
                let along = cylinder * h * h / 3.0
                    + ball * r * r / 5.0
                    + 2.0 * h * (3.0 * r / 8.0) * ball
                    + h * h * ball;
                Vector3::new(across, across, along)
            }
            Shape::ConvexPolyhedron(_) => {
                let i = self.inertia_tensor(self.volume());
                // ∫x² = (I_yy + I_zz − I_xx)/2 and so on, for unit density.
                Vector3::from_fn(|k, _| 0.5 * (i.trace() - 2.0 * i[(k, k)]))
            }
        }
    }

    /// Inertia tensor of a uniform solid of mass `mass`, in the body frame
    /// (diagonal: the body axes are principal axes for every shape but a
    /// polyhedron, whose tensor is its own).
    pub fn inertia_tensor(&self, mass: f64) -> Matrix3<f64> {
        if let Shape::ConvexPolyhedron(p) = self {
            if p.rounding() > 0.0 {
                return p.inertia() * mass;
            }
            return p.hull().inertia() * (mass * p.scale() * p.scale());
        }
        let m2 = self.second_moments() * (mass / self.volume());
        Matrix3::from_diagonal(&Vector3::new(m2.y + m2.z, m2.x + m2.z, m2.x + m2.y))
    }

    /// The same body scaled by `factor` (> 0) in every length: what a
    /// body growing at a uniform rate becomes. Every distance between
    /// scaled bodies is `factor` times the distance between the bodies at
    /// centre separations divided by it.
    pub fn scaled(&self, factor: f64) -> Shape {
        debug_assert!(factor.is_finite() && factor > 0.0, "{factor}");
        match self {
            Shape::Sphere(s) => Shape::Sphere(Sphere {
                radius: s.radius * factor,
            }),
            Shape::Ellipsoid(e) => Shape::Ellipsoid(Ellipsoid {
                semi_axes: e.semi_axes * factor,
            }),
            Shape::Superellipsoid(s) => {
                // The bounding radius found again for the scaled semi-axes,
                // not scaled: a function of the semi-axes alone, as for
                // the shape read back from a log's record of it (the
                // searches' bounds read it, and a resumed run must see
                // the same bits).
                let semi_axes = s.semi_axes * factor;
                Shape::Superellipsoid(Superellipsoid {
                    semi_axes,
                    exponents: s.exponents,
                    bounding_radius: superellipsoid_bounding_radius(&semi_axes, &s.exponents),
                })
            }
            Shape::Cuboid(c) => Shape::Cuboid(Cuboid {
                half_extents: c.half_extents * factor,
            }),
            Shape::Spherocylinder(s) => Shape::Spherocylinder(Spherocylinder {
                radius: s.radius * factor,
                half_length: s.half_length * factor,
            }),
            Shape::ConvexPolyhedron(p) => Shape::ConvexPolyhedron(p.scaled(factor)),
        }
    }

    /// Radius of the smallest sphere about the body centre that holds the body.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Sphere(s) => s.radius,
            Shape::Ellipsoid(e) => e.semi_axes.max(),
            Shape::Superellipsoid(s) => s.bounding_radius,
            Shape::Cuboid(c) => c.half_extents.norm(),
            Shape::Spherocylinder(s) => s.radius + s.half_length,
            Shape::ConvexPolyhedron(p) => p.bounding_radius(),
        }
    }

    /// An upper bound on |x × n(x)| over the surface (x from the centre, n
    /// the unit normal there): the arm with which a rotation moves a surface
    /// point along its normal, so that a body turning at ω changes its
    /// distance to anything no faster than |ω| times this. Exact for
    /// spheres (0), ellipsoids (largest minus smallest semi-axis) and
    /// cuboids (√(a² + b²) of the two largest half-lengths: at a vertex x
    /// any normal n of the cone there has x·n ≥ the smallest half-length);
    /// the bounding radius for superellipsoids.
    pub fn moment_arm(&self) -> f64 {
        match self {
            Shape::Sphere(_) => 0.0,
            Shape::Ellipsoid(e) => e.semi_axes.max() - e.semi_axes.min(),
            Shape::Cuboid(c) => {
                let h = c.half_extents;
                (h.norm_squared() - h.min() * h.min()).sqrt()
            }
            Shape::Superellipsoid(_) => self.bounding_radius(),
            // On the cylinder x × n = z e_z × n, on a cap x × n = c × n
            // with c = ±h e_z: at most h, reached at the rims.
            Shape::Spherocylinder(s) => s.half_length,
            // |x × n| ≤ |x|.
            Shape::ConvexPolyhedron(_) => self.bounding_radius(),
        }
    }

    /// How the support value h(u) = max_x x·u of a turning body can grow
    /// along the body-frame image u(τ) of a fixed lab direction (|u| = 1,
    /// u̇(0) = `u_dot`, with |u̇| ≤ `speed` and |ü| ≤ `accel` throughout):
    /// h(u(τ)) ≤ value + slope τ + Σ w (|c + rτ| − |c|) + ½ curvature τ²
    /// (over the kinks) and ≤ value + lipschitz τ, for every τ ≥ 0.
    /// Since ḣ = ∇h·u̇ and ḧ = u̇ᵀ∇²h u̇ + ∇h·ü with ∇h the
    /// support point and ∇²h the radii of curvature there: for ellipsoids
    /// slope = x·u̇ and curvature = R_max speed² + a_max accel (R_max =
    /// a_max²/a_min); for cuboids h = Σ aₖ|uₖ| with |uₖ(τ)| ≤
    /// |uₖ + u̇ₖτ| + |Rₖ(τ)| (a kink where uₖ + u̇ₖτ changes sign: a face
    /// normal crossing the plane of n) and, R being the Taylor remainder,
    /// Σ aₖ|Rₖ| ≤ |a| |R| ≤ ½ |a| accel τ² (Cauchy–Schwarz: |a|, not
    /// Σ aₖ); superellipsoids, whose faces may be flat, get
    /// only the Lipschitz bound (|ḣ| ≤ |x × u| |u̇| ≤ moment arm × speed).
    pub fn support_growth(
        &self,
        u: &Vector3<f64>,
        u_dot: &Vector3<f64>,
        speed: f64,
        accel: f64,
    ) -> SupportGrowth {
        let lipschitz = self.moment_arm() * speed;
        match self {
            Shape::Sphere(s) => SupportGrowth {
                value: s.radius,
                slope: 0.0,
                kinks: [(0.0, 0.0, 0.0); 3],
                curvature: 0.0,
                lipschitz: 0.0,
            },
            Shape::Ellipsoid(e) => {
                let x = e.support(u);
                let (big, small) = (e.semi_axes.max(), e.semi_axes.min());
                SupportGrowth {
                    value: x.dot(u),
                    slope: x.dot(u_dot),
                    kinks: [(0.0, 0.0, 0.0); 3],
                    curvature: big * big / small * speed * speed + big * accel,
                    lipschitz,
                }
            }
            Shape::Cuboid(c) => {
                let h = c.half_extents;
                SupportGrowth {
                    value: h.dot(&u.abs()),
                    slope: 0.0,
                    kinks: [0, 1, 2].map(|k| (h[k], u[k], u_dot[k])),
                    curvature: h.norm() * accel,
                    lipschitz,
                }
            }
            Shape::ConvexPolyhedron(p) => {
                // max(h + b₀τ, h₂ + b_maxτ) = h + b₀τ + max(0, sτ − Δ) with
                // s = b_max − b₀, Δ = h − h₂: the hinge is the kink
                // ½(|sτ − Δ| − Δ) plus ½sτ. The corners' remainder
                // v·(u(τ) − u − u̇τ) is at most the circumradius × ½ accel τ².
                let (h, b0, h2, b_max) = p.support_lines(u, u_dot);
                let rise = (b_max - b0).max(0.0);
                let drop = (h - h2).max(0.0);
                let circumradius = p.bounding_radius() - p.rounding();
                SupportGrowth {
                    value: h + p.rounding(),
                    slope: b0 + 0.5 * rise,
                    kinks: [(0.5, -drop, rise), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)],
                    curvature: circumradius * accel,
                    lipschitz,
                }
            }
            Shape::Superellipsoid(_) => SupportGrowth {
                value: self.support(u).dot(u),
                slope: lipschitz,
                kinks: [(0.0, 0.0, 0.0); 3],
                curvature: 0.0,
                lipschitz,
            },
            // h = r + h_s |u_z|: the cuboid's bound along one axis, the
            // radius a constant.
            Shape::Spherocylinder(s) => SupportGrowth {
                value: s.radius + s.half_length * u.z.abs(),
                slope: 0.0,
                kinks: [
                    (s.half_length, u.z, u_dot.z),
                    (0.0, 0.0, 0.0),
                    (0.0, 0.0, 0.0),
                ],
                curvature: s.half_length * accel,
                lipschitz,
            },
        }
    }

    /// Half-extents of the tightest box about the body centre, along the body
    /// axes, that holds the body (its oriented bounding box).
    pub fn obb_half_extents(&self) -> Vector3<f64> {
        match self {
            Shape::Sphere(s) => Vector3::repeat(s.radius),
            Shape::Ellipsoid(e) => e.semi_axes,
            Shape::Superellipsoid(s) => s.semi_axes,
            Shape::Cuboid(c) => c.half_extents,
            Shape::Spherocylinder(s) => Vector3::new(s.radius, s.radius, s.radius + s.half_length),
            Shape::ConvexPolyhedron(p) => p.half_extents(),
        }
    }

    /// Smallest length of the body's extent along its axes (a scale for
    /// tolerances).
    pub fn min_half_extent(&self) -> f64 {
        self.obb_half_extents().min()
    }

    /// The point of the body farthest along `dir` (body frame; `dir` need
    /// not be normalised, and must not be zero).
    pub fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        match self {
            Shape::Sphere(s) => s.support(dir),
            Shape::Ellipsoid(e) => e.support(dir),
            Shape::Superellipsoid(s) => s.support(dir),
            Shape::Cuboid(c) => c.support(dir),
            Shape::Spherocylinder(s) => s.support(dir),
            Shape::ConvexPolyhedron(p) => p.support(dir),
        }
    }

    /// How far the body turned by `rotation` (body → lab) reaches from its
    /// centre along each lab axis, up and down: the support values
    /// (hₖ(+eₖ), hₖ(−eₖ)) with h(d) = d · R s(Rᵀ d), the exact
    /// axis-aligned bounding box, which a body without a centre of
    /// symmetry (a tetrahedron) need not fill evenly. What a hard wall
    /// normal to eₖ on either side sees.
    pub fn lab_extents(&self, rotation: &nalgebra::Matrix3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        if let Shape::Sphere(s) = self {
            return (Vector3::repeat(s.radius), Vector3::repeat(s.radius));
        }
        let reach = |d: Vector3<f64>| d.dot(&self.support(&d));
        let up = Vector3::from_fn(|k, _| reach(rotation.row(k).transpose()));
        let down = Vector3::from_fn(|k, _| reach(-rotation.row(k).transpose()));
        (up, down)
    }

    /// Half-extents along the lab axes of the smallest box centred on the
    /// body that holds it turned by `rotation` (body → lab): the larger of
    /// the reaches up and down ([`Shape::lab_extents`]), which are equal for
    /// bodies symmetric through their centre.
    pub fn lab_half_extents(&self, rotation: &nalgebra::Matrix3<f64>) -> Vector3<f64> {
        let (up, down) = self.lab_extents(rotation);
        up.sup(&down)
    }

    /// Whether the body has rotational symmetry that makes orientation
    /// irrelevant (only the sphere).
    pub fn is_sphere(&self) -> bool {
        matches!(self, Shape::Sphere(_))
    }
}

/// max |x| over the superellipsoid surface. With uᵢ = |xᵢ/aᵢ|^{nᵢ} on the
/// simplex Σuᵢ = 1, |x|² = Σ aᵢ² uᵢ^{2/nᵢ} is concave (nᵢ ≥ 2), and so is its
/// partial maximum over u₁: nested Brent searches find the global maximum.
fn superellipsoid_bounding_radius(a: &Vector3<f64>, exponents: &Vector3<f64>) -> f64 {
    let p = exponents.map(|n| 2.0 / n);
    let r2 = |u0: f64, u1: f64| {
        let u2 = (1.0 - u0 - u1).max(0.0);
        a.x * a.x * u0.max(0.0).powf(p.x)
            + a.y * a.y * u1.max(0.0).powf(p.y)
            + a.z * a.z * u2.powf(p.z)
    };
    let inner = |u0: f64| -brent_minimize(|u1| -r2(u0, u1), 0.0, (1.0 - u0).max(0.0), 1e-13, 200).1;
    let (u0, _, _) = brent_minimize(|u0| -inner(u0), 0.0, 1.0, 1e-13, 200);
    // The corners of the simplex (the semi-axes) are candidates too: the
    // maximum of a concave function can sit on the boundary.
    let best = inner(u0).max(a.x * a.x).max(a.y * a.y).max(a.z * a.z);
    // A hair above the maximum so that it is a true bound after rounding.
    best.sqrt() * (1.0 + 1e-9)
}

#[cfg(test)]
mod tests;
