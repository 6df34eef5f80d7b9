//! The densest known lattice packing of each shape, bodies aligned with
//! the lattice frame: fcc for spheres, its affine image for ellipsoids,
//! stacked boxes for cuboids, and Jiao, Stillinger and Torquato's C₀ and
//! C₁ lattices for superballs (PRE 79, 041309 (2009)), stretched along the
//! semi-axes for superellipsoids of one exponent.

use nalgebra::{Matrix3, Vector3};

use super::crystal::{CrystalError, UnitCell};
use crate::geometry::Shape;
use crate::geometry::roots::narrow_sign_change;

type V3 = Vector3<f64>;

impl UnitCell {
    /// The densest lattice packing known for `shape`, bodies aligned: fcc
    /// for spheres (π/√18, Gauss); for ellipsoids the fcc stretched along
    /// the semi-axes, an affine image with the same packing fraction (the
    /// densest lattice packing of ellipsoids, as of spheres); for cuboids
    /// the stacking of aligned boxes that fills space; for superellipsoids
    /// with one exponent 2p along all three axes, the superball lattice of
    /// [`superball_lattice`] stretched along the semi-axes. Superellipsoids
    /// whose exponents differ have no known densest lattice.
    ///
    /// ```
    /// use hardbody::geometry::Shape;
    /// use hardbody::state::Species;
    /// use hardbody::state::crystal::{CrystalSpec, UnitCell};
    ///
    /// let shape: Shape = "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4, 4, 4))"
    ///     .parse()
    ///     .unwrap();
    /// let species = [Species { name: "b".into(), shape, rotation: true }];
    /// let spec = CrystalSpec {
    ///     cell: UnitCell::densest(&shape)?,
    ///     cells: [5, 5, 5],
    ///     packing_fraction: 0.8,
    /// };
    /// // Jiao, Stillinger and Torquato's C1 lattice at p = 2.
    /// let limit = spec.densest_packing_fraction(&species, &[125])?;
    /// assert!((limit - 0.8698892).abs() < 1e-6);
    /// # Ok::<(), hardbody::state::crystal::CrystalError>(())
    /// ```
    pub fn densest(shape: &Shape) -> Result<Self, CrystalError> {
        let stretched = |cell: Self, axes: V3| Self {
            vectors: Matrix3::from_diagonal(&axes) * cell.vectors,
            ..cell
        };
        match shape {
            Shape::Sphere(_) => Ok(Self::fcc()),
            Shape::Ellipsoid(e) => Ok(stretched(Self::fcc(), e.semi_axes())),
            Shape::Cuboid(c) => Ok(stretched(Self::simple_cubic(), c.half_extents())),
            Shape::Spherocylinder(_) => Err(CrystalError::NoDensest(format!(
                "{shape}: the densest packings of spherocylinders are not lattices this tool builds yet; give the lattice with Custom"
            ))),
            Shape::ConvexPolyhedron(_) => Err(CrystalError::NoDensest(format!(
                "{shape}: the densest lattice packings of polyhedra are not built by this tool yet; give the lattice with Custom"
            ))),
            Shape::Superellipsoid(s) => {
                let n = s.exponents();
                if n.x != n.y || n.y != n.z {
                    return Err(CrystalError::NoDensest(format!(
                        "{shape}, whose exponents differ (the densest lattices known are those of one exponent, the superballs)"
                    )));
                }
                let primitive = Self::aligned(superball_lattice(n.x / 2.0), &[[0.0; 3]]);
                Ok(stretched(primitive, s.semi_axes()))
            }
        }
    }
}

/// The densest known lattice of the superball |x|²ᵖ + |y|²ᵖ + |z|²ᵖ ≤ 1,
/// p ≥ 1, as columns: the denser of Jiao et al.'s C₀ and C₁ lattices
/// (C₀ up to p ≈ 1.1509, C₁ above). Each body touches 12 neighbours;
/// both are fcc at p = 1 and C₁ becomes the simple cubic as p → ∞. The
/// vectors are in units where touching bodies' centres are 2 apart in the
/// superball's own norm, ‖v‖₂ₚ = 2 (the difference body of a centrally
/// symmetric body is the body doubled).
pub fn superball_lattice(p: f64) -> Matrix3<f64> {
    let (c0, c1) = (superball_c0(p), superball_c1(p));
    if c0.determinant() <= c1.determinant() {
        c0
    } else {
        c1
    }
}

