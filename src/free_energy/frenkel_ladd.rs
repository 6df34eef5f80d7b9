//! The free energy of a crystal by Frenkel–Ladd thermodynamic
//! integration, the centre of mass held.
//!
//! With Z = ∫ d³ᴺr e^{−βU} and the centre of mass held by δ(ū), the
//! configurational integral of the basin of one labelling is V Z_CM, and
//! the N! labellings count each configuration N_c times (a translation by
//! one of the crystal's N_c lattice vectors relabels it), so
//!
//!   βF = −ln(V / N_c) − ln Z_CM(0),
//!   ln Z_CM(0) = ln Z_E(λ_max) + ln P₀(λ_max) + ∫₀^λ_max ⟨Σ|uᵢ − ū|²⟩_λ dλ,
//!   ln Z_E(λ) = (3(N − 1)/2) ln(π/λ) + (3/2) ln N,
//!
//! with Λ = 1 length unit. The centre-of-mass terms are those Polson,
//! Trizac, Pronk & Frenkel analyse (J. Chem. Phys. 112, 5339 (2000));
//! for a Bravais lattice V/N_c is 1/ρ. P₀ is the probability that the ideal Einstein crystal's
//! bodies do not overlap, sampled directly; the integral runs over
//! x = ln(λ + c), where (λ + c)⟨Σ|uᵢ − ū|²⟩/N is nearly flat (from
//! c g₀ at λ = 0 to 3/2 at large λ, for c = 3/(2 g₀), g₀ the spread per
//! body of the free crystal), by Gauss–Legendre quadrature.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use rand::SeedableRng;
use rand_pcg::Pcg64;

use super::{FreeEnergyError, in_parallel};
use crate::analysis::quadrature::gauss_legendre_on;
use crate::analysis::series::{Estimate, estimate_from};
use crate::mc::einstein::{Anchors, Tether, overlap_free_samples, spring_symmetries};
use crate::mc::einstein_orientation::{WELL_DEPTH, orientational_partition};
use crate::mc::moves::{Counts, MoveSizes};
use crate::mc::tuning::Tuner;
use crate::run::Progress;
use crate::state::System;

/// The acceptance the translation size is tuned toward at every point.
const TARGET_ACCEPTANCE: f64 = 0.35;

/// Sweeps between two tunings of the translation size.
const TUNE_EVERY: u64 = 50;

/// The widest path allowed: λ_max at most this many times c. Beyond it
/// the quadrature points spread too thinly over ln(λ + c).
pub const WIDEST_PATH: f64 = 1e4;

/// The fewest overlap-free samples of the Einstein crystal a path may
/// leave: below, ln P₀ is not measured.
pub const FEWEST_FREE: f64 = 0.01;

/// How the Frenkel–Ladd path is run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrenkelLadd {
    /// Gauss–Legendre points along ln(λ + c).
    pub points: usize,
    /// Sweeps sampled at each point.
    pub sweeps: u64,
    /// Sweeps run at each point before sampling (the size tuned during
    /// the first half).
    pub equilibration: u64,
    /// λ_max, βλ in 1/length² (None: the weakest springs, doubled from
    /// 16 c, whose Einstein crystal is overlap-free in 90 % of samples).
    pub spring: Option<f64>,
    /// κ (length²): the orientational springs are κλ (None: chosen so
    /// that the free crystal's orientations and positions spread alike
    /// per degree of freedom, and deep enough for a finite group's wells
    /// to be told apart at λ_max).
    pub twist: Option<f64>,
    /// Samples of the ideal Einstein crystal for P₀.
    pub einstein_samples: usize,
    /// Seed of every random number drawn.
    pub seed: u64,
}

impl Default for FrenkelLadd {
    fn default() -> Self {
        Self {
            points: 12,
            sweeps: 40_000,
            equilibration: 4_000,
            spring: None,
            twist: None,
            einstein_samples: 20_000,
            seed: 1,
        }
    }
}

