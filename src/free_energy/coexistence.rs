//! Fluid–crystal coexistence: each phase's free energy at one density
//! (the fluid's from its equation of state, the crystal's by
//! Frenkel–Ladd), its equation of state on a few densities below it, and
//! the pressure where the two chemical potentials cross.
//!
//! On each branch βP(ρ) is fitted by a quadratic in ρ, and
//! βF/N(ρ) = βF/N(ρ₀) + ∫_ρ₀^ρ βP/ρ′² dρ′, βμ = βF/N + βP/ρ. Coexistence
//! is the βP at which βμ_fluid = βμ_crystal. Its errors come from
//! resampling the anchors and every pressure within their errors and
//! solving again.

use std::sync::atomic::{AtomicBool, AtomicU64};

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

use super::fluid::sample_pressure;
use super::{CrystalFreeEnergy, FluidFreeEnergy, FreeEnergyError, in_parallel};
use crate::analysis::quadrature::gauss_legendre_on;
use crate::run::Progress;
use crate::state::System;

/// How coexistence is found.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CoexistenceOptions {
    /// Densities of each branch, from the anchor down.
    pub points: usize,
    /// The lowest density of each branch, as a fraction below its anchor.
    pub span: f64,
    /// Sweeps sampled at each branch density.
    pub sweeps: u64,
    /// Sweeps before sampling.
    pub equilibration: u64,
    /// Resamples for the errors.
    pub resamples: usize,
    /// Seed.
    pub seed: u64,
}

impl Default for CoexistenceOptions {
    fn default() -> Self {
        Self {
            points: 5,
            span: 0.08,
            sweeps: 20_000,
            equilibration: 2_000,
            resamples: 400,
            seed: 1,
        }
    }
}

/// One measured density of a branch.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BranchPoint {
    /// N/V.
    pub density: f64,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// βP with its error.
    pub pressure: (f64, f64),
    /// Global Q₆ after the run.
    pub q6: f64,
}

/// One phase: its anchor and its equation of state.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Branch {
    /// The anchor's density.
    pub anchor_density: f64,
    /// βF/N at the anchor, with its error.
    pub anchor_free_energy: (f64, f64),
    /// βP(ρ) = c₀ + c₁ρ + c₂ρ², fitted to the points.
    pub fit: [f64; 3],
    /// χ² of the fit (about points − 3 if it fits).
    pub chi_squared: f64,
    /// The measured densities.
    pub points: Vec<BranchPoint>,
}

/// The coexisting fluid and crystal.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Coexistence {
    /// βP at coexistence (1/length³).
    pub pressure: f64,
    /// Its standard error.
    pub pressure_error: f64,
    /// βμ at coexistence, with its error.
    pub chemical_potential: (f64, f64),
    /// The fluid's packing fraction at coexistence.
    pub fluid_packing_fraction: f64,
    /// Its standard error.
    pub fluid_packing_fraction_error: f64,
    /// The crystal's packing fraction at coexistence.
    pub solid_packing_fraction: f64,
    /// Its standard error.
    pub solid_packing_fraction_error: f64,
    /// The fluid branch.
    pub fluid: Branch,
    /// The crystal branch.
    pub solid: Branch,
    /// βμ of each branch on a grid of βP over their common range:
    /// (βP, βμ_fluid, βμ_crystal).
    pub chemical_potentials: Vec<(f64, f64, f64)>,
}

impl CoexistenceOptions {
    /// Whether the options can give a branch to fit.
    pub fn check(&self) -> Result<(), FreeEnergyError> {
        if self.points < 3 || !(self.span > 0.0 && self.span < 0.5) {
            return Err(FreeEnergyError::Options(
                "coexistence needs 3 or more points per branch and a span in (0, 0.5)".into(),
            ));
        }
        Ok(())
    }
}

/// The volume of the bodies per body of `system`: φ = ρ × this.
pub fn volume_per_body(system: &System) -> f64 {
    system.packing_fraction() * system.periodic_box().volume() / system.len() as f64
}

