//! What the dynamics keeps per kind of body: the shape, mass, moments and
//! the spins no collision changes, per species, and with polydisperse
//! sizes among other shapes per body.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::{Body, DynamicsOptions, EdmdError, FreeTop};
use crate::geometry::Shape;
use crate::geometry::symmetry::Symmetry;
use crate::state::{Species, System};

type V3 = Vector3<f64>;

/// Per species: what the dynamics needs to know.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Kind {
    pub(super) shape: Shape,
    pub(super) inverse_mass: f64,
    /// Whether the species turns.
    pub(super) rotates: bool,
    /// Principal moments of inertia along the body axes: all equal (the
    /// mean of the body's) for a spherical top, else the body's own.
    pub(super) moments: V3,
    /// The spins of a turning kind that no collision changes.
    pub(super) frozen: FrozenSpin,
}

/// The part of a turning body's spin that collisions never change: every
/// normal of a body of revolution meets its axis, and every normal of a
/// sphere its centre, so no impulse has a torque about them. Such a spin
/// keeps its value for ever, is no degree of freedom of the fluid, and
/// is left out of its temperature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum FrozenSpin {
    /// A body with no axis of revolution: every spin is exchanged.
    None,
    /// A body of revolution about this body axis.
    About(usize),
    /// A sphere: no spin is exchanged.
    All,
}

impl Kind {
    /// The free rotation of a body of this kind with orientation `q` and
    /// lab angular velocity `omega` (zero for kinds that do not turn).
    #[inline]
    pub(super) fn spin(&self, q: &UnitQuaternion<f64>, omega: &V3) -> FreeTop {
        if !self.rotates {
            return FreeTop::new(self.moments, *q, V3::zeros());
        }
        FreeTop::new(self.moments, *q, *omega)
    }

    /// I⁻¹ in the lab frame at orientation `q`.
    pub(super) fn inverse_inertia(&self, q: &UnitQuaternion<f64>) -> Matrix3<f64> {
        if !self.rotates {
            return Matrix3::zeros();
        }
        let r = q.to_rotation_matrix().into_inner();
        r * Matrix3::from_diagonal(&self.moments.map(|m| 1.0 / m)) * r.transpose()
    }

    /// ½ ω·I ω.
    pub(super) fn rotational_energy(&self, q: &UnitQuaternion<f64>, omega: &V3) -> f64 {
        if !self.rotates {
            return 0.0;
        }
        let body = q.inverse_transform_vector(omega);
        0.5 * body.component_mul(&body).dot(&self.moments)
    }

    /// The rotational degrees of freedom collisions exchange: 3, 2 for a
    /// body of revolution, none for a sphere or a kind that does not turn.
    pub(super) fn exchanged_rotations(&self) -> usize {
        match (self.rotates, self.frozen) {
            (false, _) | (true, FrozenSpin::All) => 0,
            (true, FrozenSpin::About(_)) => 2,
            (true, FrozenSpin::None) => 3,
        }
    }

    /// The energy of the spin no collision changes ([`FrozenSpin`]).
    pub(super) fn frozen_energy(&self, q: &UnitQuaternion<f64>, omega: &V3) -> f64 {
        match (self.rotates, self.frozen) {
            (false, _) | (true, FrozenSpin::None) => 0.0,
            (true, FrozenSpin::All) => self.rotational_energy(q, omega),
            (true, FrozenSpin::About(k)) => {
                let spin = q.inverse_transform_vector(omega)[k];
                0.5 * self.moments[k] * spin * spin
            }
        }
    }

    /// `omega_body` (body frame) without the spin no collision changes.
    pub(super) fn exchanged_spin(&self, mut omega_body: V3) -> V3 {
        match self.frozen {
            FrozenSpin::None => {}
            FrozenSpin::About(k) => omega_body[k] = 0.0,
            FrozenSpin::All => omega_body = V3::zeros(),
        }
        omega_body
    }
}

/// `species` with their shapes scaled by `scale` (as they are at 1).
pub(super) fn scaled_species(species: &[Species], scale: f64) -> Vec<Species> {
    species
        .iter()
        .map(|s| Species {
            shape: if scale == 1.0 {
                s.shape
            } else {
                s.shape.scaled(scale)
            },
            ..s.clone()
        })
        .collect()
}

