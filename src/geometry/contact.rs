//! What a contact search reports: B's placement relative to A, the contact
//! found (distance, points, normal), how it was found and whether it can be
//! trusted. Every distance kernel and the drivers above share these types.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

type V3 = Vector3<f64>;

/// B's placement in A's body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relative {
    /// B's centre in A's body frame.
    pub translation: V3,
    /// B's body axes (columns) in A's body frame.
    pub rotation: Matrix3<f64>,
}

impl Relative {
    /// From the lab-frame separation `r_ab = r_b − r_a` and orientations.
    pub fn new(r_ab: &V3, q_a: &UnitQuaternion<f64>, q_b: &UnitQuaternion<f64>) -> Self {
        Self {
            translation: q_a.inverse_transform_vector(r_ab),
            rotation: (q_a.inverse() * q_b).to_rotation_matrix().into_inner(),
        }
    }

    /// A's placement in B's frame (the same pair seen from B).
    pub fn inverse(&self) -> Self {
        let rt = self.rotation.transpose();
        Self {
            translation: -(rt * self.translation),
            rotation: rt,
        }
    }

    /// A point given in B's body frame, in A's frame.
    #[inline]
    pub fn b_to_a(&self, x: &V3) -> V3 {
        self.rotation * x + self.translation
    }
}

/// Why an iterative solve failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// The Newton system was singular.
    SingularJacobian,
    /// A step was not finite.
    NonFinite,
    /// The solver stopped at a point that does not satisfy eqs. (9).
    NotASolution,
    /// Eqs. (9) hold but at an extremum that is not the distance.
    SpuriousSolution,
}

/// How a distance computation ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Exact (closed form) or converged to the tolerance.
    Converged {
        /// Iterations used (0 for closed forms).
        iterations: u32,
    },
    /// Stopped at the iteration cap; the result is the last iterate.
    IterationCap {
        /// Iterations used.
        iterations: u32,
    },
    /// The solver failed; distance and points are NaN.
    Failed {
        /// What went wrong.
        why: Failure,
        /// Iterations used.
        iterations: u32,
    },
    /// The bodies overlap by more than the method defines a negative distance
    /// for (De Michele Fig. 2); `distance` is negative, an estimate.
    DeepOverlap,
}

/// Which method produced a result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Closed form (sphere–sphere).
    Analytic,
    /// OCSI distance (Tonti & Patti eq. 2).
    Ocsi,
    /// De Michele's Newton–Raphson.
    Newton,
    /// GJK.
    Gjk,
    /// Expanding polytope after GJK (penetration depth).
    Epa,
    /// 15-axis separating-axis test (cuboid penetration depth, and the
    /// distance where the features of the largest separation face each
    /// other).
    SeparatingAxes,
    /// Largest gap between support planes over a cuboid's features (exact
    /// cuboid–smooth distance near contact).
    SupportGap,
    /// Closest features of two polytopes by enumeration (where GJK stops
    /// short).
    Features,
}

/// Signed distance of two bodies and where it is attained, in A's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Signed distance: > 0 apart, < 0 overlapping.
    pub distance: f64,
    /// Point of A's surface.
    pub point_a: V3,
    /// Point of B's surface.
    pub point_b: V3,
    /// Unit normal at the contact, from A towards B.
    pub normal: V3,
    /// How the computation ended.
    pub status: Status,
    /// Which method produced it.
    pub method: Method,
    /// A start for the next Newton solve of the same pair.
    pub warm_start: Option<WarmStart>,
}

impl Contact {
    /// Whether the result can be used: converged or closed form.
    pub fn is_converged(&self) -> bool {
        matches!(self.status, Status::Converged { .. })
    }

    /// The solver iterations it took (0 where none were counted).
    pub fn iterations(&self) -> u32 {
        match self.status {
            Status::Converged { iterations }
            | Status::IterationCap { iterations }
            | Status::Failed { iterations, .. } => iterations,
            Status::DeepOverlap => 0,
        }
    }

    /// This contact, computed with the bodies in the order (B, A) and frame
    /// of B, expressed for the order (A, B) in A's frame (`rel` is B in A).
    pub(crate) fn swapped(self, rel: &Relative) -> Contact {
        Contact {
            distance: self.distance,
            point_a: rel.b_to_a(&self.point_b),
            point_b: rel.b_to_a(&self.point_a),
            normal: -(rel.rotation * self.normal),
            status: self.status,
            method: self.method,
            warm_start: self.warm_start.map(|w| WarmStart {
                point_a: w.point_b,
                point_b: w.point_a,
                alpha: 1.0 / w.alpha,
            }),
        }
    }
}

/// A previous solution, kept in each body's own frame so that it remains a
/// good start after the bodies have moved (EDMD) or been perturbed (MC).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarmStart {
    /// Contact point on A, A's body frame.
    pub point_a: V3,
    /// Contact point on B, B's body frame.
    pub point_b: V3,
    /// Lagrange multiplier α of eq. (9a).
    pub alpha: f64,
}
