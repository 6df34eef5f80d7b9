//! Starting states: a dilute cubic lattice with random orientations, from
//! which compression begins.

use nalgebra::Vector3;
use rand::Rng;

use super::{Particle, Species, StateError, System};
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
) -> Result<System, StateError> {
    if n == 0 || species.is_empty() {
        return Err(StateError::Empty);
    }
    let count = n * n * n;
    if let Some(i) = (0..count).find(|&i| species_of(i) as usize >= species.len()) {
        return Err(StateError::UnknownSpecies(i, species_of(i), species.len()));
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
    let box_ = PeriodicBox::new(Vector3::repeat(len)).map_err(|_| StateError::Empty)?;
    System::new(box_, species, particles)
}

/// Why a starting state could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StartError {
    /// The lattice has too few sites.
    #[error(
        "a lattice in the box {lengths:?} holds at most {sites} particles (sites at least {:.4} x {:.4} x {:.4} apart), the species have {wanted}: enlarge the box",
        spacing[0], spacing[1], spacing[2]
    )]
    LatticeTooSmall {
        /// Box edges.
        lengths: [f64; 3],
        /// Smallest site spacing per axis.
        spacing: [f64; 3],
        /// Sites available.
        sites: usize,
        /// Particles asked for.
        wanted: usize,
    },
    /// Random insertion gave up.
    #[error(
        "random insertion placed {placed} of {wanted} particles in {attempts} attempts: the box is too dense for a random start (use Lattice, or a larger box and a Compress stage)"
    )]
    InsertionFailed {
        /// Particles placed.
        placed: usize,
        /// Particles asked for.
        wanted: usize,
        /// Attempts made.
        attempts: u64,
    },
    /// The box or the species are unusable.
    #[error(transparent)]
    System(#[from] StateError),
    /// A crystal that cannot be built.
    #[error(transparent)]
    Crystal(#[from] super::crystal::CrystalError),
}

/// A lattice for `n` particles of `species` in a box of edges `lengths`:
/// sites per axis, and whether orientations may be random. Sites at least
/// one bounding diameter apart allow any orientation; otherwise bodies are
/// aligned with the box axes and sites are at least one oriented-box width
/// apart along each axis (aligned boxes that far apart cannot meet). The
/// site counts spread the particles as evenly as the box allows.
pub fn lattice_plan(lengths: &Vector3<f64>, species: &[Species], n: usize) -> LatticePlan {
    let margin = 1.0 + 1e-9;
    let diameter = 2.0
        * species
            .iter()
            .map(|s| s.shape.bounding_radius())
            .fold(0.0, f64::max)
        * margin;
    let widths = species
        .iter()
        .map(|s| 2.0 * s.shape.obb_half_extents() * margin)
        .fold(Vector3::zeros(), |m: Vector3<f64>, w| m.sup(&w));
    let fit = |spacing: &Vector3<f64>| -> [usize; 3] {
        std::array::from_fn(|k| (lengths[k] / spacing[k]).floor().max(0.0) as usize)
    };
    let random = fit(&Vector3::repeat(diameter));
    let (max, spacing, random_orientations) = if random.iter().product::<usize>() >= n {
        (random, Vector3::repeat(diameter), true)
    } else {
        (fit(&widths), widths, false)
    };
    // Start from the even spacing (V/n)^⅓ and add sites where the spacing
    // is widest until there are enough.
    let even = (lengths.product() / n as f64).cbrt();
    let mut sites: [usize; 3] =
        std::array::from_fn(|k| ((lengths[k] / even).floor() as usize).clamp(1, max[k].max(1)));
    while sites.iter().product::<usize>() < n {
        let widest = (0..3).filter(|&k| sites[k] < max[k]).max_by(|&a, &b| {
            (lengths[a] / sites[a] as f64).total_cmp(&(lengths[b] / sites[b] as f64))
        });
        match widest {
            Some(k) => sites[k] += 1,
            None => break,
        }
    }
    LatticePlan {
        sites,
        capacity: max.iter().product(),
        spacing,
        random_orientations,
    }
}

/// See [`lattice_plan`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatticePlan {
    /// Sites per axis.
    pub sites: [usize; 3],
    /// The most sites the box holds at the smallest spacing.
    pub capacity: usize,
    /// Smallest spacing allowed per axis.
    pub spacing: Vector3<f64>,
    /// Whether orientations are random (else aligned with the box).
    pub random_orientations: bool,
}

