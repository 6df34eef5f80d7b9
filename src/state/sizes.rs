//! Polydisperse sizes: the distributions a species' bodies draw their
//! sizes from (scale factors of the species' shape), the drawing, and two
//! bodies exchanging their sizes.

use nalgebra::Vector3;
use rand::Rng;
use rand_distr::{Distribution, LogNormal, Normal};
use serde::{Deserialize, Serialize};

use super::{Neighbours, System};

impl System {
    /// Bodies `i` and `j` of one species exchange their sizes, if neither
    /// then overlaps another body, the other or a wall: the size-swap
    /// move, symmetric and so accepted exactly when it leaves no overlap.
    /// False, and nothing changed, where it would, and for bodies without
    /// sizes of their own, of two species, or one body twice.
    pub fn try_swap_sizes(&mut self, i: usize, j: usize) -> bool {
        let same = self.particles[i].species == self.particles[j].species;
        if self.sizes.is_none() || i == j || !same {
            return false;
        }
        if !self.body_shape(i).is_sphere() {
            // Turned bodies: each tried at the other's size where it is,
            // their own pair included (its contact depends on how they
            // face each other).
            self.swap(i, j);
            let clear = (!self.overlaps_at(i, &self.positions[i], &self.rotations[i]))
                && !self.overlaps_at(j, &self.positions[j], &self.rotations[j]);
            if !clear {
                self.swap(i, j);
            }
            return clear;
        }
        // Spheres: their own pair keeps its contact distance, the sum of
        // their radii, and only the one that grows can come to overlap.
        let (ri, rj) = (self.body_radii[i], self.body_radii[j]);
        let (grows, radius) = if rj > ri { (i, rj) } else { (j, ri) };
        if self.sphere_overlaps_at(grows, radius, |k| k == i || k == j) {
            return false;
        }
        self.swap(i, j)
    }

    /// Exchanges the sizes of `i` and `j` everywhere they are kept.
    fn swap(&mut self, i: usize, j: usize) -> bool {
        let sizes = self.sizes.as_mut().expect("sizes");
        sizes.swap(i, j);
        self.body_radii.swap(i, j);
        if let Some(shapes) = &mut self.body_shapes {
            shapes.swap(i, j);
            for k in [i, j] {
                self.placed[k] = crate::geometry::Placed::new(&shapes[k], &self.rotations[k]);
            }
        }
        for k in [i, j] {
            let radius = self.body_radii[k];
            match &mut self.cells {
                Neighbours::Cells(cells) => cells.set_radius(k, radius),
                Neighbours::PerSpecies(grids) => {
                    grids[self.particles[k].species as usize].set_radius(k, radius)
                }
                Neighbours::Aabb(_) => {}
            }
            if let Some(lists) = &mut self.sphere_lists {
                lists.resized(k, radius, &self.positions[k]);
            }
        }
        self.changed = true;
        true
    }

    /// Whether sphere `k` where it is, at radius `radius`, overlaps a wall
    /// or a body m (at its own size) but those with `skip(m)`.
    fn sphere_overlaps_at(&self, k: usize, radius: f64, skip: impl Fn(usize) -> bool) -> bool {
        let centre = self.positions[k];
        if self.ideal {
            return false;
        }
        if self.box_.wall_gap(
            &centre,
            (&Vector3::repeat(radius), &Vector3::repeat(radius)),
        ) <= 0.0
        {
            return true;
        }
        let touches = |m: usize, d: &Vector3<f64>| {
            let reach = radius + self.body_radii[m];
            d.norm_squared() <= reach * reach && !skip(m)
        };
        match &self.cells {
            // The cells keep each body's radius beside its centre.
            Neighbours::Cells(cells) => {
                cells.sphere_overlaps_where(&centre, radius, |m| !skip(m as usize))
            }
            Neighbours::PerSpecies(grids) => (grids.iter().enumerate())
                .any(|(s, grid)| grid.any_within(&centre, radius + self.radii[s], touches)),
            Neighbours::Aabb(cells) => cells.any_near(&centre, &Vector3::repeat(radius), |m| {
                touches(
                    m,
                    &self.box_.minimum_image_near(&(self.positions[m] - centre)),
                )
            }),
        }
    }
}