/// The root of the decreasing `g` on (0, hi), where g(0) > 0 > g(hi).
fn root(g: impl Fn(f64) -> f64, hi: f64) -> f64 {
    let (lo, _, _, _, _) = narrow_sign_change(&g, (0.0, g(0.0)), (hi, g(hi)), 1e-15, 400);
    lo
}

/// C₀: one contact along a cube axis, e₃ = 2ẑ, and e₁ = 2(β, −α, ½),
/// e₂ = 2(−α, β, ½) with e₁, e₂, e₁ − e₃, e₂ − e₃ and e₁ + e₂ − e₃ =
/// 2(β − α)(1, 1, 0) all touching: β − α = 2^(−1/2p) and
/// α²ᵖ + β²ᵖ = 1 − 2^(−2p).
pub fn superball_c0(p: f64) -> Matrix3<f64> {
    let q = 2.0 * p;
    let shift = 2f64.powf(-1.0 / q);
    let alpha = root(
        |a: f64| 1.0 - 2f64.powf(-q) - a.powf(q) - (a + shift).powf(q),
        1.0 - shift,
    );
    let beta = alpha + shift;
    2.0 * Matrix3::new(beta, -alpha, 0.0, -alpha, beta, 0.0, 0.5, 0.5, 1.0)
}

