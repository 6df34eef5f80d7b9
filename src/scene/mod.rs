//! The RON scene (DESIGN.md contract): typed by serde, unknown fields
//! rejected, then validated field by field; every error names the field
//! path and its line in the text.

pub mod outline;
pub mod plan;

use serde::{Deserialize, Serialize};

use crate::geometry::Shape;
use outline::Outline;

/// A scene: what to simulate, in which stages, logged where.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Random seed (the command line's `--seed` overrides it).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Box edges (the starting box; compression and NPT change it).
    #[serde(rename = "box")]
    pub box_lengths: (f64, f64, f64),
    /// Axes closed by hard walls (not available in this version).
    #[serde(default)]
    pub walls: Vec<Axis>,
    /// Kinds of particle.
    pub species: Vec<SpeciesSpec>,
    /// How the first state is made.
    #[serde(default)]
    pub start: Start,
    /// What runs, in order; each stage starts from the state the previous
    /// one ended with.
    pub stages: Vec<Stage>,
    /// The MCAP log.
    #[serde(default)]
    pub log: LogSpec,
    /// Accuracy knobs of the event-driven dynamics.
    #[serde(default)]
    pub accuracy: Accuracy,
}

/// Sweeps a compression may take when the scene does not say.
pub const DEFAULT_COMPRESS_SWEEPS: u64 = 1_000_000;

/// The most particles a scene may hold: about 1 kB each in the drivers,
/// the log and its frames, so 10 GB at this bound.
pub const MAX_PARTICLES: usize = 10_000_000;

/// The range of masses, temperatures (kT) and pressures (βP) a scene may give: within it,
/// sums over every particle such as N kT, and speeds sqrt(kT/m), stay far
/// inside double precision.
pub const VALUE_RANGE: (f64, f64) = (1e-100, 1e100);

/// The most `/stats` messages, and frames, one stage may write.
pub const MAX_STATS_PER_STAGE: f64 = 1e7;
/// See [`MAX_STATS_PER_STAGE`].
pub const MAX_FRAMES_PER_STAGE: f64 = 1e6;

/// The most times the smallest body size (cube root of its volume) a body may travel, at the
/// thermal speed, in one dynamics stage (about as many collisions per
/// body): beyond it a stage would not end in any real time.
pub const MAX_SIZES_TRAVELLED: f64 = 1e12;

fn default_seed() -> u64 {
    1
}

/// A box axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Axis {
    /// x
    X,
    /// y
    Y,
    /// z
    Z,
}

/// A kind of particle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Species")]
pub struct SpeciesSpec {
    /// Unique name.
    pub name: String,
    /// Shape, in the scene spelling (`Ellipsoid(a: 1.0, b: 0.5, c: 0.5)`).
    pub shape: Shape,
    /// Number of particles.
    pub count: usize,
    /// Mass (EDMD); 1 by default.
    #[serde(default = "one")]
    pub mass: f64,
    /// Whether orientations change; `false` freezes them.
    #[serde(default = "yes")]
    pub rotation: bool,
}

fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}

/// The first state.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub enum Start {
    /// Particles on a simple lattice filling the box, random orientations.
    #[default]
    Lattice,
    /// Random sequential insertion, random orientations.
    Random,
    /// The last complete state of an earlier log.
    Resume(String),
    /// A lattice as `Lattice`, the species in layers along the axis in
    /// scene order (the first at the low end): two species released from
    /// the two halves of a box.
    Layered(Axis),
}

