//! The ideal orientational Einstein crystal: bodies held near reference
//! orientations by βU = λ_o φ(R), φ the misalignment of
//! [`Symmetry::misalignment`]; its partition function per body and
//! direct samples of it.
//!
//! Orientations are measured with the volume of SO(3) set to 1, so that
//! an ideal gas's orientational part is zero; a body's symmetries are
//! counted as distinct orientations in the fluid and the crystal alike.

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Gamma, StandardNormal};

use crate::analysis::quadrature::gauss_legendre_on;
use crate::geometry::symmetry::Symmetry;

/// λ_o times the misalignment at a well's edge must reach this for the
/// wells of a finite group to be counted apart: beyond the edge the
/// weight is below e⁻⁴⁰.
pub const WELL_DEPTH: f64 = 40.0;

/// q(λ_o) = ∫_SO(3) e^{−λ_o φ(R)} dR (volume 1), or None where the wells of
/// a finite group are too shallow to be counted apart (λ_o × the well's
/// edge below [`WELL_DEPTH`]).
///
/// - body of revolution: q = ∫₀¹ e^{−λ_o(1 − x²)} dx, x = a·a₀ (the
///   spin about the axis is free);
/// - finite group G: q = |G| (1/π) ∫₀^π e^{−λ_o(1 − cos θ)} (1 − cos θ) dθ,
///   the rotation angle θ having density (1 − cos θ)/π, integrated in
///   v = √(1 − cos θ) over the well, where the rest is under e⁻⁴⁰.
pub fn orientational_partition(symmetry: &Symmetry, spring: f64) -> Option<f64> {
    let panels = |a: f64, b: f64, f: &dyn Fn(f64) -> f64| -> f64 {
        let count = 16;
        let width = (b - a) / count as f64;
        (0..count)
            .map(|k| {
                let lo = a + width * k as f64;
                gauss_legendre_on(24, lo, lo + width)
                    .iter()
                    .map(|&(x, w)| w * f(x))
                    .sum::<f64>()
            })
            .sum()
    };
    match symmetry {
        Symmetry::Sphere => Some(1.0),
        Symmetry::Revolution { .. } => {
            // s = 1 − x: e^{−λ s (2 − s)} ≤ e^{−λ s} on [0, 1].
            let end = (WELL_DEPTH / spring.max(1e-300)).min(1.0);
            Some(panels(0.0, end, &|s| (-spring * s * (2.0 - s)).exp()))
        }
        Symmetry::Finite(group) => {
            if spring * symmetry.well_edge() < WELL_DEPTH {
                return None;
            }
            let end = (WELL_DEPTH / spring).sqrt();
            // u = v²: du = 2v dv, the density e^{−λu} √(u/(2 − u)).
            let well = panels(0.0, end, &|v| {
                2.0 * v * v * (-spring * v * v).exp() / (2.0 - v * v).sqrt()
            });
            Some(group.len() as f64 * well / std::f64::consts::PI)
        }
    }
}

/// A uniformly random unit vector.
fn random_axis<R: Rng>(rng: &mut R) -> Unit<Vector3<f64>> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
        if let Some(u) = Unit::try_new(v, 1e-12) {
            return u;
        }
    }
}

/// An orientation drawn from the ideal orientational Einstein crystal
/// about `reference` (body → lab) with spring `spring` (one well; its
/// images under the symmetry are the same body).
pub fn sample_orientation<R: Rng>(
    symmetry: &Symmetry,
    spring: f64,
    reference: &Matrix3<f64>,
    rng: &mut R,
) -> Matrix3<f64> {
    match symmetry {
        Symmetry::Sphere => *reference,
        Symmetry::Revolution { axis } => {
            // s = 1 − a·a₀ from e^{−λ s(2 − s)} on [0, 1]: proposed from
            // e^{−λ s} (inverse CDF), kept with e^{−λ s(1 − s)} ≤ 1.
            let s = loop {
                let u: f64 = rng.r#gen();
                let s = -(1.0 - u * (1.0 - (-spring).exp())).ln() / spring;
                if rng.r#gen::<f64>() < (-spring * s * (1.0 - s)).exp() {
                    break s;
                }
            };
            let a0 = reference.column(*axis).into_owned();
            // Turn a₀ by θ = acos(1 − s) about an axis normal to it.
            let normal = loop {
                let n = random_axis(rng).into_inner();
                let n = n - a0 * a0.dot(&n);
                if let Some(n) = Unit::try_new(n, 1e-9) {
                    break n;
                }
            };
            let turn = Rotation3::from_axis_angle(&normal, (1.0 - s).clamp(-1.0, 1.0).acos());
            turn.matrix() * reference
        }
        Symmetry::Finite(_) => {
            // u = 1 − cos θ from e^{−λu} √(u/(2 − u)) on the well (u ≤ 1):
            // proposed from Gamma(3/2, 1/λ), kept with 1/√(2 − u) ≤ 1.
            let gamma = Gamma::new(1.5, 1.0 / spring).expect("a positive spring");
            let u = loop {
                let u: f64 = gamma.sample(rng);
                if u <= 1.0 && rng.r#gen::<f64>() < 1.0 / (2.0 - u).sqrt() {
                    break u;
                }
            };
            let turn = Rotation3::from_axis_angle(&random_axis(rng), (1.0 - u).acos());
            turn.matrix() * reference
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// −d ln q/dλ_o is ⟨φ⟩ of the ideal crystal: the quadrature's
    /// derivative (central differences) against the mean misalignment of
    /// direct samples, within four errors, for a spheroid and a cube; the
    /// large-λ limits f/(2λ) (f = 2, 3 bound freedoms) come out.
    #[test]
    fn the_orientational_partition_function_gives_the_samples_mean() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let reference = Rotation3::from_euler_angles(0.4, 0.2, -1.3).into_inner();
        for (text, spring) in [
            ("Ellipsoid(a: 0.5, b: 0.5, c: 1.0)", 30.0),
            ("Ellipsoid(a: 0.5, b: 0.5, c: 1.0)", 3.0),
            ("Cuboid(a: 0.5, b: 0.5, c: 0.5)", 400.0),
            ("Cuboid(a: 0.3, b: 0.5, c: 0.8)", 60.0),
        ] {
            let symmetry = Symmetry::of(&text.parse().unwrap());
            let q = |l: f64| orientational_partition(&symmetry, l).unwrap();
            let h = 1e-4 * spring;
            let derivative = -(q(spring + h).ln() - q(spring - h).ln()) / (2.0 * h);
            let n = 200_000;
            let phis: Vec<f64> = (0..n)
                .map(|_| {
                    let r = sample_orientation(&symmetry, spring, &reference, &mut rng);
                    symmetry.misalignment(&r, &reference)
                })
                .collect();
            let mean = phis.iter().sum::<f64>() / n as f64;
            let sd = (phis.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
            let error = sd / (n as f64).sqrt();
            assert!(
                (mean - derivative).abs() < 4.0 * error,
                "{text} at {spring}: samples {mean} ± {error}, quadrature {derivative}"
            );
            if spring >= 30.0 {
                let limit = symmetry.bound_freedoms() as f64 / (2.0 * spring);
                assert!(
                    (derivative / limit - 1.0).abs() < 0.1,
                    "{text}: {derivative} vs {limit}"
                );
            }
        }
        let cube = Symmetry::of(&"Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap());
        assert_eq!(orientational_partition(&cube, 10.0), None);
    }
}
