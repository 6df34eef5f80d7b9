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

use super::System;
use crate::geometry::{Relative, overlap};

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

    /// Adds the xᵢ of one configuration. Pairs are found by an all-pairs
    /// scan limited by the bounding spheres (O(N²); an observable taken
    /// every so many sweeps).
    pub fn add(&mut self, system: &System) {
        let n = system.len();
        let shrink = 1.0 - self.x_max;
        let mut x_min = vec![f64::INFINITY; n];
        for i in 0..n {
            let pi = &system.particles[i];
            let si = pi.species as usize;
            for j in i + 1..n {
                let pj = &system.particles[j];
                let sj = pj.species as usize;
                let d = system.box_.minimum_image(&(pj.position - pi.position));
                let reach = system.radii[si] + system.radii[sj];
                // Beyond reach even after the largest shrink considered.
                if (d * shrink).norm_squared() > reach * reach {
                    continue;
                }
                let (shape_i, shape_j) = (&system.species[si].shape, &system.species[sj].shape);
                let x = if shape_i.is_sphere() && shape_j.is_sphere() {
                    1.0 - reach / d.norm()
                } else {
                    let (ri, rj): (&Matrix3<f64>, &Matrix3<f64>) =
                        (&system.rotations[i], &system.rotations[j]);
                    let overlaps_at = |x: f64| {
                        let rel = Relative {
                            translation: ri.tr_mul(&(d * (1.0 - x))),
                            rotation: ri.tr_mul(rj),
                        };
                        overlap(shape_i, shape_j, &rel)
                    };
                    if !overlaps_at(self.x_max) {
                        continue;
                    }
                    // Overlap is monotone in the shrink for convex bodies:
                    // bisect to far below a bin width.
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
                    0.5 * (lo + hi)
                };
                x_min[i] = x_min[i].min(x);
                x_min[j] = x_min[j].min(x);
            }
        }
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