/// One stage of a scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Stage {
    /// Monte Carlo compression to a packing fraction.
    Compress {
        /// Target φ (or give `pressure`).
        #[serde(default)]
        packing_fraction: Option<f64>,
        /// Target βP: compression to the packing fraction at which the
        /// measured pressure is this (or give `packing_fraction`).
        #[serde(default)]
        pressure: Option<f64>,
        /// Give up after this many sweeps (default 10⁶).
        #[serde(default)]
        max_sweeps: Option<u64>,
        /// A jam short of the target ends the stage successfully at the
        /// packing fraction reached (default: it is an error).
        #[serde(default)]
        until_jammed: bool,
    },
    /// Metropolis Monte Carlo.
    MonteCarlo {
        /// NVT or NPT.
        ensemble: Ensemble,
        /// Sweeps (N trial moves each, plus one box move in NPT).
        sweeps: u64,
        /// Sweeps at the start during which move sizes are tuned toward
        /// 30 % acceptance; frozen after (default: a fifth of `sweeps`).
        #[serde(default)]
        tune_sweeps: Option<u64>,
    },
    /// Event-driven molecular dynamics.
    Dynamics {
        /// Simulated time to run.
        duration: f64,
        /// kT of the Maxwell–Boltzmann velocities (default 1).
        #[serde(default = "one")]
        temperature: f64,
        /// Simulated time between `/stats` messages (default duration/100).
        #[serde(default)]
        stats_every: Option<f64>,
        /// Simulated time between frames (default duration/20).
        #[serde(default)]
        frames_every: Option<f64>,
        /// Bodies of revolution turn as symmetric tops with their true
        /// moments of inertia (default: spherical tops).
        #[serde(default)]
        true_inertia: bool,
        /// Report the mean-squared displacement in `/stats`.
        #[serde(default)]
        msd: bool,
        /// Report the orientational correlation C₂(t) in `/stats`.
        #[serde(default)]
        c2: bool,
    },
}

impl Stage {
    /// How long a Monte Carlo stage tunes its move sizes: `tune_sweeps`
    /// if given; else an NVT stage its first fifth, an NPT stage its first
    /// fifth and on until its density settles. None for other stages.
    pub fn tuning_span(&self) -> Option<crate::mc::tuning::TuningSpan> {
        use crate::mc::tuning::TuningSpan;
        let Stage::MonteCarlo {
            ensemble,
            sweeps,
            tune_sweeps,
        } = self
        else {
            return None;
        };
        Some(match (tune_sweeps, ensemble) {
            (Some(t), _) => TuningSpan::Fixed(*t),
            (None, Ensemble::Npt { .. }) => TuningSpan::UntilSettled {
                at_least: sweeps / 5,
                at_most: *sweeps,
            },
            (None, Ensemble::Nvt) => TuningSpan::Fixed(sweeps / 5),
        })
    }

    /// The `/stats` name of the stage.
    pub fn kind(&self) -> &'static str {
        match self {
            Stage::Compress { .. } => "compress",
            Stage::MonteCarlo { .. } => "monte_carlo",
            Stage::Dynamics { .. } => "dynamics",
        }
    }
}

/// A Monte Carlo ensemble.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Ensemble {
    /// Fixed volume.
    Nvt,
    /// Fixed pressure βP.
    Npt {
        /// βP (1/length³).
        pressure: f64,
        /// Box moves one axis at a time.
        #[serde(default)]
        anisotropic: bool,
    },
}

/// Where and how often to log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Log")]
pub struct LogSpec {
    /// The MCAP file (the command line's `--out` overrides it).
    #[serde(default = "default_log_path")]
    pub path: String,
    /// Sweeps between `/stats` messages in Monte Carlo stages.
    #[serde(default = "default_stats_every")]
    pub stats_every: u64,
    /// Sweeps between frames (`/scene`, `/state`) in Monte Carlo stages.
    #[serde(default = "default_frames_every")]
    pub frames_every: u64,
}

fn default_log_path() -> String {
    "run.mcap".into()
}
fn default_stats_every() -> u64 {
    100
}
fn default_frames_every() -> u64 {
    1000
}

impl Default for LogSpec {
    fn default() -> Self {
        Self {
            path: default_log_path(),
            stats_every: default_stats_every(),
            frames_every: default_frames_every(),
        }
    }
}

/// Accuracy knobs of the event-driven dynamics (defaults as in
/// [`crate::edmd::predict::PredictorOptions`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accuracy {
    /// ε_d of De Michele's eq. (39): the distance below which contact
    /// searches step finely and look for grazing contacts.
    #[serde(default = "default_grazing")]
    pub grazing_threshold: f64,
    /// A contact is accepted when the distance is within this of zero.
    #[serde(default = "default_contact_tolerance")]
    pub contact_tolerance: f64,
    /// Newton–Raphson convergence, relative to the smallest semi-axis.
    #[serde(default = "default_newton_tolerance")]
    pub newton_tolerance: f64,
    /// How the dynamics finds the bodies a body may meet.
    #[serde(default)]
    pub neighbours: Neighbours,
}

