//! How a shape is written: its spelling in a scene (`ShapeSpec`, in RON),
//! the conversion to a validated [`Shape`], and the text form
//! `Ellipsoid(a: 1.0, b: 0.5, c: 0.5)` the command line reads and prints.

use serde::{Deserialize, Serialize};

use super::shape::{
    ConvexPolyhedron, Cuboid, Ellipsoid, Shape, ShapeError, Sphere, Spherocylinder, Superellipsoid,
};

use super::solids::Solid;

type V3 = nalgebra::Vector3<f64>;

/// The scene spelling of a shape (docs/CONVENTIONS.md), before validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeSpec {
    /// `Sphere(radius: r)`
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// `Ellipsoid(a: , b: , c: )`
    Ellipsoid {
        /// Semi-axis along body x.
        a: f64,
        /// Semi-axis along body y.
        b: f64,
        /// Semi-axis along body z.
        c: f64,
    },
    /// `Superellipsoid(a: , b: , c: , exponents: (n, m, p))`
    Superellipsoid {
        /// Semi-axis along body x.
        a: f64,
        /// Semi-axis along body y.
        b: f64,
        /// Semi-axis along body z.
        c: f64,
        /// Exponents (n, m, p), each ≥ 2.
        exponents: (f64, f64, f64),
    },
    /// `Cuboid(a: , b: , c: )`, half-lengths.
    Cuboid {
        /// Half-length along body x.
        a: f64,
        /// Half-length along body y.
        b: f64,
        /// Half-length along body z.
        c: f64,
    },
    /// `Spherocylinder(radius: , length: )`: a cylinder of `length` along
    /// body z capped by hemispheres of `radius`.
    Spherocylinder {
        /// Radius of the cylinder and the caps.
        radius: f64,
        /// Length of the cylinder (the axis segment between the caps'
        /// centres).
        length: f64,
    },
    /// `ConvexPolyhedron(vertices: [(x, y, z), ...])`: the convex hull of
    /// the points, which must hold the body origin; the body's centre is
    /// the hull's centroid.
    ConvexPolyhedron {
        /// The points (4 to 64) whose hull the body is.
        vertices: Vec<(f64, f64, f64)>,
    },
    /// `Spheropolyhedron(vertices: [(x, y, z), ...], radius: r)`: the
    /// convex hull of the points (as `ConvexPolyhedron`) swept by a ball
    /// of `radius`: every point within r of the hull (rounded cubes; the
    /// hull of two points swept so is `Spherocylinder`).
    Spheropolyhedron {
        /// The points (4 to 64) whose hull is the core.
        vertices: Vec<(f64, f64, f64)>,
        /// The radius of the sweeping ball (> 0).
        radius: f64,
    },
    /// `Tetrahedron(edge: )`: the regular tetrahedron, a polyhedron.
    Tetrahedron {
        /// Edge length.
        edge: f64,
    },
    /// `Cube(edge: )`: the cube as a polyhedron (`Cuboid` is the same body
    /// by the separating axes, faster).
    Cube {
        /// Edge length.
        edge: f64,
    },
    /// `Octahedron(edge: )`: the regular octahedron, a polyhedron.
    Octahedron {
        /// Edge length.
        edge: f64,
    },
    /// `Dodecahedron(edge: )`: the regular dodecahedron, a polyhedron.
    Dodecahedron {
        /// Edge length.
        edge: f64,
    },
    /// `Icosahedron(edge: )`: the regular icosahedron, a polyhedron.
    Icosahedron {
        /// Edge length.
        edge: f64,
    },
    /// `TruncatedOctahedron(edge: )`: the truncated octahedron, a
    /// polyhedron.
    TruncatedOctahedron {
        /// Edge length.
        edge: f64,
    },
}

impl ShapeSpec {
    /// The named solid and its edge, for the spellings of one.
    fn solid(&self) -> Option<(Solid, f64)> {
        Some(match *self {
            ShapeSpec::Tetrahedron { edge } => (Solid::Tetrahedron, edge),
            ShapeSpec::Cube { edge } => (Solid::Cube, edge),
            ShapeSpec::Octahedron { edge } => (Solid::Octahedron, edge),
            ShapeSpec::Dodecahedron { edge } => (Solid::Dodecahedron, edge),
            ShapeSpec::Icosahedron { edge } => (Solid::Icosahedron, edge),
            ShapeSpec::TruncatedOctahedron { edge } => (Solid::TruncatedOctahedron, edge),
            _ => return None,
        })
    }

    /// The spelling of a named solid.
    fn of_solid(solid: Solid, edge: f64) -> Self {
        match solid {
            Solid::Tetrahedron => ShapeSpec::Tetrahedron { edge },
            Solid::Cube => ShapeSpec::Cube { edge },
            Solid::Octahedron => ShapeSpec::Octahedron { edge },
            Solid::Dodecahedron => ShapeSpec::Dodecahedron { edge },
            Solid::Icosahedron => ShapeSpec::Icosahedron { edge },
            Solid::TruncatedOctahedron => ShapeSpec::TruncatedOctahedron { edge },
        }
    }
}