/// Per species, the largest size among its bodies (`species_of[i]` the
/// species of body i, `sizes[i]` its size); 1 for a species without
/// bodies. What every bound sized by species (cells, ranges, a lattice's
/// spacing) is taken at, so that it holds for each of its bodies.
pub fn largest_sizes(
    species: usize,
    species_of: impl IntoIterator<Item = u16>,
    sizes: &[f64],
) -> Vec<f64> {
    let mut largest = vec![0.0_f64; species];
    for (k, &f) in species_of.into_iter().zip(sizes) {
        largest[k as usize] = largest[k as usize].max(f);
    }
    largest
        .iter_mut()
        .filter(|f| **f == 0.0)
        .for_each(|f| *f = 1.0);
    largest
}

/// `species` with each shape at its largest body's size
/// ([`largest_sizes`]).
pub fn species_at_largest(
    species: &[super::Species],
    species_of: impl IntoIterator<Item = u16>,
    sizes: &[f64],
) -> Vec<super::Species> {
    (species
        .iter()
        .zip(largest_sizes(species.len(), species_of, sizes)))
    .map(|(s, f)| super::Species {
        shape: if f == 1.0 { s.shape } else { s.shape.scaled(f) },
        ..s.clone()
    })
    .collect()
}

/// How the sizes of a species' bodies are spread, as scale factors of its
/// shape (a sphere of radius r at size f has radius f r).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SizeDistribution {
    /// Normal with mean 1 and standard deviation `std`, cut at three
    /// deviations either side (drawn again beyond): sizes in [1 − 3 std,
    /// 1 + 3 std], so `std` < 1/3 keeps them positive.
    Gaussian {
        /// Standard deviation (the polydispersity), in [0, 1/3).
        std: f64,
    },
    /// Log-normal with mean 1 and standard deviation `std`: ln f normal
    /// with variance s² = ln(1 + std²) and mean −s²/2.
    LogNormal {
        /// Standard deviation of the size (not of its logarithm), ≥ 0.
        std: f64,
    },
    /// Uniform on [min, max], 0 < min ≤ max.
    Uniform {
        /// Smallest size.
        min: f64,
        /// Largest size.
        max: f64,
    },
    /// One size per body, in the order of the species' bodies.
    List(Vec<f64>),
}

/// Why a size distribution cannot be drawn from.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SizesError {
    /// A Gaussian whose three-deviation cut reaches zero, or no finite
    /// non-negative deviation.
    #[error(
        "Gaussian std {0} must be finite, at least 0 and below 1/3 (its sizes are cut at 1 +- 3 std and must stay positive)"
    )]
    GaussianStd(f64),
    /// A log-normal deviation that is not finite and non-negative.
    #[error("LogNormal std {0} must be finite and at least 0")]
    LogNormalStd(f64),
    /// Uniform bounds out of order or not positive.
    #[error("Uniform(min: {min}, max: {max}) needs 0 < min <= max, both finite")]
    UniformBounds {
        /// Lower bound given.
        min: f64,
        /// Upper bound given.
        max: f64,
    },
    /// A list of another length than the species' count.
    #[error("List has {given} sizes for {count} bodies")]
    ListLength {
        /// Entries given.
        given: usize,
        /// Bodies of the species.
        count: usize,
    },
    /// A list entry that is not finite and positive.
    #[error("List entry {index} is {value}: every size must be finite and positive")]
    ListEntry {
        /// Where in the list.
        index: usize,
        /// What it holds.
        value: f64,
    },
}

impl SizeDistribution {
    /// Whether `count` sizes can be drawn (every one positive).
    pub fn check(&self, count: usize) -> Result<(), SizesError> {
        match *self {
            Self::Gaussian { std } if !(std.is_finite() && (0.0..1.0 / 3.0).contains(&std)) => {
                Err(SizesError::GaussianStd(std))
            }
            Self::LogNormal { std } if !(std.is_finite() && std >= 0.0) => {
                Err(SizesError::LogNormalStd(std))
            }
            Self::Uniform { min, max }
                if !(min.is_finite() && max.is_finite() && 0.0 < min && min <= max) =>
            {
                Err(SizesError::UniformBounds { min, max })
            }
            Self::List(ref sizes) if sizes.len() != count => Err(SizesError::ListLength {
                given: sizes.len(),
                count,
            }),
            Self::List(ref sizes) => {
                match sizes.iter().position(|f| !(f.is_finite() && *f > 0.0)) {
                    Some(index) => Err(SizesError::ListEntry {
                        index,
                        value: sizes[index],
                    }),
                    None => Ok(()),
                }
            }
            _ => Ok(()),
        }
    }