/// The dynamics' neighbour structure (`accuracy.neighbours`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum Neighbours {
    /// What [`crate::edmd::automatic_neighbour_shell`] picks for the
    /// species at the packing fraction the dynamics starts at.
    #[default]
    Auto,
    /// Linked cells with cell-crossing events.
    Cells,
    /// Neighbour lists: bounding spheres grown by `shell` (a length).
    Lists {
        /// The shell Δ.
        shell: f64,
    },
}

fn default_grazing() -> f64 {
    crate::edmd::predict::PredictorOptions::default().grazing_threshold
}
fn default_contact_tolerance() -> f64 {
    crate::edmd::predict::PredictorOptions::default().contact_tolerance
}
fn default_newton_tolerance() -> f64 {
    crate::geometry::newton::NewtonOptions::default().tolerance
}

impl Default for Accuracy {
    fn default() -> Self {
        Self {
            grazing_threshold: default_grazing(),
            contact_tolerance: default_contact_tolerance(),
            newton_tolerance: default_newton_tolerance(),
            neighbours: Neighbours::Auto,
        }
    }
}

/// What is wrong with a scene, and where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// The text is not a scene (syntax, unknown or missing fields, types,
    /// shapes with bad sizes).
    #[error("line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based.
        line: usize,
        /// 1-based.
        column: usize,
        /// What the parser says.
        message: String,
    },
    /// A field holds a value the scene cannot use.
    #[error("{}{field}: {message}", line.map(|l| format!("line {l}: ")).unwrap_or_default())]
    Invalid {
        /// Path of the field, e.g. `species[1].count`.
        field: String,
        /// 1-based line of the field (or of the nearest enclosing one).
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
}

impl Scene {
    /// Parses and validates a scene.
    pub fn parse(text: &str) -> Result<Scene, SceneError> {
        let options = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        let scene: Scene = options.from_str(text).map_err(|e| SceneError::Syntax {
            line: e.span.start.line,
            column: e.span.start.col,
            message: e.code.to_string(),
        })?;
        let outline = Outline::of(text);
        scene
            .validate()
            .map_err(|(field, message)| SceneError::Invalid {
                line: outline.line_of(&field),
                field,
                message,
            })?;
        Ok(scene)
    }

    /// The scene as RON (what the log's metadata records).
    pub fn to_ron(&self) -> String {
        // Optional values written bare, as a scene file writes them (and
        // as `parse` reads them).
        let config = ron::ser::PrettyConfig::default()
            .struct_names(true)
            .extensions(ron::extensions::Extensions::IMPLICIT_SOME);
        ron::ser::to_string_pretty(self, config).expect("a scene always serialises")
    }

    /// Total number of particles.
    pub fn particle_count(&self) -> usize {
        self.species.iter().map(|s| s.count).sum()
    }

    /// Σ vᵢ over all particles.
    pub fn particle_volume(&self) -> f64 {
        self.species
            .iter()
            .map(|s| s.count as f64 * s.shape.volume())
            .sum()
    }

    /// The largest bounding radius of any species.
    pub fn largest_bounding_radius(&self) -> f64 {
        self.species
            .iter()
            .map(|s| s.shape.bounding_radius())
            .fold(0.0, f64::max)
    }

    /// The densest packing fraction the species can reach: the densest
    /// known packings of equal spheres (π/√18) and of equal ellipsoids
    /// (0.7707, Donev et al. 2004); below 1 otherwise.
    pub fn densest_packing_fraction(&self) -> f64 {
        let first = &self.species[0].shape;
        let all_same = self.species.iter().all(|s| s.shape == *first);
        match first {
            Shape::Sphere(_) if all_same => std::f64::consts::PI / 18f64.sqrt(),
            Shape::Ellipsoid(_) if all_same => 0.7707,
            _ => 1.0,
        }
    }