impl TryFrom<ShapeSpec> for Shape {
    type Error = ShapeError;
    fn try_from(spec: ShapeSpec) -> Result<Self, ShapeError> {
        if let Some((solid, edge)) = spec.solid() {
            return Ok(Shape::ConvexPolyhedron(ConvexPolyhedron::solid(
                solid, edge,
            )?));
        }
        Ok(match spec {
            ShapeSpec::Sphere { radius } => Shape::Sphere(Sphere::new(radius)?),
            ShapeSpec::Ellipsoid { a, b, c } => Shape::Ellipsoid(Ellipsoid::new(a, b, c)?),
            ShapeSpec::Superellipsoid { a, b, c, exponents } => {
                Shape::Superellipsoid(Superellipsoid::new(a, b, c, exponents)?)
            }
            ShapeSpec::Cuboid { a, b, c } => Shape::Cuboid(Cuboid::new(a, b, c)?),
            ShapeSpec::Spherocylinder { radius, length } => {
                Shape::Spherocylinder(Spherocylinder::new(radius, length)?)
            }
            ShapeSpec::ConvexPolyhedron { vertices } => {
                let points: Vec<V3> = vertices.iter().map(|&(x, y, z)| V3::new(x, y, z)).collect();
                Shape::ConvexPolyhedron(ConvexPolyhedron::new(&points)?)
            }
            ShapeSpec::Spheropolyhedron { vertices, radius } => {
                let radius = super::shape::positive("Spheropolyhedron", "radius", radius)?;
                let points: Vec<V3> = vertices.iter().map(|&(x, y, z)| V3::new(x, y, z)).collect();
                Shape::ConvexPolyhedron(ConvexPolyhedron::new(&points)?.rounded(radius))
            }
            ShapeSpec::Tetrahedron { .. }
            | ShapeSpec::Cube { .. }
            | ShapeSpec::Octahedron { .. }
            | ShapeSpec::Dodecahedron { .. }
            | ShapeSpec::Icosahedron { .. }
            | ShapeSpec::TruncatedOctahedron { .. } => unreachable!("named solids built above"),
        })
    }
}

impl From<Shape> for ShapeSpec {
    fn from(shape: Shape) -> Self {
        match shape {
            Shape::Sphere(s) => ShapeSpec::Sphere { radius: s.radius() },
            Shape::Ellipsoid(e) => {
                let [a, b, c] = e.semi_axes().into();
                ShapeSpec::Ellipsoid { a, b, c }
            }
            Shape::Superellipsoid(s) => {
                let [a, b, c] = s.semi_axes().into();
                let [n, m, p] = s.exponents().into();
                ShapeSpec::Superellipsoid {
                    a,
                    b,
                    c,
                    exponents: (n, m, p),
                }
            }
            Shape::Cuboid(q) => {
                let [a, b, c] = q.half_extents().into();
                ShapeSpec::Cuboid { a, b, c }
            }
            Shape::Spherocylinder(s) => ShapeSpec::Spherocylinder {
                radius: s.radius(),
                length: 2.0 * s.half_length(),
            },
            Shape::ConvexPolyhedron(p) if p.rounding() > 0.0 => ShapeSpec::Spheropolyhedron {
                vertices: (p.hull().given().iter())
                    .map(|v| {
                        let v = v * p.scale();
                        (v.x, v.y, v.z)
                    })
                    .collect(),
                radius: p.rounding(),
            },
            Shape::ConvexPolyhedron(p) => match p.hull().named().filter(|_| p.scale() == 1.0) {
                Some((solid, edge)) => ShapeSpec::of_solid(solid, edge),
                None => ShapeSpec::ConvexPolyhedron {
                    vertices: (p.hull().given().iter())
                        .map(|v| {
                            let v = v * p.scale();
                            (v.x, v.y, v.z)
                        })
                        .collect(),
                },
            },
        }
    }
}

/// A shape given on the command line or in a scene could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ShapeParseError {
    /// Not valid RON for a shape.
    #[error("cannot read shape {text:?}: {source}")]
    Syntax {
        /// The text given.
        text: String,
        /// What the RON parser said.
        source: ron::error::SpannedError,
    },
    /// Well-formed but invalid parameters.
    #[error("invalid shape {text:?}: {source}")]
    Invalid {
        /// The text given.
        text: String,
        /// What is wrong with it.
        source: ShapeError,
    },
}

impl std::str::FromStr for Shape {
    type Err = ShapeParseError;
    /// Reads the scene spelling, e.g. `Cuboid(a: 0.5, b: 1.0, c: 1.5)`.
    fn from_str(text: &str) -> Result<Self, ShapeParseError> {
        let spec: ShapeSpec = ron::from_str(text).map_err(|source| ShapeParseError::Syntax {
            text: text.to_owned(),
            source,
        })?;
        Shape::try_from(spec).map_err(|source| ShapeParseError::Invalid {
            text: text.to_owned(),
            source,
        })
    }
}

impl std::fmt::Display for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = ron::to_string(&ShapeSpec::from(*self)).map_err(|_| std::fmt::Error)?;
        f.write_str(&text)
    }
}

impl Serialize for Shape {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        ShapeSpec::from(*self).serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for Shape {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        Shape::try_from(ShapeSpec::deserialize(deserializer)?).map_err(serde::de::Error::custom)
    }
}
