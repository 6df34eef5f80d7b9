//! Hard bodies tethered to lattice sites by harmonic springs, the centre
//! of mass held: the coupled system of the Frenkel–Ladd path (Frenkel &
//! Ladd, J. Chem. Phys. 81, 3188 (1984)) in the centre-of-mass form of
//! Polson, Trizac, Pronk & Frenkel (J. Chem. Phys. 112, 5339 (2000)),
//! and direct samples of the ideal Einstein crystal it ends in.
//!
//! The spring energy is βU = λ (Σᵢ |uᵢ − ū|² + κ Σᵢ φᵢ), uᵢ the
//! displacement of body i from its site, ū their mean, and φᵢ the
//! misalignment of a body that turns from its reference orientation,
//! zero on every image of it under the body's symmetries
//! ([`Symmetry::misalignment`]); κ (length²) weighs the orientations. It depends on relative displacements
//! only, as the hard cores do, so the weight of every configuration is
//! that of the ensemble whose centre of mass is held, and the centre of
//! mass itself wanders freely: sampling without the constraint gives the
//! constrained averages. The sites follow the centre of mass after each
//! sweep, so that displacements stay small.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;

use super::einstein_orientation::sample_orientation;
use super::moves::{Counts, MoveSizes, propose_rotation, propose_translation};
use crate::geometry::symmetry::Symmetry;
use crate::state::System;

type V3 = Vector3<f64>;

/// What stops a tether from being built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TetherError {
    /// Not one site per body.
    #[error("{sites} lattice sites (or reference orientations) for {bodies} bodies")]
    Sites {
        /// Sites given.
        sites: usize,
        /// Bodies in the system.
        bodies: usize,
    },
    /// The spring constant, or the orientations' weight, is negative or
    /// not finite.
    #[error("spring constant {0} is not a finite number ≥ 0")]
    Spring(f64),
    /// A body sits further than half the distance between sites from its
    /// own: it is not on the lattice.
    #[error(
        "body {body} is {distance} from its site, more than half the closest distance \
         between sites ({half})"
    )]
    OffSite {
        /// The body.
        body: usize,
        /// Its distance from its site.
        distance: f64,
        /// Half the closest distance between two sites.
        half: f64,
    },
}

/// Where each body is tethered: its lattice site (a position in the box)
/// and its reference orientation (body → lab).
#[derive(Debug, Clone, PartialEq)]
pub struct Anchors {
    /// Site i of body i.
    pub sites: Vec<V3>,
    /// Reference orientation of body i.
    pub orientations: Vec<Matrix3<f64>>,
}

impl Anchors {
    /// The bodies of `system` where they are, as they are turned.
    pub fn of(system: &System) -> Self {
        Self {
            sites: system.positions.iter().copied().collect(),
            orientations: system.rotations.clone(),
        }
    }
}

/// The symmetry each species' orientational spring respects: none for a
/// species that does not turn.
pub fn spring_symmetries(system: &System) -> Vec<Symmetry> {
    (system.species().iter())
        .map(|s| match s.rotation {
            true => Symmetry::of(&s.shape),
            false => Symmetry::Sphere,
        })
        .collect()
}

/// Bodies on springs to their lattice sites and reference orientations,
/// with the centre of mass held.
#[derive(Debug, Clone)]
pub struct Tether {
    /// Each body's displacement uᵢ from its site, unwrapped.
    displacements: Vec<V3>,
    /// Σ uᵢ.
    sum: V3,
    /// βλ (1/length²).
    spring: f64,
    /// κ: the orientations' spring is κλ.
    twist: f64,
    /// The reference orientations.
    references: Vec<Matrix3<f64>>,
    /// The symmetry of each species' orientational spring.
    symmetries: Vec<Symmetry>,
    /// φᵢ of each body.
    misalignments: Vec<f64>,
    /// Half the closest distance between two sites: a body further from
    /// its site than this has left it.
    half_spacing: f64,
}