/// `counts[s]` particles of each species on the lattice of
/// [`lattice_plan`], species mixed at random over randomly chosen sites.
pub fn lattice<R: Rng>(
    box_: PeriodicBox,
    species: Vec<Species>,
    counts: &[usize],
    rng: &mut R,
) -> Result<System, StartError> {
    use rand::seq::SliceRandom;
    let lengths = box_.lengths();
    let n: usize = counts.iter().sum();
    let plan = lattice_plan(&lengths, &species, n);
    let [a, b, c] = plan.sites;
    if a * b * c < n {
        return Err(StartError::LatticeTooSmall {
            lengths: lengths.into(),
            spacing: plan.spacing.into(),
            sites: plan.capacity,
            wanted: n,
        });
    }
    let mut sites: Vec<usize> = (0..a * b * c).collect();
    sites.shuffle(rng);
    let step = Vector3::new(
        lengths.x / a as f64,
        lengths.y / b as f64,
        lengths.z / c as f64,
    );
    let kinds = counts
        .iter()
        .enumerate()
        .flat_map(|(s, &k)| std::iter::repeat_n(s as u16, k));
    let particles = sites
        .iter()
        .zip(kinds)
        .map(|(&site, kind)| {
            let ijk = Vector3::new(
                (site % a) as f64 + 0.5,
                ((site / a) % b) as f64 + 0.5,
                (site / (a * b)) as f64 + 0.5,
            );
            Particle {
                // Sites on the unsheared grid, sheared with the box.
                position: box_.shear(&(ijk.component_mul(&step) - lengths / 2.0)),
                orientation: if plan.random_orientations {
                    random_rotation(rng)
                } else {
                    nalgebra::UnitQuaternion::identity()
                },
                species: kind,
            }
        })
        .collect();
    Ok(System::new(box_, species, particles)?)
}

/// `counts[s]` particles of each species inserted one by one at uniformly
/// random positions and orientations, each kept only if it overlaps none
/// placed before; gives up after `max_attempts` attempts in all.
pub fn random_insertion<R: Rng>(
    box_: PeriodicBox,
    species: Vec<Species>,
    counts: &[usize],
    max_attempts: u64,
    rng: &mut R,
) -> Result<System, StartError> {
    random_insertion_sized(box_, species, counts, None, max_attempts, rng)
}