/// [`own_kinds`] for the bodies of `system`.
pub(super) fn body_kinds(
    kinds: &mut Vec<Kind>,
    species: (&[Species], &DynamicsOptions),
    system: &System,
) -> Vec<u32> {
    let of: Vec<u16> = system.particles().iter().map(|p| p.species).collect();
    own_kinds_of(kinds, species, system.sizes(), &of)
}

/// [`own_kinds_of`] for dumped bodies.
pub(super) fn own_kinds(
    kinds: &mut Vec<Kind>,
    species: (&[Species], &DynamicsOptions),
    sizes: Option<&[f64]>,
    bodies: &[Body],
) -> Vec<u32> {
    let of: Vec<u16> = bodies.iter().map(|b| b.species).collect();
    own_kinds_of(kinds, species, sizes, &of)
}

/// Each body's index in `kinds`: its species', except where sizes meet a
/// shape that is not a sphere (then the closed forms of spheres are not
/// used): each body not at its species' size gets a kind of its own
/// appended: its species' shape scaled by its size, the mass kept, and
/// the moments of that shape and mass. Polydisperse spheres alone keep
/// their species' kinds and their radii (`body_radii`).
fn own_kinds_of(
    kinds: &mut Vec<Kind>,
    (species, options): (&[Species], &DynamicsOptions),
    sizes: Option<&[f64]>,
    of: &[u16],
) -> Vec<u32> {
    let shared = || of.iter().map(|&s| u32::from(s)).collect();
    let Some(sizes) = sizes else {
        return shared();
    };
    if species.iter().all(|s| s.shape.is_sphere()) {
        return shared();
    }
    of.iter()
        .zip(sizes)
        .map(|(&s, &f)| {
            if f == 1.0 {
                return u32::from(s);
            }
            let kind = &kinds[s as usize];
            let shape = kind.shape.scaled(f);
            let mass = options.masses.get(s as usize).copied().unwrap_or(1.0);
            let own = Kind {
                shape,
                moments: top_moments(&shape, mass, options.true_inertia),
                ..kind.clone()
            };
            kinds.push(own);
            u32::try_from(kinds.len() - 1).expect("fewer than 2^32 bodies")
        })
        .collect()
}

/// How many rotational degrees of freedom the collisions exchange.
pub(super) fn exchanged_rotations(bodies: &[Body], kinds: &[Kind]) -> usize {
    bodies
        .iter()
        .map(|b| kinds[b.kind as usize].exchanged_rotations())
        .sum()
}

/// The principal moments of inertia (along the body axes) a body of
/// `shape` and `mass` turns with: with `true_inertia` its own, else a
/// spherical top with the mean moment (De Michele, eqs. 4–6).
pub fn top_moments(shape: &Shape, mass: f64, true_inertia: bool) -> V3 {
    let principal = shape.inertia_tensor(mass).diagonal();
    if true_inertia {
        principal
    } else {
        V3::repeat(principal.sum() / 3.0)
    }
}

/// The per-species dynamics data, checked against the options.
pub(super) fn kinds_for(
    species: &[Species],
    options: &DynamicsOptions,
) -> Result<Vec<Kind>, EdmdError> {
    let masses = if options.masses.is_empty() {
        vec![1.0; species.len()]
    } else {
        options.masses.clone()
    };
    if masses.len() != species.len() || masses.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(EdmdError::BadMasses {
            species: species.len(),
            masses: options.masses.clone(),
        });
    }
    let mut kinds = Vec::with_capacity(species.len());
    for (s, &m) in species.iter().zip(&masses) {
        let tensor = s.shape.inertia_tensor(m);
        let off_diagonal = (tensor - Matrix3::from_diagonal(&tensor.diagonal()))
            .abs()
            .max();
        if options.true_inertia && off_diagonal > 1e-12 * tensor.trace() {
            return Err(EdmdError::NotPrincipalAxes(s.name.clone()));
        }
        let moments = top_moments(&s.shape, m, options.true_inertia);
        let frozen = match s.rotation.then(|| Symmetry::of(&s.shape)) {
            Some(Symmetry::Sphere) => FrozenSpin::All,
            Some(Symmetry::Revolution { axis }) => FrozenSpin::About(axis),
            _ => FrozenSpin::None,
        };
        kinds.push(Kind {
            shape: s.shape,
            inverse_mass: 1.0 / m,
            rotates: s.rotation,
            moments,
            frozen,
        });
    }
    Ok(kinds)
}