impl Tether {
    /// Springs of constant `spring` (βλ) from each body of `system` to its
    /// anchor (body i to site i and orientation i), the orientations'
    /// springs `twist` (κ) times as strong.
    pub fn new(
        system: &System,
        anchors: &Anchors,
        spring: f64,
        twist: f64,
    ) -> Result<Self, TetherError> {
        let n = system.len();
        let sites = &anchors.sites;
        if sites.len() != n || anchors.orientations.len() != n {
            return Err(TetherError::Sites {
                sites: sites.len().min(anchors.orientations.len()),
                bodies: n,
            });
        }
        if !(spring >= 0.0 && spring.is_finite()) {
            return Err(TetherError::Spring(spring));
        }
        if !(twist >= 0.0 && twist.is_finite()) {
            return Err(TetherError::Spring(twist));
        }
        let symmetries = spring_symmetries(system);
        let misalignments = (0..n)
            .map(|i| {
                let symmetry = &symmetries[system.particles[i].species as usize];
                symmetry.misalignment(&system.rotations[i], &anchors.orientations[i])
            })
            .collect();
        let box_ = system.periodic_box();
        let displacements: Vec<V3> = (system.positions.iter().zip(sites))
            .map(|(r, s)| box_.minimum_image(&(r - s)))
            .collect();
        let mut closest = f64::INFINITY;
        for i in 0..n {
            for j in i + 1..n {
                closest = closest.min(box_.minimum_image(&(sites[j] - sites[i])).norm());
            }
        }
        let tether = Self {
            sum: displacements.iter().sum(),
            displacements,
            spring,
            twist,
            references: anchors.orientations.clone(),
            symmetries,
            misalignments,
            half_spacing: 0.5 * closest,
        };
        tether.check_on_sites()?;
        Ok(tether)
    }

    /// βλ.
    pub fn spring(&self) -> f64 {
        self.spring
    }

    /// Half the closest distance between two sites.
    pub fn half_spacing(&self) -> f64 {
        self.half_spacing
    }

    /// Σᵢ |uᵢ − ū|², the quantity whose mean is −∂ ln Z/∂λ.
    pub fn spread(&self) -> f64 {
        let mean = self.sum / self.displacements.len() as f64;
        self.displacements
            .iter()
            .map(|u| (u - mean).norm_squared())
            .sum()
    }

    /// Σᵢ φᵢ, the orientations' part: −∂ ln Z/∂λ is the mean of
    /// [`Tether::spread`] + κ Σᵢ φᵢ.
    pub fn misalignment(&self) -> f64 {
        self.misalignments.iter().sum()
    }

    /// Whether every body is within half the site spacing of its site
    /// (relative to the centre of mass): the crystal has not melted.
    pub fn check_on_sites(&self) -> Result<(), TetherError> {
        let mean = self.sum / self.displacements.len() as f64;
        let (body, distance) = (self.displacements.iter().enumerate())
            .map(|(i, u)| (i, (u - mean).norm()))
            .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        if distance > self.half_spacing {
            return Err(TetherError::OffSite {
                body,
                distance,
                half: self.half_spacing,
            });
        }
        Ok(())
    }