    /// The species as the Monte Carlo driver takes them (spheres never
    /// turn).
    pub fn mc_species(&self) -> Vec<crate::state::Species> {
        self.species
            .iter()
            .map(|s| crate::state::Species {
                name: s.name.clone(),
                shape: s.shape,
                rotation: s.rotation && !s.shape.is_sphere(),
            })
            .collect()
    }

    /// The box edges.
    pub fn box_vector(&self) -> nalgebra::Vector3<f64> {
        let (x, y, z) = self.box_lengths;
        nalgebra::Vector3::new(x, y, z)
    }

    /// The dynamics' neighbour shell (`None`: cells), as
    /// `accuracy.neighbours` asks, for a dynamics stage that starts at
    /// `packing_fraction`.
    pub fn neighbour_shell(&self, packing_fraction: f64) -> Option<f64> {
        match self.accuracy.neighbours {
            Neighbours::Auto => {
                crate::edmd::automatic_neighbour_shell(&self.mc_species(), packing_fraction)
            }
            Neighbours::Cells => None,
            Neighbours::Lists { shell } => Some(shell),
        }
    }

    /// Per axis: whether the scene closes it with hard walls.
    pub fn wall_axes(&self) -> [bool; 3] {
        let mut w = [false; 3];
        for a in &self.walls {
            w[*a as usize] = true;
        }
        w
    }

    /// The starting box, with its walls.
    pub fn periodic_box(&self) -> crate::space::PeriodicBox {
        crate::space::PeriodicBox::new(self.box_vector())
            .expect("validated edges")
            .with_walls(self.wall_axes())
    }

    /// Checks every field; on failure the field path and what is wrong.
    /// Whether `sweeps` sweeps of Monte Carlo stage `i` write at most
    /// [`MAX_STATS_PER_STAGE`] `/stats` messages and
    /// [`MAX_FRAMES_PER_STAGE`] frames.
    fn check_messages(&self, i: usize, sweeps: u64) -> Result<(), (String, String)> {
        for (name, every, most) in [
            ("log.stats_every", self.log.stats_every, MAX_STATS_PER_STAGE),
            (
                "log.frames_every",
                self.log.frames_every,
                MAX_FRAMES_PER_STAGE,
            ),
        ] {
            let messages = sweeps as f64 / every.max(1) as f64;
            if messages > most {
                return Err((
                    name.to_string(),
                    format!(
                        "every {every} sweeps would write {messages:.3e} messages in the {sweeps} sweeps of stages[{i}]: at most {most:e} per stage"
                    ),
                ));
            }
        }
        Ok(())
    }

