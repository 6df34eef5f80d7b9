//! hardbody: dense packings and dynamics of hard ellipsoids,
//! superellipsoids, cuboids and spheres.
//!
//! Layers, bottom to top: [`geometry`] (shapes, overlap, distance), [`space`]
//! (the periodic box), [`analysis`] (observables built on the geometry), and
//! the command line at the edge (`src/main.rs`).
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod edmd;
pub mod geometry;
pub mod log;
pub mod mc;
pub mod run;
pub mod scene;
pub mod space;

/// Deterministic numbers for unit tests, without a dependency.
#[cfg(test)]
pub(crate) mod test_support {
    /// Uniform numbers in [0, 1) from a 64-bit LCG (Knuth's MMIX constants).
    pub fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A random direction from the numbers of `u` (a point of the cube
    /// about the origin, normalised: not uniform on the sphere, which the
    /// tests that use it do not need).
    pub fn unit_vector(u: &mut dyn FnMut() -> f64) -> nalgebra::Vector3<f64> {
        nalgebra::Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize()
    }
}