    /// One sweep of N moves of bodies drawn at random: a rotation with
    /// probability ½ for a body that turns, else a translation, each kept
    /// with the Metropolis probability of its spring energy if it leaves
    /// the hard cores apart; then the sites follow the centre of mass.
    pub fn sweep<R: Rng>(&mut self, system: &mut System, sizes: &MoveSizes, rng: &mut R) -> Counts {
        let n = system.len();
        let mut counts = Counts::default();
        for _ in 0..n {
            let i = rng.gen_range(0..n);
            let species = system.particles[i].species as usize;
            if system.species[species].rotation && rng.r#gen::<bool>() {
                counts
                    .rotate
                    .record(self.turn(system, i, sizes.rotate, rng));
                continue;
            }
            let old = system.positions[i];
            let trial = propose_translation(&old, sizes.translate, rng);
            let step = trial - old;
            let kept = self.accepts(i, &step, rng) && !system.trial_overlaps(i, &trial, None);
            if kept {
                let p = system.particles[i];
                system.place(i, trial, p.orientation, system.rotations[i]);
                self.displacements[i] += step;
                self.sum += step;
            }
            counts.translate.record(kept);
        }
        self.follow_centre_of_mass();
        counts
    }

    /// A rotation of body `i` by at most `max_angle`, kept with the
    /// Metropolis probability of its orientational spring, κλ ∆φ, if it
    /// leaves the hard cores apart.
    fn turn<R: Rng>(&mut self, system: &mut System, i: usize, max_angle: f64, rng: &mut R) -> bool {
        let p = system.particles[i];
        let orientation = propose_rotation(&p.orientation, max_angle, rng);
        let rotation = orientation.to_rotation_matrix().into_inner();
        let symmetry = &self.symmetries[p.species as usize];
        let misalignment = symmetry.misalignment(&rotation, &self.references[i]);
        let change = self.spring * self.twist * (misalignment - self.misalignments[i]);
        let kept = (change <= 0.0 || rng.r#gen::<f64>() < (-change).exp())
            && !system.trial_overlaps(i, &p.position, Some(&rotation));
        if kept {
            system.place(i, p.position, orientation, rotation);
            self.misalignments[i] = misalignment;
        }
        kept
    }

    /// The Metropolis test of the spring energy of moving body `i` by
    /// `step`: β∆U = λ (|uᵢ + δ|² − |uᵢ|² − 2 ū·δ − |δ|²/N).
    fn accepts<R: Rng>(&self, i: usize, step: &V3, rng: &mut R) -> bool {
        if self.spring == 0.0 {
            return true;
        }
        let n = self.displacements.len() as f64;
        let u = &self.displacements[i];
        let mean = self.sum / n;
        let change = self.spring
            * ((u + step).norm_squared()
                - u.norm_squared()
                - 2.0 * mean.dot(step)
                - step.norm_squared() / n);
        change <= 0.0 || rng.r#gen::<f64>() < (-change).exp()
    }

    /// Moves the sites with the centre of mass (ū becomes zero), the sum
    /// recomputed so that rounding does not accumulate.
    fn follow_centre_of_mass(&mut self) {
        let mean = self.sum / self.displacements.len() as f64;
        for u in &mut self.displacements {
            *u -= mean;
        }
        self.sum = self.displacements.iter().sum();
    }
}