/// C₁: e₁ = 2τ(1, 0, 1), e₂ = 2τ(0, 1, 1) touching along face diagonals
/// (τ = 2^(−1/2p)), and e₃ = 2(−σ, −σ, σ + τ) with e₃, e₁ − e₃ and
/// e₂ − e₃ touching: 2σ²ᵖ + (σ + τ)²ᵖ = 1; e₁ − e₂ touches as well.
pub fn superball_c1(p: f64) -> Matrix3<f64> {
    let q = 2.0 * p;
    let tau = 2f64.powf(-1.0 / q);
    let sigma = root(
        |s: f64| 1.0 - 2.0 * s.powf(q) - (s + tau).powf(q),
        1.0 - tau,
    );
    2.0 * Matrix3::new(tau, 0.0, -sigma, 0.0, tau, -sigma, tau, tau, sigma + tau)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::Species;
    use crate::state::crystal::{CrystalSpec, crystal};
    use rand::{Rng, SeedableRng};

    /// The volume of the unit superball, 8 Γ(1 + 1/2p)³ / Γ(1 + 3/2p).
    fn superball_volume(p: f64) -> f64 {
        let g = |x: f64| statrs::function::gamma::gamma(x);
        let q = 2.0 * p;
        8.0 * g(1.0 + 1.0 / q).powi(3) / g(1.0 + 3.0 / q)
    }

    /// The packing fraction of the lattice `b` of unit superballs scaled
    /// until its shortest vector, in the superball's norm over every
    /// combination with coefficients in [−3, 3], is 2: the admissibility
    /// of the difference body, by brute force and without the overlap
    /// kernels.
    fn packing_fraction(b: &Matrix3<f64>, p: f64) -> f64 {
        let q = 2.0 * p;
        let mut shortest = f64::INFINITY;
        for i in -3i32..=3 {
            for j in -3i32..=3 {
                for k in -3i32..=3 {
                    if (i, j, k) == (0, 0, 0) {
                        continue;
                    }
                    let v = b * V3::new(i as f64, j as f64, k as f64);
                    let norm = v.iter().map(|x| x.abs().powf(q)).sum::<f64>().powf(1.0 / q);
                    shortest = shortest.min(norm);
                }
            }
        }
        superball_volume(p) / (b.determinant().abs() * (2.0 / shortest).powi(3))
    }

    /// Both lattices are fcc at p = 1 and their bodies touch exactly, in
    /// the brute-force norm, at the packing fraction of the determinant.
    #[test]
    fn both_superball_lattices_are_admissible_and_fcc_for_spheres() {
        let fcc = std::f64::consts::PI / 18f64.sqrt();
        for b in [superball_c0(1.0), superball_c1(1.0)] {
            assert!((packing_fraction(&b, 1.0) - fcc).abs() < 1e-12);
        }
        for p in [1.05, 1.1, 1.5, 2.0, 3.0, 5.0, 50.0] {
            for b in [superball_c0(p), superball_c1(p)] {
                let touching = superball_volume(p) / b.determinant();
                assert!(b.determinant() > 0.0);
                assert!(
                    (packing_fraction(&b, p) - touching).abs() < 1e-12,
                    "p = {p}: {} vs {touching}",
                    packing_fraction(&b, p)
                );
            }
        }
        // C₁ tends to the cube lattice.
        let c = superball_c1(500.0);
        assert!((packing_fraction(&c, 500.0) - 1.0).abs() < 1e-2);
    }

    /// Jiao et al. find C₀ and C₁ equally dense at p*_c = 1.1509 (to
    /// their four decimals); the crossing of our two lattices, by
    /// bisection, is there.
    #[test]
    fn the_two_lattices_cross_where_jiao_et_al_put_it() {
        let gain = |p: f64| superball_c1(p).determinant() - superball_c0(p).determinant();
        let (mut lo, mut hi) = (1.01, 1.5);
        assert!(gain(lo) > 0.0 && gain(hi) < 0.0);
        while hi - lo > 1e-10 {
            let mid = 0.5 * (lo + hi);
            if gain(mid) > 0.0 { lo = mid } else { hi = mid }
        }
        assert!((lo - 1.1509).abs() < 5e-5, "{lo}");
    }

    /// No lattice near the densest one packs superballs more densely:
    /// random deformations of the basis, each rescaled until it is
    /// admissible, never gain. The same search improves on fcc at p = 2,
    /// so it can fail. (C₁ below the crossing is a local optimum too: only
    /// C₀, a lattice elsewhere, beats it.)
    #[test]
    fn no_nearby_lattice_packs_superballs_more_densely() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(53);
        let mut best_gain = |b: &Matrix3<f64>, p: f64| {
            let start = packing_fraction(b, p);
            let mut gain = f64::NEG_INFINITY;
            for _ in 0..3000 {
                let step = Matrix3::from_fn(|_, _| rng.gen_range(-1e-3..1e-3));
                gain = gain.max(packing_fraction(&(b + step), p) - start);
            }
            gain
        };
        for p in [1.1, 1.5, 2.0, 3.0, 5.0] {
            let gain = best_gain(&superball_lattice(p), p);
            assert!(gain < 1e-12, "p = {p}: a neighbour gains {gain:e}");
        }
        let gain = best_gain(&superball_c1(1.0), 2.0);
        assert!(gain > 1e-6, "fcc at p = 2 should be beaten: {gain:e}");
    }

    fn superball(exponent: f64, axes: (f64, f64, f64)) -> (Vec<Species>, Shape) {
        let text = format!(
            "Superellipsoid(a: {}, b: {}, c: {}, exponents: ({exponent}, {exponent}, {exponent}))",
            axes.0, axes.1, axes.2
        );
        let shape: Shape = text.parse().unwrap();
        let species = vec![Species {
            name: "s".into(),
            shape,
            rotation: true,
        }];
        (species, shape)
    }

    /// `Densest` superballs and stretched superellipsoids touch, by the
    /// overlap kernels, at the packing fraction of Jiao et al.'s
    /// construction; the values agree with a search over all lattices
    /// (docs/crystals.md) to 1e-6. Just below is built overlap-free, just
    /// above refused.
    #[test]
    fn densest_superballs_touch_at_jiao_et_al_densities() {
        for (p, searched) in [
            (1.5, 0.809528),
            (2.0, 0.869889),
            (3.0, 0.931814),
            (5.0, 0.971896),
        ] {
            for axes in [(0.5, 0.5, 0.5), (1.0, 0.4, 0.7)] {
                let (species, shape) = superball(2.0 * p, axes);
                let cell = UnitCell::densest(&shape).unwrap();
                let construction = superball_volume(p) / superball_lattice(p).determinant();
                assert!(
                    (construction - searched).abs() < 1e-6,
                    "{p}: {construction}"
                );
                let counts = vec![7 * 7 * 7];
                let spec = |phi| CrystalSpec {
                    cell: cell.clone(),
                    cells: [7, 7, 7],
                    packing_fraction: phi,
                };
                let limit = spec(0.5)
                    .densest_packing_fraction(&species, &counts)
                    .unwrap();
                assert!((limit - construction).abs() < 1e-6, "{p} {axes:?}: {limit}");
                let system = crystal(&spec(construction - 1e-4), species.clone(), &counts).unwrap();
                assert_eq!(system.first_overlap_all_pairs(), None);
                match crystal(&spec(construction + 1e-4), species, &counts) {
                    Err(CrystalError::TooDense { limit: l, .. }) => {
                        assert!((l - construction).abs() < 1e-6)
                    }
                    other => panic!("{p}: {other:?}"),
                }
            }
        }
        let mixed: Shape = "Superellipsoid(a: 1, b: 1, c: 1, exponents: (4, 4, 6))"
            .parse()
            .unwrap();
        assert!(matches!(
            UnitCell::densest(&mixed),
            Err(CrystalError::NoDensest(_))
        ));
    }
}
