//! hardbody: dense packings and dynamics of hard ellipsoids,
//! superellipsoids, cuboids and spheres.
//!
//! Layers, bottom to top (each imports only those below it;
//! `tests/architecture.rs` checks it):
//!
//! 0. [`number`]: how numbers print in messages;
//! 1. [`geometry`]: shapes, overlap tests, signed distances, bounds;
//! 2. [`space`]: the periodic box, cells and neighbour lists;
//! 3. [`analysis`]: observables of a configuration, statistics of series;
//! 4. [`state`]: species, particles and the validated configuration both
//!    drivers share;
//! 5. the drivers, side by side and independent: [`mc`] (Metropolis Monte
//!    Carlo, compression) and [`edmd`] (event-driven dynamics);
//! 6. [`scene`]: the scene file and the plan it implies;
//! 7. [`log`]: MCAP logs, their reading and their averages;
//! 8. [`run`]: a scene run stage by stage into its log;
//! 9. [`free_energy`]: absolute free energies of crystals (Frenkel–Ladd);
//! 10. [`bench`](mod@bench): the benchmark suites;
//! 11. [`sweep`]: parameter sweeps as signac workspaces run by row.
//!
//! The command line (`src/cli/`) is at the edge, outside the library.
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod edmd;
pub mod free_energy;
pub mod geometry;
pub mod log;
pub mod mc;
pub mod number;
pub mod run;
pub mod scene;
pub mod space;
pub mod state;
pub mod sweep;

/// Deterministic numbers and small systems for unit tests.
#[cfg(test)]
pub(crate) mod test_support {
    /// Cubes of half-edge `half` among spheres of `radius` on a lattice in
    /// a cubic box of side `side` (`counts`: cubes, spheres), random
    /// orientations from `seed`: a size-asymmetric mixture.
    pub fn cubes_among_spheres(
        half: f64,
        radius: f64,
        side: f64,
        counts: [usize; 2],
        seed: u64,
    ) -> crate::state::System {
        use crate::geometry::{Cuboid, Shape, Sphere};
        use rand::SeedableRng;
        let species = vec![
            crate::state::Species {
                name: "cube".into(),
                shape: Shape::Cuboid(Cuboid::new(half, half, half).unwrap()),
                rotation: true,
            },
            crate::state::Species {
                name: "sphere".into(),
                shape: Shape::Sphere(Sphere::new(radius).unwrap()),
                rotation: false,
            },
        ];
        let box_ = crate::space::PeriodicBox::new(nalgebra::Vector3::repeat(side)).unwrap();
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        crate::state::start::lattice(box_, species, &counts, &mut rng).unwrap()
    }

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