/// [`random_insertion`] of bodies of their own sizes (`sizes[i]` the
/// scale factor of the i-th body's species' shape, the bodies in the
/// order of `counts`; see [`System::with_sizes`]).
pub fn random_insertion_sized<R: Rng>(
    box_: PeriodicBox,
    species: Vec<Species>,
    counts: &[usize],
    sizes: Option<Vec<f64>>,
    max_attempts: u64,
    rng: &mut R,
) -> Result<System, StartError> {
    use crate::geometry::{Relative, overlap};
    let n: usize = counts.iter().sum();
    if let Some(sizes) = &sizes
        && sizes.len() != n
    {
        return Err(StateError::SizesCount {
            sizes: sizes.len(),
            particles: n,
        }
        .into());
    }
    let size_of = |i: usize| sizes.as_ref().map_or(1.0, |s| s[i]);
    let mut placed: Vec<Particle> = Vec::with_capacity(n);
    let mut shapes: Vec<crate::geometry::Shape> = Vec::with_capacity(n);
    let mut attempts = 0;
    for (s, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let size = size_of(placed.len());
            if !(size.is_finite() && size > 0.0) {
                return Err(StateError::BadSize(placed.len(), size).into());
            }
            let shape = match sizes {
                Some(_) => species[s].shape.scaled(size),
                None => species[s].shape,
            };
            let radius = shape.bounding_radius();
            loop {
                if attempts == max_attempts {
                    return Err(StartError::InsertionFailed {
                        placed: placed.len(),
                        wanted: n,
                        attempts,
                    });
                }
                attempts += 1;
                let fractional = Vector3::from_fn(|_, _| rng.r#gen::<f64>() - 0.5);
                let position = box_.from_fractional(&fractional);
                let orientation = random_rotation(rng);
                let rotation = orientation.to_rotation_matrix().into_inner();
                let clash = {
                    let (up, down) = shape.lab_extents(&rotation);
                    box_.wall_gap(&position, (&up, &down))
                } <= 0.0
                    || placed.iter().zip(&shapes).any(|(p, other)| {
                        let d = box_.minimum_image(&(p.position - position));
                        let reach = radius + other.bounding_radius();
                        d.norm_squared() <= reach * reach
                            && overlap(
                                &shape,
                                other,
                                &Relative::new(&d, &orientation, &p.orientation),
                            )
                    });
                if !clash {
                    placed.push(Particle {
                        position: box_.wrap(&position),
                        orientation,
                        species: s as u16,
                    });
                    shapes.push(shape);
                    break;
                }
            }
        }
    }
    Ok(match sizes {
        Some(sizes) => System::with_sizes(box_, species, placed, sizes)?,
        None => System::new(box_, species, placed)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn species(shape: &str) -> Vec<Species> {
        vec![Species {
            name: "x".into(),
            shape: shape.parse().unwrap(),
            rotation: true,
        }]
    }

    #[test]
    fn a_tight_lattice_aligns_the_bodies() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        // 256 rods of length 2 in a 12³ box: 216 sites one bounding
        // diameter apart, so they are aligned (5 x 11 x 11 sites fit: the
        // spacing must exceed the oriented-box widths 2 x 1 x 1).
        let rods = species("Ellipsoid(a: 1.0, b: 0.5, c: 0.5)");
        let l = Vector3::repeat(12.0);
        let b = PeriodicBox::new(l).unwrap();
        let plan = lattice_plan(&l, &rods, 256);
        assert!(!plan.random_orientations);
        assert!(plan.sites.iter().product::<usize>() >= 256);
        let system = lattice(b, rods.clone(), &[256], &mut rng).unwrap();
        assert_eq!(system.len(), 256);
        assert_eq!(system.first_overlap_all_pairs(), None);
        // A roomy lattice turns them at random.
        assert!(lattice_plan(&l, &rods, 100).random_orientations);
        let err = lattice(b, rods, &[606], &mut rng).unwrap_err();
        assert!(
            matches!(err, StartError::LatticeTooSmall { sites: 605, .. }),
            "{err}"
        );
    }

    #[test]
    fn random_insertion_places_without_overlap_or_gives_up() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(2);
        let cubes = species("Cuboid(a: 0.5, b: 0.5, c: 0.5)");
        let b = PeriodicBox::new(Vector3::repeat(8.0)).unwrap();
        let system = random_insertion(b, cubes.clone(), &[60], 100_000, &mut rng).unwrap();
        assert_eq!(system.len(), 60);
        assert_eq!(system.first_overlap_all_pairs(), None);
        // 400 unit cubes in 512: impossible by random insertion.
        let err = random_insertion(b, cubes.clone(), &[400], 20_000, &mut rng).unwrap_err();
        // Between walls: nothing touches them.
        let walled = b.with_walls([true, false, true]).unwrap();
        let system = random_insertion(walled, cubes, &[60], 100_000, &mut rng).unwrap();
        assert_eq!(system.first_wall_overlap(), None);
        assert!(
            system
                .particles()
                .iter()
                .all(|p| p.position.x.abs() < 3.5 && p.position.z.abs() < 3.5)
        );
        assert!(matches!(err, StartError::InsertionFailed { .. }), "{err}");
    }
}
