//! Orientational order: the nematic order parameter S₂ (largest eigenvalue
//! of the Q tensor) and the cubatic alignment and order for cubes.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// S₂ of unit vectors uᵢ: the largest eigenvalue of
/// Q = ⟨(3 uᵢuᵢᵀ − I)/2⟩. 1 when all are parallel, ≈ 0 (O(1/√N)) when
/// isotropic. `None` for no vectors.
pub fn nematic_order(axes: impl IntoIterator<Item = Vector3<f64>>) -> Option<f64> {
    nematic_director(axes).map(|(order, _)| order)
}

/// S₂ of unit vectors uᵢ with its director, the eigenvector of Q of the
/// largest eigenvalue. `None` for no vectors.
pub fn nematic_director(
    axes: impl IntoIterator<Item = Vector3<f64>>,
) -> Option<(f64, Vector3<f64>)> {
    let mut q = Matrix3::zeros();
    let mut n = 0usize;
    for u in axes {
        q += u * u.transpose() * 1.5 - Matrix3::identity() * 0.5;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let eigen = SymmetricEigen::new(q / n as f64);
    let k = eigen.eigenvalues.imax();
    Some((
        eigen.eigenvalues[k],
        eigen.eigenvectors.column(k).into_owned(),
    ))
}

/// The body axis whose nematic order is meant for a shape: the one whose
/// semi-axis (half-length) differs most from the mean of the other two (the
/// symmetry axis of a spheroid, prolate or oblate). `None` for shapes
/// without one (spheres, cubes, any body with three equal extents).
pub fn molecular_axis(shape: &crate::geometry::Shape) -> Option<Vector3<f64>> {
    let h = shape.obb_half_extents();
    let (k, spread) = (0..3)
        .map(|k| {
            let others = 0.5 * (h[(k + 1) % 3] + h[(k + 2) % 3]);
            (k, (h[k] - others).abs() / others)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .expect("three axes");
    (spread > 1e-9).then(|| Vector3::ith(k, 1.0))
}

/// P₂(x) = (3x² − 1)/2, the second Legendre polynomial: ⟨P₂(u(0)·u(t))⟩
/// is the orientational correlation C₂(t).
pub fn legendre_p2(x: f64) -> f64 {
    1.5 * x * x - 0.5
}

/// The cubic alignment of two orientations (rotation matrices): with
/// R = R_aᵀ R_b, a = (1/3) Σₖₗ R_kl⁴ is 1 when the cubes' axes coincide (up
/// to cubic symmetry) and 3/5 on average for random relative orientations;
/// returned rescaled to (a − 3/5)/(2/5): 1 aligned, 0 random on average.
pub fn cubic_alignment(ra: &Matrix3<f64>, rb: &Matrix3<f64>) -> f64 {
    let r = ra.tr_mul(rb);
    let a: f64 = r.iter().map(|x| x.powi(4)).sum::<f64>() / 3.0;
    (a - 0.6) / 0.4
}

/// Mean [`cubic_alignment`] over pairs whose centres are closer than
/// `cutoff` (periodic box): a local cubatic order parameter, 1 for a simple
/// cubic crystal of aligned cubes, near 0 for an isotropic fluid. `None`
/// when no pair is that close. O(N²): an analysis, not a hot path.
pub fn local_cubic_order(
    box_: &crate::space::PeriodicBox,
    positions: &[Vector3<f64>],
    rotations: &[Matrix3<f64>],
    cutoff: f64,
) -> Option<f64> {
    let (mut sum, mut pairs) = (0.0, 0usize);
    for i in 0..positions.len() {
        for j in i + 1..positions.len() {
            if box_.minimum_image(&(positions[j] - positions[i])).norm() < cutoff {
                sum += cubic_alignment(&rotations[i], &rotations[j]);
                pairs += 1;
            }
        }
    }
    (pairs > 0).then(|| sum / pairs as f64)
}

/// The global cubatic order of bodies with rotations `rotations`: the
/// mean [`cubic_alignment`] over all ordered pairs, the body with itself
/// included, in O(N) through the fourth-rank tensor T = Σᵢ Σₖ uᵢₖ⊗⁴ of the
/// body axes uᵢₖ (Σ over pairs of Σₖₗ (uᵢₖ·uⱼₗ)⁴ is |T|²). 1 when every
/// body's axes coincide up to cubic symmetry, 1/N on average for random
/// orientations (the self pairs); no director to search for. `None` for
/// no bodies.
pub fn cubatic_order(rotations: impl IntoIterator<Item = Matrix3<f64>>) -> Option<f64> {
    let mut t = [0.0f64; 81];
    let mut n = 0usize;
    for r in rotations {
        for k in 0..3 {
            let u = r.column(k);
            for a in 0..3 {
                for b in 0..3 {
                    let ab = u[a] * u[b];
                    for c in 0..3 {
                        let abc = ab * u[c];
                        for d in 0..3 {
                            t[((a * 3 + b) * 3 + c) * 3 + d] += abc * u[d];
                        }
                    }
                }
            }
        }
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let squared: f64 = t.iter().map(|x| x * x).sum();
    let mean = squared / (3.0 * (n * n) as f64);
    Some((mean - 0.6) / 0.4)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cubatic order is the pair mean of the cubic alignment (brute
    /// force), 1 for bodies turned by symmetries of the cube only, and
    /// near 1/N for random orientations.
    #[test]
    fn cubatic_order_is_the_mean_alignment_of_all_pairs() {
        let mut u = crate::test_support::uniform(9);
        let random = |u: &mut dyn FnMut() -> f64| {
            *nalgebra::Rotation3::from_scaled_axis(
                Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 7.0,
            )
            .matrix()
        };
        let bodies: Vec<Matrix3<f64>> = (0..50).map(|_| random(&mut u)).collect();
        let brute: f64 = bodies
            .iter()
            .flat_map(|a| bodies.iter().map(move |b| cubic_alignment(a, b)))
            .sum::<f64>()
            / (50.0 * 50.0);
        let fast = cubatic_order(bodies.iter().copied()).unwrap();
        assert!((fast - brute).abs() < 1e-12, "{fast} {brute}");
        // Quarter turns and flips of one orientation: perfectly cubatic.
        let base = random(&mut u);
        let quarter = |axis: Vector3<f64>, k: u32| {
            *nalgebra::Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                k as f64 * std::f64::consts::FRAC_PI_2,
            )
            .matrix()
        };
        let symmetric: Vec<Matrix3<f64>> = (0..24)
            .map(|k| base * quarter(Vector3::x(), k % 4) * quarter(Vector3::z(), (k / 4) % 4))
            .collect();
        assert!((cubatic_order(symmetric).unwrap() - 1.0).abs() < 1e-12);
        let n = 4000;
        let isotropic = cubatic_order((0..n).map(|_| {
            // Uniform rotations from normalised Gaussian-free quaternions:
            // four uniforms in the unit ball, normalised.
            loop {
                let q = nalgebra::Vector4::new(u() - 0.5, u() - 0.5, u() - 0.5, u() - 0.5) * 2.0;
                if q.norm() <= 1.0 && q.norm() > 1e-3 {
                    let q =
                        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(q));
                    break *q.to_rotation_matrix().matrix();
                }
            }
        }))
        .unwrap();
        assert!(isotropic.abs() < 5.0 / n as f64, "{isotropic}");
        assert_eq!(cubatic_order(Vec::new()), None);
    }

    #[test]
    fn molecular_axis_is_the_odd_one_out() {
        let axis = |t: &str| molecular_axis(&t.parse().unwrap());
        assert_eq!(
            axis("Ellipsoid(a: 0.5, b: 2.0, c: 0.5)"),
            Some(Vector3::y())
        );
        assert_eq!(
            axis("Ellipsoid(a: 1.0, b: 1.0, c: 0.3)"),
            Some(Vector3::z())
        );
        assert_eq!(axis("Sphere(radius: 1.0)"), None);
        assert_eq!(axis("Cuboid(a: 1.0, b: 1.0, c: 1.0)"), None);
    }
    use nalgebra::{Rotation3, Unit};

    #[test]
    fn nematic_order_limits() {
        let z = Vector3::z();
        assert!((nematic_order(vec![z; 10]).unwrap() - 1.0).abs() < 1e-12);
        // Three orthogonal axes in equal numbers: Q = 0.
        let s = nematic_order(vec![Vector3::x(), Vector3::y(), Vector3::z()]).unwrap();
        assert!(s.abs() < 1e-12, "{s}");
        // Antiparallel is parallel for a nematic.
        assert!((nematic_order(vec![z, -z]).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(nematic_order(Vec::new()), None);
    }

    #[test]
    fn cubic_alignment_limits() {
        let id = Matrix3::identity();
        assert!((cubic_alignment(&id, &id) - 1.0).abs() < 1e-12);
        // A quarter turn is a symmetry of the cube.
        let quarter =
            *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2).matrix();
        assert!((cubic_alignment(&id, &quarter) - 1.0).abs() < 1e-12);
        // Averaged over random rotations: 0.
        let mut u = crate::test_support::uniform(4);
        let mut sum = 0.0;
        let n = 20000;
        for _ in 0..n {
            let axis = Unit::new_normalize(Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5));
            // Uniform rotation: angle density ∝ (1 − cos θ).
            let angle = loop {
                let t = std::f64::consts::PI * u();
                if u() * 2.0 < 1.0 - t.cos() {
                    break t;
                }
            };
            sum += cubic_alignment(&id, Rotation3::from_axis_angle(&axis, angle).matrix());
        }
        assert!((sum / n as f64).abs() < 0.02, "{}", sum / n as f64);
    }
}
