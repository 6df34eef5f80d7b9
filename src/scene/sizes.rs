//! Polydisperse species in a scene: the bodies' sizes drawn from the
//! scene's seed, the species a lattice start spaces by them, and the
//! checks of a species' sizes and of a stage's size swaps.

use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::{Scene, SpeciesSpec};

/// Mixed into the scene's seed for the sizes of species k (the seed xor
/// this plus k): their own streams, apart from the run's and from each
/// other's, so that the sizes of one species do not change with another's.
const SIZES_STREAM: u64 = 0x5129_e5d1_57a1_b000;

/// The most size swaps per body per sweep a stage may ask for.
pub const MAX_SWAPS: f64 = 100.0;

impl Scene {
    /// Each body's size, the bodies species by species as a run places
    /// them (1 for a species without `sizes`); `None` where no species
    /// gives sizes. Drawn from the scene's seed: `check` and `run` see the
    /// same sizes. `None` too for a distribution that validation refuses.
    pub fn body_sizes(&self) -> Option<Vec<f64>> {
        if self.species.iter().all(|s| s.sizes.is_none()) {
            return None;
        }
        let mut sizes = Vec::with_capacity(self.particle_count());
        for (k, s) in self.species.iter().enumerate() {
            match &s.sizes {
                Some(d) => {
                    let mut rng =
                        Pcg64::seed_from_u64(self.seed ^ SIZES_STREAM.wrapping_add(k as u64));
                    sizes.extend(d.draw(s.count, &mut rng).ok()?);
                }
                None => sizes.extend(std::iter::repeat_n(1.0, s.count)),
            }
        }
        Some(sizes)
    }

    /// The species as a lattice start spaces them: each at its largest
    /// body's size (the species the drivers take, without sizes).
    pub fn lattice_species(&self) -> Vec<crate::state::Species> {
        let species = self.mc_species();
        match self.body_sizes() {
            Some(sizes) => {
                let species_of = (self.species.iter().enumerate())
                    .flat_map(|(k, s)| std::iter::repeat_n(k as u16, s.count));
                crate::state::sizes::species_at_largest(&species, species_of, &sizes)
            }
            None => species,
        }
    }

    /// The species of each body, in the order of [`Scene::body_sizes`].
    pub(super) fn body_species(&self) -> impl Iterator<Item = &SpeciesSpec> {
        (self.species.iter()).flat_map(|s| std::iter::repeat_n(s, s.count))
    }

    /// Species `i`'s sizes: a distribution that keeps them positive (field,
    /// message).
    pub(super) fn validate_sizes_of(&self, i: usize) -> Result<(), (String, String)> {
        let s = &self.species[i];
        let Some(sizes) = &s.sizes else {
            return Ok(());
        };
        let field = format!("species[{i}].sizes");
        sizes.check(s.count).map_err(|e| (field, e.to_string()))
    }

    /// A Monte Carlo stage's `swaps` (field, message): finite, at least 0,
    /// at most [`MAX_SWAPS`] per body per sweep, and only with sizes to
    /// exchange.
    pub(super) fn validate_swaps(&self, field: &str, swaps: f64) -> Result<(), (String, String)> {
        if !(swaps.is_finite() && (0.0..=MAX_SWAPS).contains(&swaps)) {
            return Err((
                field.into(),
                format!("must lie in [0, {MAX_SWAPS}] size swaps per body per sweep, got {swaps}"),
            ));
        }
        if swaps > 0.0 && self.species.iter().all(|s| s.sizes.is_none()) {
            return Err((
                field.into(),
                "size swaps exchange the sizes of polydisperse bodies, and no species gives `sizes`".into(),
            ));
        }
        Ok(())
    }
}