/// Coexistence of `fluid` (its free energy found) and `solid` (its
/// free energy found), both branches sampled by expanding each state.
pub fn coexistence(
    fluid: (&System, &FluidFreeEnergy),
    solid: (&System, &CrystalFreeEnergy),
    options: &CoexistenceOptions,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Coexistence, FreeEnergyError> {
    options.check()?;
    let (fluid_system, solid_system) = (fluid.0, solid.0);
    let fluid_branch = branch_below(
        fluid_system,
        (fluid.1.free_energy_per_particle, fluid.1.error),
        Phase::Fluid,
        options,
        progress,
        stop,
    )?;
    let solid_branch = branch_below(
        solid_system,
        (solid.1.free_energy_per_particle, solid.1.error),
        Phase::Crystal,
        options,
        progress,
        stop,
    )?;
    crossed(
        (fluid_branch, volume_per_body(fluid_system)),
        (solid_branch, volume_per_body(solid_system)),
        options,
    )
}

/// Coexistence of two measured branches, each with its bodies' volume
/// per body (to give packing fractions): their crossing, and its errors
/// from the anchors and pressures resampled within their errors.
pub fn crossed(
    fluid: (Branch, f64),
    solid: (Branch, f64),
    options: &CoexistenceOptions,
) -> Result<Coexistence, FreeEnergyError> {
    let ((fluid_branch, fluid_v), (solid_branch, solid_v)) = (fluid, solid);
    let crossing = cross(&fluid_branch, &solid_branch)?;
    // Resampling: anchors and pressures drawn within their errors.
    let mut rng = Pcg64::seed_from_u64(options.seed ^ 0xc0e);
    let mut draws = Vec::with_capacity(options.resamples);
    for _ in 0..options.resamples {
        let f = fluid_branch.resampled(&mut rng)?;
        let s = solid_branch.resampled(&mut rng)?;
        if let Ok(c) = cross(&f, &s) {
            draws.push(c);
        }
    }
    if draws.len() < options.resamples / 2 {
        return Err(FreeEnergyError::NoCrossing(format!(
            "the branches cross in only {} of {} resamples within their errors",
            draws.len(),
            options.resamples
        )));
    }
    let spread = |pick: fn(&Crossing) -> f64| {
        let mean = draws.iter().map(pick).sum::<f64>() / draws.len() as f64;
        (draws.iter().map(|d| (pick(d) - mean).powi(2)).sum::<f64>() / (draws.len() - 1) as f64)
            .sqrt()
    };
    let (low, high) = common_range(&fluid_branch, &solid_branch);
    let chemical_potentials = (0..=40)
        .map(|i| {
            let p = low + (high - low) * i as f64 / 40.0;
            (
                p,
                fluid_branch.mu_at(p).unwrap_or(f64::NAN),
                solid_branch.mu_at(p).unwrap_or(f64::NAN),
            )
        })
        .collect();
    Ok(Coexistence {
        pressure: crossing.pressure,
        pressure_error: spread(|c| c.pressure),
        chemical_potential: (crossing.mu, spread(|c| c.mu)),
        fluid_packing_fraction: crossing.fluid_density * fluid_v,
        fluid_packing_fraction_error: spread(|c| c.fluid_density) * fluid_v,
        solid_packing_fraction: crossing.solid_density * solid_v,
        solid_packing_fraction_error: spread(|c| c.solid_density) * solid_v,
        fluid: fluid_branch,
        solid: solid_branch,
        chemical_potentials,
    })
}

/// Which phase a branch is of: a fluid that orders on it, or a crystal
/// that melts, is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// A fluid.
    Fluid,
    /// A crystal.
    Crystal,
}

impl Phase {
    /// `fluid` or `crystal`.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Fluid => "fluid",
            Phase::Crystal => "crystal",
        }
    }

    /// Added to the seed of each branch point's run.
    fn salt(self) -> u64 {
        match self {
            Phase::Fluid => 1000,
            Phase::Crystal => 2000,
        }
    }
}