    fn validate(&self) -> Result<(), (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        let (x, y, z) = self.box_lengths;
        if ![x, y, z].iter().all(|l| l.is_finite() && *l > 0.0) {
            return bad(
                "box",
                format!("edges must be finite and > 0, got ({x}, {y}, {z})"),
            );
        }
        for (i, a) in self.walls.iter().enumerate() {
            if self.walls[..i].contains(a) {
                return bad("walls", format!("{a:?} is listed twice"));
            }
        }
        if self.species.is_empty() {
            return bad("species", "at least one species is needed".into());
        }
        for (i, s) in self.species.iter().enumerate() {
            let f = |name: &str| format!("species[{i}].{name}");
            if s.name.trim().is_empty() {
                return bad(&f("name"), "must not be empty".into());
            }
            if self.species[..i].iter().any(|t| t.name == s.name) {
                return bad(&f("name"), format!("\"{}\" is used twice", s.name));
            }
            if s.count == 0 {
                return bad(&f("count"), "must be at least 1".into());
            }
            let so_far: usize = self.species[..i].iter().map(|t| t.count).sum();
            if s.count > MAX_PARTICLES - so_far {
                return bad(
                    &f("count"),
                    format!(
                        "{} particles with those before: at most {MAX_PARTICLES} in all (about 1 kB of memory each)",
                        (so_far as u128) + s.count as u128
                    ),
                );
            }
            let (low, high) = VALUE_RANGE;
            if !(s.mass >= low && s.mass <= high) {
                return bad(
                    &f("mass"),
                    format!("must lie in [{low:e}, {high:e}], got {:e}", s.mass),
                );
            }
        }
        if self.species.len() > u16::MAX as usize {
            return bad("species", format!("at most {} species", u16::MAX));
        }
        let n = self.particle_count();
        if n < 2 {
            return bad(
                "species",
                "at least 2 particles are needed in all (counts sum to 1)".into(),
            );
        }
        let diameter = 2.0 * self.largest_bounding_radius();
        let shortest = x.min(y).min(z);
        if shortest < 2.0 * diameter {
            return bad(
                "box",
                format!(
                    "the shortest edge {shortest} must be at least twice the largest bounding diameter {diameter} (minimum image)"
                ),
            );
        }
        let phi0 = self.particle_volume() / (x * y * z);
        match &self.start {
            Start::Lattice | Start::Layered(_) => {
                let plan =
                    crate::state::start::lattice_plan(&self.box_vector(), &self.mc_species(), n);
                if plan.sites.iter().product::<usize>() < n {
                    let w = plan.spacing;
                    return bad(
                        "start",
                        format!(
                            "a lattice in this box holds {} particles (sites {:.4} x {:.4} x {:.4} apart, the bodies aligned), the species have {n}: enlarge the box",
                            plan.capacity, w.x, w.y, w.z
                        ),
                    );
                }
            }
            Start::Random => {
                if phi0 > 0.25 {
                    return bad(
                        "start",
                        format!(
                            "random insertion at packing fraction {phi0:.3} would rarely succeed (at most 0.25): enlarge the box and compress"
                        ),
                    );
                }
            }
            Start::Resume(path) => {
                if path.trim().is_empty() {
                    return bad("start", "Resume needs the path of a log".into());
                }
            }
        }
        if self.stages.iter().any(|st| {
            matches!(
                st,
                Stage::MonteCarlo {
                    ensemble: Ensemble::Npt {
                        anisotropic: true,
                        ..
                    },
                    ..
                }
            )
        }) && self.walls.len() == 3
        {
            return bad(
                "walls",
                "a box closed by walls on every axis has no periodic direction for per-axis box moves".into(),
            );
        }
        if self.stages.is_empty() {
            return bad("stages", "at least one stage is needed".into());
        }
        let densest = self.densest_packing_fraction();
        // The packing fraction as far as it is known before running: the
        // start's, until a stage at fixed pressure makes it unknown.
        let mut known_phi = match self.start {
            Start::Resume(_) => None,
            _ => Some(phi0),
        };
        for (i, st) in self.stages.iter().enumerate() {
            let f = |name: &str| format!("stages[{i}].{name}");
            match st {
                Stage::Compress {
                    packing_fraction,
                    pressure,
                    max_sweeps,
                    until_jammed,
                } => {
                    if *max_sweeps == Some(0) {
                        return bad(&f("max_sweeps"), "must be at least 1".into());
                    }
                    self.check_messages(i, max_sweeps.unwrap_or(DEFAULT_COMPRESS_SWEEPS))?;
                    let target = match (packing_fraction, pressure) {
                        (Some(_), Some(_)) | (None, None) => {
                            return bad(
                                &f("packing_fraction"),
                                "give exactly one of packing_fraction and pressure".into(),
                            );
                        }
                        (None, Some(p)) => {
                            let (low, high) = VALUE_RANGE;
                            if !(*p >= low && *p <= high) {
                                return bad(
                                    &f("pressure"),
                                    format!("must lie in [{low:e}, {high:e}]; got {p}"),
                                );
                            }
                            if *until_jammed {
                                return bad(
                                    &f("until_jammed"),
                                    "applies to a packing_fraction target, not a pressure".into(),
                                );
                            }
                            known_phi = None;
                            continue;
                        }
                        (Some(target), None) => target,
                    };
                    if !(target.is_finite() && *target > 0.0 && *target < densest) {
                        return bad(
                            &f("packing_fraction"),
                            format!(
                                "must lie in (0, {densest:.4}), the densest packing of these shapes; got {target}"
                            ),
                        );
                    }
                    if let Some(phi) = known_phi
                        && *target < phi
                    {
                        return bad(
                            &f("packing_fraction"),
                            format!(
                                "{target} is below the packing fraction {phi:.4} the stage starts from: nothing to compress"
                            ),
                        );
                    }
                    // The box edge at the target must still allow the minimum image.
                    let scale = (phi0 / target).cbrt();
                    if shortest * scale < 2.0 * diameter {
                        return bad(
                            &f("packing_fraction"),
                            format!(
                                "at {target} the shortest box edge would be {:.4}, below twice the largest bounding diameter {diameter:.4}: use more particles",
                                shortest * scale
                            ),
                        );
                    }
                    known_phi = Some(*target);
                }
                Stage::MonteCarlo {
                    ensemble,
                    sweeps,
                    tune_sweeps,
                } => {
                    if *sweeps == 0 {
                        return bad(&f("sweeps"), "must be at least 1".into());
                    }
                    self.check_messages(i, *sweeps)?;
                    if let Some(t) = tune_sweeps
                        && t > sweeps
                    {
                        return bad(
                            &f("tune_sweeps"),
                            format!("{t} is more than the stage's {sweeps} sweeps"),
                        );
                    }
                    if let Ensemble::Npt { pressure, .. } = ensemble {
                        let (low, high) = VALUE_RANGE;
                        if !(*pressure >= low && *pressure <= high) {
                            return bad(
                                &f("ensemble.pressure"),
                                format!("must lie in [{low:e}, {high:e}], got {pressure:e}"),
                            );
                        }
                        known_phi = None;
                    }
                }
                Stage::Dynamics {
                    duration,
                    temperature,
                    stats_every,
                    frames_every,
                    true_inertia,
                    ..
                } => {
                    if !(duration.is_finite() && *duration > 0.0) {
                        return bad(
                            &f("duration"),
                            format!("must be finite and > 0, got {duration}"),
                        );
                    }
                    let (low, high) = VALUE_RANGE;
                    if !(*temperature >= low && *temperature <= high) {
                        return bad(
                            &f("temperature"),
                            format!("must lie in [{low:e}, {high:e}], got {temperature:e}"),
                        );
                    }
                    for (name, v, most) in [
                        ("stats_every", stats_every, MAX_STATS_PER_STAGE),
                        ("frames_every", frames_every, MAX_FRAMES_PER_STAGE),
                    ] {
                        if let Some(v) = v {
                            if !(v.is_finite() && *v > 0.0) {
                                return bad(&f(name), format!("must be finite and > 0, got {v}"));
                            }
                            if duration / v > most {
                                return bad(
                                    &f(name),
                                    format!(
                                        "{v:e} would write {:.3e} messages over the duration {duration}: at most {most:e} per stage",
                                        duration / v
                                    ),
                                );
                            }
                        }
                    }
                    // The fastest thermal speed against the smallest body.
                    let lightest = self.species.iter().map(|s| s.mass).fold(f64::MAX, f64::min);
                    let smallest = self
                        .species
                        .iter()
                        .map(|s| s.shape.volume().cbrt())
                        .fold(f64::MAX, f64::min);
                    let travelled = duration * (temperature / lightest).sqrt() / smallest;
                    if travelled.is_nan() || travelled > MAX_SIZES_TRAVELLED {
                        return bad(
                            &f("duration"),
                            format!(
                                "at kT = {temperature:e} the lightest body (mass {lightest:e}) would travel {travelled:.3e} times the smallest body size {smallest:e} (cube root of its volume): at most {MAX_SIZES_TRAVELLED:e} in one stage"
                            ),
                        );
                    }
                    if *true_inertia
                        && let Some(s) = self
                            .species
                            .iter()
                            .find(|s| s.rotation && s.shape.symmetric_top_axis().is_none())
                    {
                        return bad(
                            &f("true_inertia"),
                            format!(
                                "species \"{}\" ({}) has three different principal moments; true inertia is available for bodies of revolution only",
                                s.name, s.shape
                            ),
                        );
                    }
                }
            }
        }
        if self.log.path.trim().is_empty() {
            return bad("log.path", "must not be empty".into());
        }
        if self.log.path.ends_with('/') || self.log.path.ends_with(std::path::MAIN_SEPARATOR) {
            return bad(
                "log.path",
                format!(
                    "\"{}\" ends in a separator: a log path names a file",
                    self.log.path
                ),
            );
        }
        if self.log.stats_every == 0 {
            return bad("log.stats_every", "must be at least 1 sweep".into());
        }
        if self.log.frames_every == 0 {
            return bad("log.frames_every", "must be at least 1 sweep".into());
        }
        let a = &self.accuracy;
        if !(a.grazing_threshold > 0.0 && a.grazing_threshold < 1.0) {
            return bad(
                "accuracy.grazing_threshold",
                format!("must lie in (0, 1), got {}", a.grazing_threshold),
            );
        }
        if !(a.contact_tolerance > 0.0 && a.contact_tolerance < a.grazing_threshold) {
            return bad(
                "accuracy.contact_tolerance",
                format!(
                    "must lie in (0, grazing_threshold = {}), got {}",
                    a.grazing_threshold, a.contact_tolerance
                ),
            );
        }
        if !(a.newton_tolerance > 0.0 && a.newton_tolerance < 1e-3) {
            return bad(
                "accuracy.newton_tolerance",
                format!("must lie in (0, 1e-3), got {}", a.newton_tolerance),
            );
        }
        if let Neighbours::Lists { shell } = a.neighbours
            && !(shell.is_finite() && shell > 0.0)
        {
            return bad(
                "accuracy.neighbours",
                format!("the neighbour shell must be a length > 0, got {shell}"),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"Scene(
    seed: 7,
    box: (12.0, 12.0, 12.0),
    walls: [],
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 1.0, b: 0.5, c: 0.5), count: 256),
    ],
    start: Lattice,
    stages: [
        Compress(packing_fraction: 0.50),
        MonteCarlo(ensemble: Npt(pressure: 3.0), sweeps: 20000),
        MonteCarlo(ensemble: Nvt, sweeps: 10000),
        Dynamics(duration: 50.0, temperature: 1.0),
    ],
    log: Log(path: "run.mcap", stats_every: 100, frames_every: 1000),
)"#;

    #[test]
    fn the_design_example_parses() {
        let s = Scene::parse(GOOD).unwrap();
        assert_eq!(s.seed, 7);
        assert_eq!(s.particle_count(), 256);
        assert_eq!(s.stages.len(), 4);
        assert_eq!(s.species[0].mass, 1.0);
        assert!(s.species[0].rotation);
        // Round trip through the serialised form the log records.
        assert_eq!(Scene::parse(&s.to_ron()).unwrap(), s);
    }

    #[test]
    fn errors_name_the_field_and_line() {
        let text = GOOD.replace("count: 256", "count: 0");
        match Scene::parse(&text) {
            Err(SceneError::Invalid { field, line, .. }) => {
                assert_eq!(field, "species[0].count");
                assert_eq!(line, Some(6));
            }
            other => panic!("{other:?}"),
        }
        let text = GOOD.replace("sweeps: 10000", "sweeps: 10000, steps: 3");
        match Scene::parse(&text) {
            Err(SceneError::Syntax { line, message, .. }) => {
                assert_eq!(line, 12);
                assert!(message.contains("steps"), "{message}");
            }
            other => panic!("{other:?}"),
        }
        let text = GOOD.replace("b: 0.5, c", "b: -0.5, c");
        let e = Scene::parse(&text).unwrap_err().to_string();
        assert!(e.contains("line 6") && e.contains("b must be"), "{e}");
    }

    #[test]
    fn impossible_targets_are_refused() {
        let text = GOOD.replace("packing_fraction: 0.50", "packing_fraction: 0.80");
        let e = Scene::parse(&text).unwrap_err().to_string();
        assert!(e.contains("densest"), "{e}");
        let text = GOOD.replace("packing_fraction: 0.50", "packing_fraction: 0.05");
        let e = Scene::parse(&text).unwrap_err().to_string();
        assert!(e.contains("nothing to compress"), "{e}");
        let text = GOOD.replace("count: 256", "count: 900");
        let e = Scene::parse(&text).unwrap_err().to_string();
        assert!(e.contains("start") && e.contains("lattice"), "{e}");
    }
}