/// One point of the path.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PathPoint {
    /// βλ.
    pub spring: f64,
    /// ⟨Σ|uᵢ − ū|²⟩/N at this λ, with its error.
    pub spread: Estimate,
    /// ⟨Σφᵢ⟩/N, the orientations' misalignment, with its error.
    pub misalignment: Estimate,
    /// (λ + c)⟨Σ|uᵢ − ū|² + κ Σφᵢ⟩/N, the integrand over ln(λ + c).
    pub integrand: f64,
    /// Its standard error.
    pub integrand_error: f64,
    /// The Gauss–Legendre weight over ln(λ + c).
    pub weight: f64,
    /// Moves accepted while sampling.
    pub acceptance: f64,
}

/// βF/N of a crystal and how it was found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CrystalFreeEnergy {
    /// βF/N with Λ = 1 length unit.
    pub free_energy_per_particle: f64,
    /// Its standard error.
    pub error: f64,
    /// βF/N − (ln ρΛ³ − 1): the excess over the ideal gas of the same
    /// density in the thermodynamic limit (independent of Λ).
    pub excess_free_energy_per_particle: f64,
    /// Bodies.
    pub n: usize,
    /// Lattice translations N_c that map the crystal onto itself.
    pub lattice_translations: usize,
    /// Packing fraction.
    pub packing_fraction: f64,
    /// N/V.
    pub number_density: f64,
    /// λ_max.
    pub spring_max: f64,
    /// c of x = ln(λ + c).
    pub spring_shift: f64,
    /// κ: the orientational springs are κλ (length²; 0 where no body
    /// turns).
    pub twist: f64,
    /// −ln Z_E(λ_max)/N: the Einstein crystal's term, positions and
    /// orientations.
    pub einstein: f64,
    /// Its orientations' part, −Σᵢ ln qᵢ(κλ_max)/N (SO(3) of volume 1).
    pub einstein_orientations: f64,
    /// P₀: the fraction of Einstein-crystal samples free of overlaps.
    pub overlap_free: f64,
    /// −ln P₀ / N, with its error.
    pub overlap_term: (f64, f64),
    /// −∫ ⟨Σ|uᵢ − ū|²⟩ dλ / N, with its error.
    pub integral_term: (f64, f64),
    /// The path, point by point in λ.
    pub path: Vec<PathPoint>,
}

