//! The free energy of a fluid by integrating its equation of state from
//! the ideal gas:
//!
//!   βF/N = ln ρΛ³ − 1 + ∫₀^ρ (Z(ρ′) − 1)/ρ′ dρ′,   Z = βP/ρ,
//!
//! the ideal part that of the thermodynamic limit, Λ = 1 length unit.
//! (Z − 1)/ρ is smooth and finite at ρ = 0 (it tends to B₂), so
//! Gauss–Legendre quadrature in ρ over [0, ρ] converges fast. Each point
//! is the fluid's own state expanded to that density (an expansion of
//! convex bodies' centres never makes an overlap), run by NVT Monte Carlo,
//! its βP from the scale distribution in blocks whose spread gives the
//! error.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::{FreeEnergyError, in_parallel};
use crate::analysis::quadrature::gauss_legendre_on;
use crate::analysis::series::{Estimate, estimate_from};
use crate::mc::moves::{Ensemble, MoveSizes, sweep};
use crate::mc::sdf::Sdf;
use crate::mc::tuning::Tuner;
use crate::run::Progress;
use crate::state::System;

/// Global Q₆ (bonds within 1.4 bounding diameters) above which a state
/// counts as ordered: about 0.5 for a thermal fcc or hcp crystal, 0.35 for
/// simple cubic, under 0.1 for a fluid of a few hundred bodies.
pub const ORDERED_Q6: f64 = 0.3;

/// Nematic order S₂ above which a state of bodies that turn counts as
/// ordered.
pub const ORDERED_S2: f64 = 0.4;

/// The scale distribution's widest window and bins (as the Monte Carlo
/// stages use).
const SDF_WINDOW: (f64, usize) = (0.02, 200);

/// How the equation of state is integrated.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EquationOfState {
    /// Gauss–Legendre points in ρ over [0, ρ].
    pub points: usize,
    /// Sweeps sampled at each point.
    pub sweeps: u64,
    /// Sweeps before sampling (move sizes tuned in the first half).
    pub equilibration: u64,
    /// Blocks the sampled sweeps are cut into, one βP each.
    pub blocks: usize,
    /// Seed of every random number drawn.
    pub seed: u64,
}

impl Default for EquationOfState {
    fn default() -> Self {
        Self {
            points: 8,
            sweeps: 20_000,
            equilibration: 2_000,
            blocks: 20,
            seed: 1,
        }
    }
}

/// One density of the integration.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EosPoint {
    /// N/V.
    pub density: f64,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// βP over the blocks, with its error.
    pub pressure: Estimate,
    /// (Z − 1)/ρ, the integrand.
    pub integrand: f64,
    /// Its standard error.
    pub integrand_error: f64,
    /// The Gauss–Legendre weight over ρ.
    pub weight: f64,
    /// Global Q₆ of the last configuration.
    pub q6: f64,
}

/// βF/N of a fluid and how it was found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FluidFreeEnergy {
    /// βF/N with Λ = 1 length unit.
    pub free_energy_per_particle: f64,
    /// Its standard error.
    pub error: f64,
    /// βF/N − (ln ρΛ³ − 1): the integral of (Z − 1)/ρ.
    pub excess_free_energy_per_particle: f64,
    /// Bodies.
    pub n: usize,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// N/V.
    pub number_density: f64,
    /// βP at the state itself, with its error.
    pub pressure: (f64, f64),
    /// βμ = βF/N + βP/ρ, with its error.
    pub chemical_potential: (f64, f64),
    /// The integration, point by point in ρ.
    pub path: Vec<EosPoint>,
}

