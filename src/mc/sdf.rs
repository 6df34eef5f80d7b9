//! Pressure of a hard-particle configuration from the scale distribution
//! function (SDF; Eppenga & Frenkel 1984, as HOOMD's SDF compute).
//!
//! For each particle i, xᵢ is the smallest relative shrink of all centre
//! positions (r → (1 − x) r, shapes unchanged) at which i would overlap some
//! other particle. s(x) is the density of the xᵢ per particle; in three
//! dimensions βP = ρ (1 + s(0⁺)/6), with s(0⁺) extrapolated by a quadratic
//! least-squares fit to the histogram on [0, x_max].
//!
//! For spheres this is the contact theorem: xᵢⱼ = 1 − σ/rᵢⱼ, so
//! s(0⁺) = 4πρσ³g(σ) and βP/ρ = 1 + (2π/3)ρσ³g(σ).

use nalgebra::Matrix3;

use crate::geometry::{Relative, overlap};
use crate::space::CellList;
use crate::state::System;

/// Accumulates the scale distribution over configurations.
#[derive(Debug, Clone)]
pub struct Sdf {
    x_max: f64,
    counts: Vec<u64>,
    /// Particle-configurations accumulated (Σ N over configurations).
    particles: u64,
    /// Σ N/V over configurations.
    density_sum: f64,
    configurations: u64,
}

impl Sdf {
    /// An empty accumulator with `bins` bins on [0, `x_max`] (HOOMD uses
    /// x_max ≈ 0.02 and bins of 10⁻⁴).
    pub fn new(x_max: f64, bins: usize) -> Self {
        Self {
            x_max,
            counts: vec![0; bins.max(3)],
            particles: 0,
            density_sum: 0.0,
            configurations: 0,
        }
    }

    /// Adds one configuration: each particle's xᵢ from the pairs whose
    /// centres lie within reach/(1 − x_max), found through cells that
    /// wide (all pairs cost N² distances, 8·10⁶ for 4000 particles: once
    /// four times the sweeps between two samples).
    pub fn add(&mut self, system: &System) {
        let shrink = 1.0 - self.x_max;
        let largest = system.radii.iter().copied().fold(0.0, f64::max);
        // (A hair wider than the farthest pair that counts.)
        let width = 2.0 * largest / shrink * (1.0 + 1e-9);
        let cells = CellList::new(system.box_.lengths(), width, system.positions.as_slice());
        let pairs = (0..system.len()).flat_map(|i| {
            let cells = &cells;
            (cells.neighbour_cells(cells.cell_of(i)).into_iter())
                .flat_map(move |cell| cells.members(cell as usize))
                .map(|&j| j as usize)
                .filter(move |&j| j > i)
                .map(move |j| (i, j))
        });
        let x_min = self.smallest_shrinks(system, pairs);
        self.add_shrinks(system, x_min);
    }

