//! Starting states: a dilute cubic lattice with random orientations, from
//! which compression begins.

use nalgebra::Vector3;
use rand::Rng;

use super::{McError, Particle, Species, System};
use crate::analysis::virial::random_rotation;
use crate::space::PeriodicBox;

/// n³ particles on a cubic lattice with uniformly random orientations,
/// species assigned by `species_of`. The spacing is at least twice the
/// largest bounding radius (no orientation can overlap) and dilute enough
/// that φ ≤ 0.1.
pub fn dilute_lattice<R: Rng>(
    n: usize,
    species: Vec<Species>,
    species_of: impl Fn(usize) -> u16,
    rng: &mut R,
) -> Result<System, McError> {
    if n == 0 || species.is_empty() {
        return Err(McError::Empty);
    }
    let count = n * n * n;
    if let Some(i) = (0..count).find(|&i| species_of(i) as usize >= species.len()) {
        return Err(McError::UnknownSpecies(i, species_of(i), species.len()));
    }
    let largest = species
        .iter()
        .map(|s| s.shape.bounding_radius())
        .fold(0.0, f64::max);
    let volume: f64 = (0..count)
        .map(|i| species[species_of(i) as usize].shape.volume())
        .sum();
    let spacing = (2.0 * largest * 1.001).max((volume / 0.1).cbrt() / n as f64);
    let len = spacing * n as f64;
    let particles = (0..count)
        .map(|i| Particle {
            position: Vector3::new((i % n) as f64, ((i / n) % n) as f64, (i / (n * n)) as f64)
                * spacing
                - Vector3::repeat(len / 2.0),
            orientation: random_rotation(rng),
            species: species_of(i),
        })
        .collect();
    let box_ = PeriodicBox::new(Vector3::repeat(len)).map_err(|_| McError::Empty)?;
    System::new(box_, species, particles)
}
