//! The orientation-averaged excluded volume of two shapes and the second
//! virial coefficient B₂ = V_excl/2, by Monte Carlo integration: B's centre
//! uniform in the ball of radius R_A + R_B (bounding spheres) around A, both
//! orientations uniform; V_excl = V_ball × (fraction of overlapping samples).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use rayon::prelude::*;

use crate::geometry::pair::{OverlapStrains, counting_strains};
use crate::geometry::{Relative, Shape, overlap};

/// Samples per independent random stream; streams are keyed on
/// (seed, chunk), so results do not depend on the thread count.
const CHUNK: u64 = 1 << 16;

/// An excluded-volume estimate with its standard error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct VirialEstimate {
    /// ⟨V_excl⟩ over orientations.
    pub excluded_volume: f64,
    /// Standard error of `excluded_volume`.
    pub excluded_volume_error: f64,
    /// B₂ = V_excl / 2.
    pub b2: f64,
    /// Samples drawn.
    pub samples: u64,
    /// Overlap tests of the samples that GJK left undecided (each settled
    /// by the signed distance, or counted as an overlap where that failed
    /// too).
    pub overlap_strains: OverlapStrains,
}

/// A uniformly random rotation (normalised 4-D Gaussian).
pub fn random_rotation<R: Rng>(rng: &mut R) -> UnitQuaternion<f64> {
    loop {
        let q = Quaternion::new(
            rng.sample::<f64, _>(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        );
        if q.norm() > 1e-8 {
            return UnitQuaternion::from_quaternion(q);
        }
    }
}

/// A point uniform in the ball of radius `r`.
fn random_in_ball<R: Rng>(rng: &mut R, r: f64) -> Vector3<f64> {
    loop {
        let p =
            Vector3::new(rng.r#gen::<f64>(), rng.r#gen(), rng.r#gen()) * 2.0 - Vector3::repeat(1.0);
        if p.norm_squared() <= 1.0 {
            return p * r;
        }
    }
}

/// Estimates the excluded volume of `a` and `b` from `samples` random
/// relative placements (at least one).
pub fn excluded_volume(a: &Shape, b: &Shape, samples: u64, seed: u64) -> VirialEstimate {
    let samples = samples.max(1);
    let reach = a.bounding_radius() + b.bounding_radius();
    let chunks = samples.div_ceil(CHUNK);
    let (hits, strains) = (0..chunks)
        .into_par_iter()
        .map(|chunk| {
            let mut rng = Pcg64::seed_from_u64(seed ^ chunk.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            let n = CHUNK.min(samples - chunk * CHUNK);
            counting_strains(|| {
                let mut hits = 0;
                for _ in 0..n {
                    let r_ab = random_in_ball(&mut rng, reach);
                    let (qa, qb) = if a.is_sphere() {
                        (UnitQuaternion::identity(), random_rotation(&mut rng))
                    } else {
                        (random_rotation(&mut rng), random_rotation(&mut rng))
                    };
                    hits += overlap(a, b, &Relative::new(&r_ab, &qa, &qb)) as u64;
                }
                hits
            })
        })
        .reduce(
            || (0, OverlapStrains::default()),
            |(h, s), (h2, s2)| (h + h2, s + s2),
        );
    let ball = 4.0 / 3.0 * std::f64::consts::PI * reach.powi(3);
    let p = hits as f64 / samples as f64;
    let excluded = ball * p;
    VirialEstimate {
        excluded_volume: excluded,
        excluded_volume_error: ball * (p * (1.0 - p) / samples as f64).sqrt(),
        b2: excluded / 2.0,
        samples,
        overlap_strains: strains,
    }
}