/// Direct samples of the ideal Einstein crystal of spring constant
/// `spring` about `anchors` (each displacement component Gaussian of
/// variance 1/(2λ), their mean taken off: the centre of mass held; each
/// orientation from its spring κλ, [`sample_orientation`]): how many of
/// `samples` leave the bodies of `system` apart.
pub fn overlap_free_samples<R: Rng>(
    system: &System,
    anchors: &Anchors,
    (spring, twist): (f64, f64),
    samples: usize,
    rng: &mut R,
) -> usize {
    let mut system = system.clone();
    let symmetries = spring_symmetries(&system);
    let sites = &anchors.sites;
    let n = system.len();
    let width = (0.5 / spring).sqrt();
    let mut draws = vec![V3::zeros(); n];
    let mut free = 0;
    for _ in 0..samples {
        for u in &mut draws {
            *u = V3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal)) * width;
        }
        let mean: V3 = draws.iter().sum::<V3>() / n as f64;
        for (i, (site, u)) in sites.iter().zip(&draws).enumerate() {
            let p = system.particles[i];
            let (orientation, rotation) = match &symmetries[p.species as usize] {
                Symmetry::Sphere => (p.orientation, system.rotations[i]),
                symmetry => {
                    let r =
                        sample_orientation(symmetry, spring * twist, &anchors.orientations[i], rng);
                    let q =
                        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
                    (q, r)
                }
            };
            system.place(i, site + (u - mean), orientation, rotation);
        }
        free += system.first_overlap().is_none() as usize;
    }
    free
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::einstein_orientation::orientational_partition;
    use crate::state::Species;
    use crate::state::crystal::{CrystalSpec, UnitCell, crystal};
    use rand::SeedableRng;

    fn fcc(shape: &str, phi: f64, cells: usize) -> System {
        let species = vec![Species {
            name: "s".into(),
            shape: shape.parse().unwrap(),
            rotation: !shape.starts_with("Sphere"),
        }];
        let spec = CrystalSpec {
            cell: UnitCell::fcc(),
            cells: [cells; 3],
            packing_fraction: phi,
        };
        crystal(&spec, species, &[4 * cells.pow(3)]).unwrap()
    }

    fn sizes(translate: f64, rotate: f64) -> MoveSizes {
        MoveSizes {
            translate,
            rotate,
            volume: 0.0,
            shear: 0.0,
        }
    }

    /// Bodies too small to meet sample the ideal Einstein crystal with the
    /// centre of mass held, whose ⟨Σ|uᵢ − ū|²⟩ is 3(N − 1)/(2λ) exactly
    /// (N − 1 free displacements, not N): the spring's Metropolis weight
    /// and its centre-of-mass term are right, within four standard errors.
    #[test]
    fn an_ideal_tethered_crystal_has_the_einstein_spread() {
        let mut system = fcc("Sphere(radius: 0.001)", 1e-6, 2);
        let anchors = Anchors::of(&system);
        let n = system.len() as f64;
        let spring = 50.0;
        let mut tether = Tether::new(&system, &anchors, spring, 0.0).unwrap();
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let size = sizes(1.5 / spring.sqrt(), 0.0);
        for _ in 0..200 {
            tether.sweep(&mut system, &size, &mut rng);
        }
        let samples: Vec<f64> = (0..60000)
            .map(|_| {
                tether.sweep(&mut system, &size, &mut rng);
                tether.spread()
            })
            .collect();
        let estimate = crate::analysis::series::estimate_from(&samples, 0);
        let exact = 3.0 * (n - 1.0) / (2.0 * spring);
        assert!(
            (estimate.mean - exact).abs() < 4.0 * estimate.error,
            "{} ± {} against {exact}",
            estimate.mean,
            estimate.error
        );
        // Without the centre-of-mass term the spread would be 3N/(2λ),
        // more than eight standard errors away.
        assert!(
            3.0 / (2.0 * spring) > 8.0 * estimate.error,
            "{}",
            estimate.error
        );
    }

    /// Cubes and spheroids too small to meet, on orientational springs
    /// κλ: the Metropolis rotations give ⟨Σφ⟩ = −N d ln q/dλ_o of the
    /// quadrature (their symmetries respected: a cube's 24 wells, a
    /// spheroid's axis either way up), within four errors.
    #[test]
    fn tethered_orientations_follow_the_orientational_partition_function() {
        for (shape, twist) in [
            ("Cuboid(a: 0.001, b: 0.001, c: 0.001)", 4.0),
            ("Ellipsoid(a: 0.001, b: 0.001, c: 0.002)", 0.5),
        ] {
            let mut system = fcc(shape, 1e-8, 2);
            let anchors = Anchors::of(&system);
            let n = system.len() as f64;
            let spring = 50.0;
            let mut tether = Tether::new(&system, &anchors, spring, twist).unwrap();
            let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
            let size = sizes(0.2, 0.6 / (spring * twist).sqrt());
            for _ in 0..500 {
                tether.sweep(&mut system, &size, &mut rng);
            }
            let samples: Vec<f64> = (0..40000)
                .map(|_| {
                    tether.sweep(&mut system, &size, &mut rng);
                    tether.misalignment()
                })
                .collect();
            let estimate = crate::analysis::series::estimate_from(&samples, 0);
            let symmetry = Symmetry::of(&shape.parse().unwrap());
            let lambda = spring * twist;
            let q = |l: f64| orientational_partition(&symmetry, l).unwrap();
            let h = 1e-4 * lambda;
            let exact = -n * (q(lambda + h).ln() - q(lambda - h).ln()) / (2.0 * h);
            assert!(
                (estimate.mean - exact).abs() < 4.0 * estimate.error,
                "{shape}: {} ± {} against {exact}",
                estimate.mean,
                estimate.error
            );
        }
    }

    /// Strong springs keep every sample of the ideal crystal apart, weak
    /// ones almost never; a crystal whose bodies sit off their sites is
    /// refused, naming the body.
    #[test]
    fn einstein_samples_overlap_as_the_springs_weaken() {
        let system = fcc("Sphere(radius: 0.5)", 0.5, 2);
        let anchors = Anchors::of(&system);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        assert_eq!(
            overlap_free_samples(&system, &anchors, (1e5, 0.0), 50, &mut rng),
            50
        );
        assert!(overlap_free_samples(&system, &anchors, (1.0, 0.0), 50, &mut rng) < 5);
        let mut shifted = anchors.clone();
        shifted.sites[5] += V3::new(0.9, 0.0, 0.0);
        assert!(matches!(
            Tether::new(&system, &shifted, 1.0, 0.0),
            Err(TetherError::OffSite { body: 5, .. })
        ));
    }
}