    /// [`Sdf::add`] by all pairs (the reference the cells are tested
    /// against).
    #[cfg(test)]
    fn add_all_pairs(&mut self, system: &System) {
        let n = system.len();
        let pairs = (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j)));
        let x_min = self.smallest_shrinks(system, pairs);
        self.add_shrinks(system, x_min);
    }

    /// Each particle's smallest shrink at which it overlaps another, over
    /// `pairs` (each pair once; infinite for a particle that overlaps none
    /// below x_max).
    fn smallest_shrinks(
        &self,
        system: &System,
        pairs: impl Iterator<Item = (usize, usize)>,
    ) -> Vec<f64> {
        let mut x_min = vec![f64::INFINITY; system.len()];
        for (i, j) in pairs {
            if let Some(x) = self.pair_shrink(system, i, j) {
                x_min[i] = x_min[i].min(x);
                x_min[j] = x_min[j].min(x);
            }
        }
        x_min
    }

    /// The smallest shrink in [0, x_max) at which particles `i` and `j`
    /// overlap, if any (their centres farther than reach/(1 − x_max)
    /// never do).
    fn pair_shrink(&self, system: &System, i: usize, j: usize) -> Option<f64> {
        let shrink = 1.0 - self.x_max;
        let (pi, pj) = (&system.particles[i], &system.particles[j]);
        let (si, sj) = (pi.species as usize, pj.species as usize);
        let d = system.box_.minimum_image(&(pj.position - pi.position));
        let reach = system.radii[si] + system.radii[sj];
        // Beyond reach even after the largest shrink considered.
        if (d * shrink).norm_squared() > reach * reach {
            return None;
        }
        let (shape_i, shape_j) = (&system.species[si].shape, &system.species[sj].shape);
        if shape_i.is_sphere() && shape_j.is_sphere() {
            return Some(1.0 - reach / d.norm());
        }
        let (ri, rj): (&Matrix3<f64>, &Matrix3<f64>) = (&system.rotations[i], &system.rotations[j]);
        let overlaps_at = |x: f64| {
            let rel = Relative {
                translation: ri.tr_mul(&(d * (1.0 - x))),
                rotation: ri.tr_mul(rj),
            };
            overlap(shape_i, shape_j, &rel)
        };
        if !overlaps_at(self.x_max) {
            return None;
        }
        // Overlap is monotone in the shrink for convex bodies: bisect to
        // far below a bin width.
        let (mut lo, mut hi) = (0.0, self.x_max);
        let tol = self.x_max / self.counts.len() as f64 * 1e-3;
        while hi - lo > tol {
            let mid = 0.5 * (lo + hi);
            if overlaps_at(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(0.5 * (lo + hi))
    }

    /// Bins each particle's smallest shrink `x_min` of one configuration.
    fn add_shrinks(&mut self, system: &System, x_min: Vec<f64>) {
        let n = system.len();
        let bins = self.counts.len();
        let width = self.x_max / bins as f64;
        for x in x_min {
            if (0.0..self.x_max).contains(&x) {
                self.counts[((x / width) as usize).min(bins - 1)] += 1;
            }
        }
        self.particles += n as u64;
        self.density_sum += n as f64 / system.box_.volume();
        self.configurations += 1;
    }

    /// The share of the binned shrinks that lie in the first tenth of
    /// [0, x_max): near one, the window is too wide for the fit (a packing
    /// near its jam, whose shrinks are all tiny).
    pub fn front_share(&self) -> f64 {
        let total: u64 = self.counts.iter().sum();
        if total == 0 {
            return 0.0;
        }
        let front: u64 = self.counts[..self.counts.len().div_ceil(10)].iter().sum();
        front as f64 / total as f64
    }

    /// βP from the configurations added so far; `None` before any.
    pub fn pressure(&self) -> Option<f64> {
        if self.configurations == 0 {
            return None;
        }
        let width = self.x_max / self.counts.len() as f64;
        // s(x) per particle at the bin centres; fit s ≈ c₀ + c₁x + c₂x².
        let mut ata = Matrix3::<f64>::zeros();
        let mut atb = nalgebra::Vector3::<f64>::zeros();
        for (k, &c) in self.counts.iter().enumerate() {
            let x = (k as f64 + 0.5) * width;
            let s = c as f64 / (self.particles as f64 * width);
            let row = nalgebra::Vector3::new(1.0, x, x * x);
            ata += row * row.transpose();
            atb += row * s;
        }
        let c = ata.lu().solve(&atb)?;
        let density = self.density_sum / self.configurations as f64;
        Some(density * (1.0 + c[0] / 6.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::mc::dense_start;
    use crate::geometry::Shape;
    use crate::mc::moves::{Ensemble, MoveSizes, sweep};
    use crate::space::PeriodicBox;
    use crate::state::Species;
    use nalgebra::Vector3;
    use rand::SeedableRng;

    /// A few sweeps of `system`, so that pairs sit at every distance.
    fn shaken(mut system: System, seed: u64) -> System {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let sizes = MoveSizes {
            translate: 0.1,
            rotate: 0.1,
            volume: 0.0,
        };
        for _ in 0..20 {
            sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
        }
        system
    }

    /// The cells find every pair all pairs find: the same histogram to the
    /// count for spheres, needles and cubes (dense, and in a box two cells
    /// wide, where neighbour cells repeat) and for cubes among spheres of a
    /// quarter their bounding radius.
    #[test]
    fn cells_count_what_all_pairs_count() {
        let mut systems = Vec::new();
        for text in [
            "Sphere(radius: 0.5)",
            "Ellipsoid(a: 1.25, b: 0.25, c: 0.25)",
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
        ] {
            let shape: Shape = text.parse().unwrap();
            systems.push(shaken(dense_start(&shape, 600, 0.5).unwrap(), 1));
            if shape.is_sphere() || text.starts_with("Cuboid") {
                // A box two or three cells wide.
                systems.push(shaken(dense_start(&shape, 16, 0.45).unwrap(), 2));
            }
        }
        // Cells exactly one diameter wide if they were not widened by
        // 1/(1 − x_max).
        let sphere = vec![Species {
            name: "sphere".into(),
            shape: "Sphere(radius: 0.5)".parse().unwrap(),
            rotation: false,
        }];
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let box_ = PeriodicBox::new(Vector3::repeat(8.0)).unwrap();
        let spheres = crate::state::start::lattice(box_, sphere, &[340], &mut rng).unwrap();
        systems.push(shaken(spheres, 6));
        let mixture = crate::test_support::cubes_among_spheres(0.5, 0.2, 11.0, [300, 600], 3);
        systems.push(shaken(mixture, 4));
        // (A wide x_max reaches far past the interaction range.)
        for x_max in [0.02, 0.2] {
            for (k, system) in systems.iter().enumerate() {
                let (mut cells, mut all) = (Sdf::new(x_max, 200), Sdf::new(x_max, 200));
                cells.add(system);
                all.add_all_pairs(system);
                assert_eq!(cells.counts, all.counts, "system {k}, x_max {x_max}");
                assert!(
                    all.counts.iter().sum::<u64>() > 0,
                    "system {k}: no pair near"
                );
                assert_eq!(cells.pressure(), all.pressure(), "system {k}");
            }
        }
    }
}