/// βF/N of `system`, a fluid: its equation of state sampled at
/// `options.points` densities below its own and at its own, integrated.
/// A state that is ordered, or orders at a point, is refused: the
/// integration would cross a transition.
pub fn fluid_free_energy(
    system: &System,
    options: &EquationOfState,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<FluidFreeEnergy, FreeEnergyError> {
    options.check()?;
    if let Some(order) = ordered(system, BondOrder::of(system)) {
        return Err(FreeEnergyError::Ordered {
            packing_fraction: system.packing_fraction(),
            order,
        });
    }
    let n = system.len() as f64;
    let density = n / system.periodic_box().volume();
    let mut densities = gauss_legendre_on(options.points, 0.0, density);
    densities.push((density, 0.0));
    let description = format!("equation of state, {} densities", densities.len());
    let per_point = options.equilibration + options.sweeps;
    let mut path = in_parallel(
        &densities,
        &description,
        per_point,
        progress,
        |k, &(rho, weight), done| {
            let (pressure, order, phi) =
                sample_pressure(system, rho, options, k as u64, done, stop)?;
            if order.ordered() {
                return Err(FreeEnergyError::Ordered {
                    packing_fraction: phi,
                    order: format!("global Q₆ = {:.3} after its run", order.q6),
                });
            }
            Ok(EosPoint {
                density: rho,
                packing_fraction: phi,
                integrand: (pressure.mean / rho - 1.0) / rho,
                integrand_error: pressure.error / (rho * rho),
                pressure,
                weight,
                q6: order.q6,
            })
        },
    )?;
    let own = path.pop().expect("the state's own point is last");
    let (integral, variance) = path.iter().fold((0.0, 0.0), |(s, v), p| {
        (
            s + p.weight * p.integrand,
            v + (p.weight * p.integrand_error).powi(2),
        )
    });
    let free_energy = density.ln() - 1.0 + integral;
    let error = variance.sqrt();
    let pressure = (own.pressure.mean, own.pressure.error);
    Ok(FluidFreeEnergy {
        free_energy_per_particle: free_energy,
        error,
        excess_free_energy_per_particle: integral,
        n: system.len(),
        packing_fraction: system.packing_fraction(),
        number_density: density,
        pressure,
        chemical_potential: (
            free_energy + pressure.0 / density,
            error.hypot(pressure.1 / density),
        ),
        path,
    })
}

impl EquationOfState {
    fn check(&self) -> Result<(), FreeEnergyError> {
        let bad = |what: &str| Err(FreeEnergyError::Options(what.to_string()));
        if self.points < 2 {
            return bad("points must be 2 or more");
        }
        if self.blocks < 4 {
            return bad("blocks must be 4 or more");
        }
        if self.sweeps < 10 * self.blocks as u64 {
            return bad("sweeps must be at least 10 per block");
        }
        Ok(())
    }
}

/// Global Q₆ of a state's centres and the bonds it is taken over.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct BondOrder {
    /// Q₆ from the q₆ₘ summed over every bond.
    pub q6: f64,
    /// The bonds (pairs within 1.4 of the largest bounding diameter).
    pub bonds: usize,
}

impl BondOrder {
    /// Global Q₆ of `system`'s centres, bonds within 1.4 of the largest
    /// bounding diameter.
    pub fn of(system: &System) -> Self {
        use crate::analysis::structure::{neighbours, steinhardt};
        let centres: Vec<Vector3<f64>> = system.positions.iter().copied().collect();
        let bonds = neighbours(
            system.periodic_box(),
            &centres,
            1.4 * system.interaction_range(),
        );
        Self {
            q6: steinhardt(&bonds, &[6])[0].global,
            bonds: bonds.iter().map(Vec::len).sum::<usize>() / 2,
        }
    }

    /// Whether it says the state is ordered: Q₆ above [`ORDERED_Q6`] and
    /// above five times 1/√bonds, the Q₆ that bonds of random directions
    /// give (|Σ Y₆ₘ|² of n random bonds is n/4π for each m), so that the
    /// few bonds of a dilute state never read as order.
    pub fn ordered(&self) -> bool {
        self.q6 > ORDERED_Q6 && self.q6 * (self.bonds as f64).sqrt() > 5.0
    }
}

/// Why `system` counts as ordered (bond order `q6`, or the nematic order
/// of a species that turns), or None.
fn ordered(system: &System, order: BondOrder) -> Option<String> {
    if order.ordered() {
        return Some(format!("global Q₆ = {:.3}", order.q6));
    }
    for (s, species) in system.species().iter().enumerate() {
        let Some(axis) = species.order_axis() else {
            continue;
        };
        let axes = (system.particles().iter())
            .filter(|p| p.species as usize == s)
            .map(|p| p.orientation * axis);
        if let Some(order) = crate::analysis::order::nematic_order(axes)
            && order > ORDERED_S2
        {
            return Some(format!(
                "nematic order S₂ = {order:.3} of `{}`",
                species.name
            ));
        }
    }
    None
}

