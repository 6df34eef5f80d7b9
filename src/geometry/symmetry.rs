//! The proper rotations that map a body onto itself, read from its
//! support function: a rotation g is a symmetry when h(g d) = h(d) for
//! the support value h(d) = d · s(d) along many directions d.

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

use super::Shape;

/// How a body's orientation can be told apart from its images.
#[derive(Debug, Clone, PartialEq)]
pub enum Symmetry {
    /// A sphere: every rotation maps it onto itself.
    Sphere,
    /// A body of revolution about body axis `axis` (0, 1, 2), head and
    /// tail alike (every shape here is centrosymmetric).
    Revolution {
        /// The axis.
        axis: usize,
    },
    /// A finite group of proper rotations (body frame), the identity
    /// first: 4 for a body with three different axes, 8 for a square
    /// cross-section, 24 for a cube or superball.
    Finite(Vec<Matrix3<f64>>),
}

/// Directions the support values are compared along: spread over the
/// sphere, none on a symmetry axis or plane of the candidates.
fn probe_directions() -> Vec<Vector3<f64>> {
    // A Fibonacci lattice on the sphere, tilted off the axes.
    let count = 40;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64 + 0.3;
            Vector3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Whether `rotation` (body frame) maps `shape` onto itself.
fn maps_onto_itself(shape: &Shape, rotation: &Matrix3<f64>) -> bool {
    let h = |d: &Vector3<f64>| d.dot(&shape.support(d));
    probe_directions().iter().all(|d| {
        let (a, b) = (h(d), h(&(rotation * d)));
        (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
    })
}

/// The 24 proper rotations of the cube: signed permutation matrices of
/// determinant +1, the identity first.
fn cube_rotations() -> Vec<Matrix3<f64>> {
    let permutations = [
        [0, 1, 2],
        [1, 2, 0],
        [2, 0, 1],
        [0, 2, 1],
        [2, 1, 0],
        [1, 0, 2],
    ];
    let mut out = Vec::with_capacity(24);
    for p in permutations {
        for signs in 0..8u8 {
            let s = |k: usize| if signs >> k & 1 == 1 { -1.0 } else { 1.0 };
            let m = Matrix3::from_fn(|i, j| if p[i] == j { s(i) } else { 0.0 });
            if m.determinant() > 0.0 {
                out.push(m);
            }
        }
    }
    out
}

impl Symmetry {
    /// The symmetry of `shape`: a sphere; a body of revolution if a turn
    /// by one radian about a body axis maps it onto itself; else the
    /// rotations of the cube's group that do (every shape here has at
    /// least the three half-turns about its axes).
    pub fn of(shape: &Shape) -> Symmetry {
        if shape.is_sphere() {
            return Symmetry::Sphere;
        }
        for axis in 0..3 {
            let turn =
                Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::ith(axis, 1.0)), 1.0);
            if maps_onto_itself(shape, turn.matrix()) {
                return Symmetry::Revolution { axis };
            }
        }
        Symmetry::Finite(
            cube_rotations()
                .into_iter()
                .filter(|g| maps_onto_itself(shape, g))
                .collect(),
        )
    }

    /// The orientational degrees of freedom a spring on this symmetry
    /// binds: 0, 2 or 3.
    pub fn bound_freedoms(&self) -> usize {
        match self {
            Symmetry::Sphere => 0,
            Symmetry::Revolution { .. } => 2,
            Symmetry::Finite(_) => 3,
        }
    }

    /// φ(R) ≥ 0 of a body turned by `rotation` from its reference
    /// `reference` (both body → lab), zero where a symmetry maps one
    /// onto the other: 1 − (a·a₀)² for a body of revolution (a its axis),
    /// min over g of 1 − cos θ, θ the angle of the rotation between R and
    /// R₀ g, for a finite group.
    pub fn misalignment(&self, rotation: &Matrix3<f64>, reference: &Matrix3<f64>) -> f64 {
        match self {
            Symmetry::Sphere => 0.0,
            Symmetry::Revolution { axis } => {
                let c = rotation.column(*axis).dot(&reference.column(*axis));
                1.0 - c * c
            }
            Symmetry::Finite(group) => {
                // tr(Rᵀ R₀ g) = 1 + 2 cos θ.
                let m = rotation.transpose() * reference;
                let best = group
                    .iter()
                    .map(|g| (m * g).trace())
                    .fold(f64::NEG_INFINITY, f64::max);
                0.5 * (3.0 - best)
            }
        }
    }

    /// 1 − cos of half the smallest angle between two elements of a finite
    /// group: a well's edge, beyond which another well is nearer (2 for a
    /// body of revolution, whose two wells meet at 90°, 1 − cos 90° = 1,
    /// counted in its own variable).
    pub fn well_edge(&self) -> f64 {
        match self {
            Symmetry::Sphere => f64::INFINITY,
            Symmetry::Revolution { .. } => 1.0,
            Symmetry::Finite(group) => {
                let smallest = (group.iter().skip(1))
                    .map(|g| ((g.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos())
                    .fold(std::f64::consts::PI, f64::min);
                1.0 - (0.5 * smallest).cos()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group_size(text: &str) -> usize {
        match Symmetry::of(&text.parse().unwrap()) {
            Symmetry::Finite(g) => g.len(),
            other => panic!("{text}: {other:?}"),
        }
    }

    /// Cube 24, square prism 8, brick 4, superball 24, triaxial ellipsoid
    /// 4; a spheroid is a body of revolution about its odd axis; a sphere
    /// is a sphere.
    #[test]
    fn symmetries_of_the_shapes() {
        assert_eq!(group_size("Cuboid(a: 0.5, b: 0.5, c: 0.5)"), 24);
        assert_eq!(group_size("Cuboid(a: 0.5, b: 0.5, c: 0.8)"), 8);
        assert_eq!(group_size("Cuboid(a: 0.3, b: 0.5, c: 0.8)"), 4);
        assert_eq!(
            group_size("Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (6.0, 6.0, 6.0))"),
            24
        );
        assert_eq!(group_size("Ellipsoid(a: 0.3, b: 0.5, c: 0.8)"), 4);
        assert_eq!(
            Symmetry::of(&"Ellipsoid(a: 0.5, b: 0.5, c: 1.0)".parse().unwrap()),
            Symmetry::Revolution { axis: 2 }
        );
        assert_eq!(
            Symmetry::of(&"Ellipsoid(a: 1.0, b: 0.5, c: 0.5)".parse().unwrap()),
            Symmetry::Revolution { axis: 0 }
        );
        assert_eq!(
            Symmetry::of(&"Sphere(radius: 0.5)".parse().unwrap()),
            Symmetry::Sphere
        );
        let cube = Symmetry::of(&"Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap());
        // Nearest distinct cube rotations are quarter turns: the edge is
        // at 45°.
        assert!((cube.well_edge() - (1.0 - (std::f64::consts::PI / 4.0).cos())).abs() < 1e-12);
    }

    /// φ is zero at the reference and at its images under the group, and
    /// grows as 1 − cos θ (θ²/2 for small θ) off them.
    #[test]
    fn misalignment_vanishes_on_the_images_only() {
        let cube = Symmetry::of(&"Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap());
        let reference = Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
        let Symmetry::Finite(group) = &cube else {
            unreachable!()
        };
        for g in group {
            assert!(cube.misalignment(&(reference * g), &reference).abs() < 1e-12);
        }
        let tilt = Rotation3::from_axis_angle(&Vector3::y_axis(), 0.2).into_inner();
        let phi = cube.misalignment(&(reference * tilt), &reference);
        assert!((phi - (1.0 - 0.2f64.cos())).abs() < 1e-12);
        let rod = Symmetry::Revolution { axis: 2 };
        let flipped = reference
            * Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI).into_inner();
        assert!(rod.misalignment(&flipped, &reference).abs() < 1e-12);
        let spun = reference * Rotation3::from_axis_angle(&Vector3::z_axis(), 0.9).into_inner();
        assert!(rod.misalignment(&spun, &reference).abs() < 1e-12);
        let tilted = reference * tilt;
        assert!((rod.misalignment(&tilted, &reference) - 0.2f64.sin().powi(2)).abs() < 1e-12);
    }
}