/// The branch of `system`'s phase from its density down by
/// `options.span`, at `options.points` densities, each the state expanded
/// and run in NVT; `anchor` is βF/N at the state, with its error.
pub fn branch_below(
    system: &System,
    anchor: (f64, f64),
    phase: Phase,
    options: &CoexistenceOptions,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Branch, FreeEnergyError> {
    let indices: Vec<usize> = (0..options.points).collect();
    let description = format!("{} branch, {} densities", phase.name(), options.points);
    let per_point = options.sweeps + options.equilibration;
    let points = in_parallel(
        &indices,
        &description,
        per_point,
        progress,
        |_, &k, done: &AtomicU64| branch_point(system, phase, options, k, done, stop),
    )?;
    Branch::fitted(number_density(system), anchor, points)
}

/// N/V.
pub(super) fn number_density(system: &System) -> f64 {
    system.len() as f64 / system.periodic_box().volume()
}

/// Point `k` of [`branch_below`]'s branch of `system` (k = 0 the state's
/// own density, the last `options.span` below it), with its own seed:
/// the state expanded to its density and run in NVT, the sweeps counted
/// in `done`. A fluid that orders, or a crystal that melts, is refused.
pub fn branch_point(
    system: &System,
    phase: Phase,
    options: &CoexistenceOptions,
    k: usize,
    done: &AtomicU64,
    stop: &AtomicBool,
) -> Result<BranchPoint, FreeEnergyError> {
    options.check()?;
    if k >= options.points {
        return Err(FreeEnergyError::Options(format!(
            "branch point {k} of a branch of {} points (0 to {})",
            options.points,
            options.points - 1
        )));
    }
    let rho =
        number_density(system) * (1.0 - options.span * k as f64 / (options.points - 1) as f64);
    let eos = super::EquationOfState {
        points: 2,
        sweeps: options.sweeps,
        equilibration: options.equilibration,
        blocks: 20,
        seed: options.seed,
    };
    let (pressure, order, phi) =
        sample_pressure(system, rho, &eos, phase.salt() + k as u64, done, stop)?;
    let q6 = order.q6;
    match (phase, order.ordered()) {
        (Phase::Fluid, true) => Err(FreeEnergyError::Ordered {
            packing_fraction: phi,
            order: format!("global Q₆ = {q6:.3}: the fluid crystallised on its branch"),
        }),
        (Phase::Crystal, false) => Err(FreeEnergyError::MeltedBranch {
            packing_fraction: phi,
            q6,
        }),
        _ => Ok(BranchPoint {
            density: rho,
            packing_fraction: phi,
            pressure: (pressure.mean, pressure.error),
            q6,
        }),
    }
}

/// Where two branches' chemical potentials cross.
#[derive(Debug, Clone, Copy)]
struct Crossing {
    pressure: f64,
    mu: f64,
    fluid_density: f64,
    solid_density: f64,
}

/// The βP range both branches cover.
fn common_range(a: &Branch, b: &Branch) -> (f64, f64) {
    let (a0, a1) = a.pressure_range();
    let (b0, b1) = b.pressure_range();
    (a0.max(b0), a1.min(b1))
}

/// The crossing of βμ_fluid(βP) and βμ_crystal(βP) by bisection over the
/// range both branches cover.
fn cross(fluid: &Branch, solid: &Branch) -> Result<Crossing, FreeEnergyError> {
    let (low, high) = common_range(fluid, solid);
    let ranges = || {
        let (f0, f1) = fluid.pressure_range();
        let (s0, s1) = solid.pressure_range();
        format!("the fluid's branch covers βP {f0:.4}–{f1:.4}, the crystal's {s0:.4}–{s1:.4}")
    };
    if low >= high {
        return Err(FreeEnergyError::NoCrossing(format!(
            "the branches share no pressure: {}",
            ranges()
        )));
    }
    let gap = |p: f64| -> Option<f64> { Some(fluid.mu_at(p)? - solid.mu_at(p)?) };
    let (mut a, mut b) = (low, high);
    let (ga, gb) = (gap(a), gap(b));
    let (Some(mut ga), Some(gb)) = (ga, gb) else {
        return Err(FreeEnergyError::NoCrossing(ranges()));
    };
    if ga.signum() == gb.signum() {
        return Err(FreeEnergyError::NoCrossing(format!(
            "βμ_fluid − βμ_crystal is {ga:.4} and {gb:.4} at the two ends: {}; give a denser \
             fluid or a looser crystal so that the branches bracket coexistence",
            ranges()
        )));
    }
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        let gm = gap(m).ok_or_else(|| FreeEnergyError::NoCrossing(ranges()))?;
        if gm.signum() == ga.signum() {
            a = m;
            ga = gm;
        } else {
            b = m;
        }
        if b - a < 1e-12 * b.abs() {
            break;
        }
    }
    let pressure = 0.5 * (a + b);
    let fluid_density = fluid.density_at(pressure).expect("inside the range");
    Ok(Crossing {
        pressure,
        mu: fluid.mu_at(pressure).expect("inside the range"),
        fluid_density,
        solid_density: solid.density_at(pressure).expect("inside the range"),
    })
}