/// βP of `system` expanded to density `rho` (its own, or lower) by NVT
/// Monte Carlo, with the bond order and φ of the last configuration.
pub(super) fn sample_pressure(
    system: &System,
    rho: f64,
    options: &EquationOfState,
    k: u64,
    done: &AtomicU64,
    stop: &AtomicBool,
) -> Result<(Estimate, BondOrder, f64), FreeEnergyError> {
    let mut system = system.clone();
    let n = system.len() as f64;
    let stretch = (n / system.periodic_box().volume() / rho).cbrt();
    if stretch > 1.0 + 1e-12 {
        let lengths = system.periodic_box().lengths() * stretch;
        if !system.rescale_allowing_overlaps(lengths) || system.first_overlap().is_some() {
            return Err(FreeEnergyError::Options(format!(
                "the state cannot be expanded to density {rho}"
            )));
        }
    }
    let mut rng = Pcg64::seed_from_u64(options.seed.wrapping_add(k.wrapping_mul(0x9e37_79b9)));
    let lengths = system.periodic_box().lengths();
    let tuner = Tuner {
        target: 0.3,
        max_translate: 0.5 * lengths.min(),
    };
    let mut sizes = MoveSizes {
        translate: 0.2 * system.interaction_range(),
        rotate: 0.2,
        volume: 0.01,
        shear: 0.01,
    };
    let tick = |sweeps: u64| -> Result<(), FreeEnergyError> {
        done.fetch_add(sweeps, Ordering::Relaxed);
        match stop.load(Ordering::Relaxed) {
            true => Err(FreeEnergyError::Stopped),
            false => Ok(()),
        }
    };
    let half = options.equilibration / 2;
    tuner.equilibrate(&mut system, &mut sizes, &Ensemble::Nvt, half, 50, &mut rng);
    for _ in half..options.equilibration {
        sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
    }
    tick(options.equilibration)?;
    let per_block = options.sweeps / options.blocks as u64;
    let mut pressures = Vec::with_capacity(options.blocks);
    for _ in 0..options.blocks {
        let mut sdf = Sdf::new(SDF_WINDOW.0, SDF_WINDOW.1);
        for s in 0..per_block {
            sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
            if s % 2 == 1 {
                sdf.add(&system);
            }
        }
        pressures.push(sdf.pressure().unwrap_or(f64::NAN));
        tick(per_block)?;
    }
    Ok((
        estimate_from(&pressures, 0),
        BondOrder::of(&system),
        system.packing_fraction(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::Species;
    use crate::state::crystal::{CrystalSpec, UnitCell, crystal};

    /// A dilute gas's few bonds give Q₆ about 1/√bonds (bonds of random
    /// directions), above [`ORDERED_Q6`] in some states, yet never
    /// ordered; an fcc crystal is.
    #[test]
    fn a_dilute_gas_is_never_ordered_by_its_few_bonds() {
        let species = vec![Species {
            name: "s".into(),
            shape: "Sphere(radius: 0.5)".parse().unwrap(),
            rotation: false,
        }];
        // 256 spheres at φ ≈ 0.01, where the fluid path's first point lies.
        let side = (256.0 * std::f64::consts::PI / 6.0 / 0.0098f64).cbrt();
        let mut rng = Pcg64::seed_from_u64(3);
        let (mut scaled, mut over_threshold) = (0.0, 0);
        let states = 60;
        for _ in 0..states {
            let box_ = crate::space::PeriodicBox::new(Vector3::repeat(side)).unwrap();
            let gas = crate::state::start::random_insertion(
                box_,
                species.clone(),
                &[256],
                1_000_000,
                &mut rng,
            )
            .unwrap();
            let order = BondOrder::of(&gas);
            assert!(!order.ordered(), "{order:?}");
            scaled += order.q6 * (order.bonds as f64).sqrt() / states as f64;
            over_threshold += usize::from(order.q6 > ORDERED_Q6);
        }
        // ⟨χ₁₃⟩/√13 = 0.981 for bonds of random directions.
        assert!((scaled - 0.98).abs() < 0.1, "{scaled}");
        assert!(over_threshold > 0, "no state above the bare threshold");
        let spec = CrystalSpec {
            cell: UnitCell::fcc(),
            cells: [4, 4, 4],
            packing_fraction: 0.5,
        };
        let solid = crystal(&spec, species, &[256]).unwrap();
        assert!(BondOrder::of(&solid).ordered());
    }
}