/// βF/N of `system`, a crystal whose bodies sit near their `anchors`
/// (site and reference orientation i for body i), with
/// `lattice_translations` lattice vectors in its box. `progress` hears of
/// the sweeps as they run; `stop` ends the work early (with an error: a
/// path cut short has no free energy).
pub fn crystal_free_energy(
    system: &System,
    anchors: &Anchors,
    lattice_translations: usize,
    options: &FrenkelLadd,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<CrystalFreeEnergy, FreeEnergyError> {
    options.check()?;
    let n = system.len();
    let nf = n as f64;
    let symmetries = spring_symmetries(system);
    let of_body = |i: usize| &symmetries[system.particles()[i].species as usize];
    // Orientational freedoms the springs bind, per body on average.
    let freedoms = (0..n).map(|i| of_body(i).bound_freedoms()).sum::<usize>() as f64 / nf;
    // The free crystal first: its spreads set κ and c, and it must stay
    // on its lattice.
    let pilot_sweeps = options.equilibration.max(TUNE_EVERY * 4);
    let pilot = run_point(system, anchors, (0.0, 0.0), pilot_sweeps, options, u64::MAX)?;
    let (positions, turns) = (pilot.spread.mean, pilot.misalignment.mean);
    let mut twist = match (options.twist, freedoms > 0.0 && turns > 0.0) {
        (Some(t), _) => t,
        (None, true) => (positions / 3.0) / (turns / freedoms),
        (None, false) => 0.0,
    };
    let shift_for = |twist: f64| 0.5 * (3.0 + freedoms) / (positions + twist * turns);
    let (spring_max, _) = match options.spring {
        Some(spring) => (spring, 1.0),
        None => weakest_overlap_free_springs(system, anchors, shift_for(twist), twist, options),
    };
    // A finite group's wells must be deep enough at λ_max to count apart.
    let edge = (0..n)
        .map(|i| of_body(i).well_edge())
        .fold(f64::INFINITY, f64::min);
    if options.twist.is_none() && freedoms > 0.0 {
        twist = twist.max(1.01 * WELL_DEPTH / (edge * spring_max));
    }
    let shift = shift_for(twist);
    let overlap_free = einstein_overlap_free(system, anchors, (spring_max, twist), options);
    if overlap_free < FEWEST_FREE {
        return Err(FreeEnergyError::SpringsTooWeak {
            spring: spring_max,
            overlap_free,
        });
    }
    if !(spring_max > shift && spring_max <= WIDEST_PATH * shift) {
        return Err(FreeEnergyError::PathOutOfRange {
            spring: spring_max,
            shift,
            widest: WIDEST_PATH,
        });
    }
    let mut einstein_orientations = 0.0;
    for i in 0..n {
        let q = orientational_partition(of_body(i), twist * spring_max).ok_or(
            FreeEnergyError::ShallowWells {
                spring: twist * spring_max,
                edge,
            },
        )?;
        einstein_orientations -= q.ln() / nf;
    }
    let nodes = gauss_legendre_on(options.points, shift.ln(), (spring_max + shift).ln());
    let description = format!("Frenkel–Ladd path, {} points", nodes.len());
    let per_point = options.equilibration + options.sweeps;
    let path = in_parallel(
        &nodes,
        &description,
        per_point,
        progress,
        |k, &(x, weight), done| {
            let spring = x.exp() - shift;
            let sampled = run_point_counted(
                system,
                anchors,
                (spring, twist),
                options,
                k as u64,
                done,
                stop,
            )?;
            let scale = spring + shift;
            Ok(PathPoint {
                spring,
                integrand: scale * sampled.combined.mean,
                integrand_error: scale * sampled.combined.error,
                spread: sampled.spread,
                misalignment: sampled.misalignment,
                weight,
                acceptance: sampled.acceptance,
            })
        },
    )?;
    let (integral, integral_variance) = path.iter().fold((0.0, 0.0), |(s, v), p| {
        (
            s + p.weight * p.integrand,
            v + (p.weight * p.integrand_error).powi(2),
        )
    });
    let volume = system.periodic_box().volume();
    let einstein = einstein_orientations
        - (1.5 * (nf - 1.0) * (std::f64::consts::PI / spring_max).ln() + 1.5 * nf.ln()) / nf;
    let samples = options.einstein_samples as f64;
    let overlap_term = (
        -overlap_free.ln() / nf,
        ((1.0 - overlap_free) / (overlap_free * samples)).sqrt() / nf,
    );
    let integral_term = (-integral, integral_variance.sqrt());
    let free_energy = -(volume / lattice_translations as f64).ln() / nf
        + einstein
        + overlap_term.0
        + integral_term.0;
    let density = nf / volume;
    Ok(CrystalFreeEnergy {
        free_energy_per_particle: free_energy,
        error: overlap_term.1.hypot(integral_term.1),
        excess_free_energy_per_particle: free_energy - (density.ln() - 1.0),
        n,
        lattice_translations,
        packing_fraction: system.packing_fraction(),
        number_density: density,
        spring_max,
        spring_shift: shift,
        twist,
        einstein,
        einstein_orientations,
        overlap_free,
        overlap_term,
        integral_term,
        path,
    })
}

impl FrenkelLadd {
    /// Whether the options can run a path.
    fn check(&self) -> Result<(), FreeEnergyError> {
        let bad = |what: &str| Err(FreeEnergyError::Options(what.to_string()));
        if self.points < 2 {
            return bad("points must be 2 or more");
        }
        if self.sweeps < 100 {
            return bad("sweeps must be 100 or more");
        }
        if self.einstein_samples < 100 {
            return bad("einstein_samples must be 100 or more");
        }
        match (self.spring, self.twist) {
            (Some(s), _) if !(s > 0.0 && s.is_finite()) => {
                bad("spring must be a finite number > 0")
            }
            (_, Some(t)) if !(t > 0.0 && t.is_finite()) => bad("twist must be a finite number > 0"),
            _ => Ok(()),
        }
    }
}

/// What one point's sampling found (per body).
struct Sampled {
    spread: Estimate,
    misalignment: Estimate,
    combined: Estimate,
    acceptance: f64,
}

/// The fraction of `options.einstein_samples` Einstein-crystal samples at
/// `springs` (λ, κ) that are overlap-free.
fn einstein_overlap_free(
    system: &System,
    anchors: &Anchors,
    springs: (f64, f64),
    options: &FrenkelLadd,
) -> f64 {
    let mut rng = Pcg64::seed_from_u64(options.seed ^ 0xe1);
    let free = overlap_free_samples(system, anchors, springs, options.einstein_samples, &mut rng);
    free as f64 / options.einstein_samples as f64
}

/// λ_max doubled from 16 c until 90 % of 1000 Einstein-crystal samples
/// are overlap-free, and P₀ there.
fn weakest_overlap_free_springs(
    system: &System,
    anchors: &Anchors,
    shift: f64,
    twist: f64,
    options: &FrenkelLadd,
) -> (f64, f64) {
    let mut rng = Pcg64::seed_from_u64(options.seed ^ 0xe2);
    let mut spring = 16.0 * shift;
    while spring < WIDEST_PATH * shift / 2.0
        && overlap_free_samples(system, anchors, (spring, twist), 1000, &mut rng) < 900
    {
        spring *= 2.0;
    }
    let free = einstein_overlap_free(system, anchors, (spring, twist), options);
    (spring, free)
}

/// One point of the path: springs (λ, κ), its sweeps run and sampled.
fn run_point_counted(
    system: &System,
    anchors: &Anchors,
    (spring, twist): (f64, f64),
    options: &FrenkelLadd,
    k: u64,
    done: &AtomicU64,
    stop: &AtomicBool,
) -> Result<Sampled, FreeEnergyError> {
    let mut system = system.clone();
    let mut tether = Tether::new(&system, anchors, spring, twist)?;
    let mut rng = Pcg64::seed_from_u64(options.seed.wrapping_add(k.wrapping_mul(0x9e37_79b9)));
    let tuner = Tuner {
        target: TARGET_ACCEPTANCE,
        max_translate: tether.half_spacing(),
    };
    let mut sizes = MoveSizes {
        translate: 0.1 * tether.half_spacing(),
        rotate: 0.1,
        volume: 0.0,
        shear: 0.0,
    };
    let mut window = Counts::default();
    let mut kept = Counts::default();
    let n = system.len() as f64;
    let capacity = options.sweeps as usize;
    let (mut spreads, mut turns) = (Vec::with_capacity(capacity), Vec::with_capacity(capacity));
    for s in 0..options.equilibration + options.sweeps {
        if s % 256 == 0 {
            done.fetch_add(
                256.min(options.equilibration + options.sweeps - s),
                Ordering::Relaxed,
            );
            if stop.load(Ordering::Relaxed) {
                return Err(FreeEnergyError::Stopped);
            }
        }
        let counts = tether.sweep(&mut system, &sizes, &mut rng);
        if s < options.equilibration {
            window += counts;
            if s < options.equilibration / 2 && (s + 1) % TUNE_EVERY == 0 {
                tuner.update(&mut sizes, &window);
                window = Counts::default();
            }
            continue;
        }
        kept += counts;
        tether
            .check_on_sites()
            .map_err(|source| FreeEnergyError::Melted { spring, source })?;
        spreads.push(tether.spread() / n);
        turns.push(tether.misalignment() / n);
    }
    let combined: Vec<f64> = (spreads.iter().zip(&turns))
        .map(|(a, b)| a + twist * b)
        .collect();
    let moves = kept.translate + kept.rotate;
    Ok(Sampled {
        spread: estimate_from(&spreads, 0),
        misalignment: estimate_from(&turns, 0),
        combined: estimate_from(&combined, 0),
        acceptance: moves.rate(),
    })
}

/// The free crystal's run (λ = 0) for κ and c, and the check that it
/// holds.
fn run_point(
    system: &System,
    anchors: &Anchors,
    springs: (f64, f64),
    sweeps: u64,
    options: &FrenkelLadd,
    k: u64,
) -> Result<Sampled, FreeEnergyError> {
    let pilot = FrenkelLadd {
        equilibration: sweeps,
        sweeps,
        ..options.clone()
    };
    run_point_counted(
        system,
        anchors,
        springs,
        &pilot,
        k,
        &AtomicU64::new(0),
        &AtomicBool::new(false),
    )
}