impl Branch {
    /// The branch with its quadratic fitted (weighted least squares).
    pub fn fitted(
        anchor_density: f64,
        anchor_free_energy: (f64, f64),
        points: Vec<BranchPoint>,
    ) -> Result<Self, FreeEnergyError> {
        let mut ata = nalgebra::Matrix3::<f64>::zeros();
        let mut atb = nalgebra::Vector3::<f64>::zeros();
        for p in &points {
            let w = 1.0 / p.pressure.1.powi(2);
            let row = nalgebra::Vector3::new(1.0, p.density, p.density * p.density);
            ata += w * row * row.transpose();
            atb += w * row * p.pressure.0;
        }
        let c = ata.lu().solve(&atb).ok_or_else(|| {
            FreeEnergyError::NoCrossing("a branch's pressures cannot be fitted".into())
        })?;
        let fit = [c[0], c[1], c[2]];
        let chi_squared = points
            .iter()
            .map(|p| ((p.pressure.0 - poly(&fit, p.density)) / p.pressure.1).powi(2))
            .sum();
        Ok(Self {
            anchor_density,
            anchor_free_energy,
            fit,
            chi_squared,
            points,
        })
    }

    /// The same branch with its anchor and pressures drawn within their
    /// errors, refitted.
    fn resampled(&self, rng: &mut Pcg64) -> Result<Self, FreeEnergyError> {
        let draw = |rng: &mut Pcg64, (m, e): (f64, f64)| {
            Normal::new(m, e.max(1e-300)).map_or(m, |d| d.sample(rng))
        };
        let points = (self.points.iter())
            .map(|p| BranchPoint {
                pressure: (draw(rng, p.pressure), p.pressure.1),
                ..*p
            })
            .collect();
        let anchor = (
            draw(rng, self.anchor_free_energy),
            self.anchor_free_energy.1,
        );
        Self::fitted(self.anchor_density, anchor, points)
    }

    /// The densities the branch was measured over.
    fn density_range(&self) -> (f64, f64) {
        let lo = self
            .points
            .iter()
            .map(|p| p.density)
            .fold(f64::INFINITY, f64::min);
        let hi = self.points.iter().map(|p| p.density).fold(0.0, f64::max);
        (lo, hi)
    }

    /// βP at the ends of the measured densities.
    fn pressure_range(&self) -> (f64, f64) {
        let (lo, hi) = self.density_range();
        (poly(&self.fit, lo), poly(&self.fit, hi))
    }

    /// The density at which the fit gives βP = `pressure`, inside the
    /// measured range (the fit rising through it), by bisection.
    fn density_at(&self, pressure: f64) -> Option<f64> {
        let (mut a, mut b) = self.density_range();
        let f = |rho: f64| poly(&self.fit, rho) - pressure;
        if f(a) > 0.0 || f(b) < 0.0 {
            return None;
        }
        for _ in 0..100 {
            let m = 0.5 * (a + b);
            if f(m) < 0.0 {
                a = m;
            } else {
                b = m;
            }
        }
        Some(0.5 * (a + b))
    }

    /// βF/N at density `rho`: carried from the anchor by ∫ βP/ρ² dρ
    /// (16-point Gauss–Legendre on the fit).
    pub fn free_energy_at(&self, rho: f64) -> f64 {
        let carried: f64 = gauss_legendre_on(16, self.anchor_density, rho)
            .iter()
            .map(|&(x, w)| w * poly(&self.fit, x) / (x * x))
            .sum();
        self.anchor_free_energy.0 + carried
    }

    /// The error of [`Branch::free_energy_at`] from the pressures alone
    /// (the anchor's left out): the fit's covariance carried through the
    /// integral.
    pub fn carried_error(&self, rho: f64) -> f64 {
        // ∫ (c₀ + c₁x + c₂x²)/x² dx is linear in c: its gradient.
        let g: nalgebra::Vector3<f64> = gauss_legendre_on(16, self.anchor_density, rho)
            .iter()
            .map(|&(x, w)| nalgebra::Vector3::new(w / (x * x), w / x, w))
            .sum();
        let mut ata = nalgebra::Matrix3::<f64>::zeros();
        for p in &self.points {
            let row = nalgebra::Vector3::new(1.0, p.density, p.density * p.density);
            ata += row * row.transpose() / p.pressure.1.powi(2);
        }
        ata.try_inverse()
            .map_or(f64::NAN, |cov| (g.transpose() * cov * g)[(0, 0)].sqrt())
    }

    /// βμ at βP = `pressure`: [`Branch::free_energy_at`] the density of
    /// that pressure, plus βP/ρ.
    fn mu_at(&self, pressure: f64) -> Option<f64> {
        let rho = self.density_at(pressure)?;
        Some(self.free_energy_at(rho) + pressure / rho)
    }
}

/// c₀ + c₁x + c₂x².
fn poly(c: &[f64; 3], x: f64) -> f64 {
    c[0] + x * (c[1] + x * c[2])
}
