//! The geometry and overlap layer: shapes, their implicit and support
//! descriptions, bounding volumes, and one overlap test and one signed
//! distance for every pair of shapes. Both drivers stand on this layer; it
//! depends on nothing above it.

pub mod capsule;
pub mod contact;
pub mod gjk;
pub mod implicit;
pub mod newton;
pub mod obb;
pub mod ocsi;
pub mod pair;
pub mod polyhedron;
pub mod roots;
pub mod shape;
pub mod solids;
pub mod spec;
pub mod symmetry;

pub use contact::{Contact, Failure, Method, Relative, Status, WarmStart};
pub use newton::{NewtonOptions, NewtonSystem, SteepestDescent};
pub use obb::Obb;
pub use pair::{DistanceOptions, Placed, distance, overlap, placed_overlap};
pub use polyhedron::{Polyhedron, PolyhedronError};
pub use shape::{
    ConvexPolyhedron, Cuboid, Ellipsoid, Shape, ShapeError, Sphere, Spherocylinder, Superellipsoid,
};
pub use spec::{ShapeParseError, ShapeSpec};