    /// `count` sizes drawn independently (a list is taken as it is).
    pub fn draw<R: Rng>(&self, count: usize, rng: &mut R) -> Result<Vec<f64>, SizesError> {
        self.check(count)?;
        Ok(match *self {
            Self::Gaussian { std } => {
                let normal = Normal::new(1.0, std).expect("checked deviation");
                (0..count)
                    .map(|_| {
                        loop {
                            let f: f64 = normal.sample(rng);
                            if (f - 1.0).abs() <= 3.0 * std {
                                break f;
                            }
                        }
                    })
                    .collect()
            }
            Self::LogNormal { std } => {
                let s2 = (1.0 + std * std).ln();
                let log_normal = LogNormal::new(-0.5 * s2, s2.sqrt()).expect("checked deviation");
                (0..count).map(|_| log_normal.sample(rng)).collect()
            }
            Self::Uniform { min, max } => (0..count).map(|_| rng.gen_range(min..=max)).collect(),
            Self::List(ref sizes) => sizes.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use statrs::statistics::Statistics;

    /// Each distribution's sample has the mean and spread it promises,
    /// within its sampling error, and keeps to its bounds.
    #[test]
    fn sizes_have_the_moments_and_bounds_they_promise() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let n = 200_000;
        let sqrt_n = (n as f64).sqrt();
        for (dist, mean, std) in [
            // The cut at 3 deviations narrows a normal by 1.35 %.
            (SizeDistribution::Gaussian { std: 0.2 }, 1.0, 0.2 * 0.98654),
            (SizeDistribution::LogNormal { std: 0.3 }, 1.0, 0.3),
            (
                SizeDistribution::Uniform { min: 0.8, max: 1.4 },
                1.1,
                0.6 / 12f64.sqrt(),
            ),
        ] {
            let sizes = dist.draw(n, &mut rng).unwrap();
            let (m, s) = (sizes.iter().mean(), sizes.iter().std_dev());
            assert!((m - mean).abs() < 4.0 * std / sqrt_n, "{dist:?}: mean {m}");
            assert!((s - std).abs() < 0.01 * std, "{dist:?}: std {s}");
            assert!(sizes.iter().all(|f| *f > 0.0), "{dist:?}");
        }
        let cut = SizeDistribution::Gaussian { std: 0.3 };
        let sizes = cut.draw(n, &mut rng).unwrap();
        assert!(sizes.iter().all(|f| (f - 1.0).abs() <= 0.9));
        assert!(sizes.iter().any(|f| (f - 1.0).abs() > 0.85));
    }

    #[test]
    fn distributions_that_allow_non_positive_sizes_are_refused() {
        let bad = [
            (SizeDistribution::Gaussian { std: 1.0 / 3.0 }, "1/3"),
            (SizeDistribution::Gaussian { std: -0.1 }, "at least 0"),
            (SizeDistribution::Gaussian { std: f64::NAN }, "finite"),
            (SizeDistribution::LogNormal { std: -1.0 }, "at least 0"),
            (SizeDistribution::Uniform { min: 0.0, max: 1.0 }, "0 < min"),
            (
                SizeDistribution::Uniform { min: 1.2, max: 1.0 },
                "min <= max",
            ),
            (SizeDistribution::List(vec![1.0, 0.0, 1.0]), "entry 1 is 0"),
            (SizeDistribution::List(vec![1.0; 2]), "2 sizes for 3"),
        ];
        for (dist, says) in bad {
            let message = dist.check(3).unwrap_err().to_string();
            assert!(message.contains(says), "{dist:?}: {message}");
        }
        assert!(SizeDistribution::List(vec![1.0, 2.0, 0.5]).check(3).is_ok());
        assert!(SizeDistribution::Gaussian { std: 0.0 }.check(3).is_ok());
    }
}
