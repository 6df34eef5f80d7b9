//! The RON scene (the README's "Scenes" is its reference): typed by serde, unknown fields
//! rejected, then validated field by field; every error names the field
//! path and its line in the text.

mod error;
pub mod outline;
pub mod plan;
mod sizes;
pub mod space;
mod valid;
mod validate;

use serde::{Deserialize, Serialize};

use crate::geometry::Shape;
pub use error::{Problem, SceneError};
use outline::Outline;
pub use valid::ValidScene;

/// A scene as written: what to simulate, in which stages, logged where.
/// It is checked by [`Scene::validated`] before anything plans or runs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Random seed (the command line's `--seed` overrides it).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The starting box (compression and NPT change it): edges, or edges
    /// and tilts; left out by a `Crystal` start, whose supercell it is.
    #[serde(rename = "box", default, skip_serializing_if = "Option::is_none")]
    pub box_spec: Option<space::BoxSpec>,
    /// Axes closed by hard walls (the others are periodic).
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

/// The most species a scene may hold: the plan and both drivers keep
/// tables per pair of species, which grow as its square (1024 species
/// take about 100 MB and a fraction of a second to set up; 6000 took
/// 2 GB before a run could start).
pub const MAX_SPECIES: usize = 1024;

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

/// The slowest growth a `Jam` stage may ask: a jam's collisions grow as
/// 1/γ (about 2×10⁵ per sphere at 3×10⁻⁴), so slower would not end in any
/// real time.
pub const MIN_GROWTH_RATE: f64 = 1e-6;
/// The lowest βPV/N a `Jam` stage may take for jammed: dense fluids and
/// glasses reach tens, and at 10³ the gaps are a thousandth of the size.
pub const MIN_JAM_PRESSURE: f64 = 1e3;
/// The collisions per body a `Jam` stage may run at most; it then ends,
/// not jammed, and says so. Jams at the slowest rates measured took
/// under 2×10⁵ per sphere and 10⁵ per superball.
pub const JAM_COLLISIONS_PER_BODY: u64 = 10_000_000;
/// The collisions per body a `Dynamics` stage may run at most: about
/// 10⁶ s of one core for a thousand bodies. A stage whose collision rate
/// would take it past this (a packing near its jam collides 10¹² times
/// per body and unit time) fails early, saying so, rather than never end.
pub const DYNAMICS_COLLISIONS_PER_BODY: u64 = 1_000_000_000;

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
    /// Polydisperse sizes: how the bodies' scale factors of `shape` are
    /// spread (spheres; drawn from the scene's seed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sizes: Option<crate::state::sizes::SizeDistribution>,
}

fn one() -> f64 {
    1.0
}
fn is_zero(x: &f64) -> bool {
    *x == 0.0
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
    /// A crystal: `cells` unit cells of `lattice` along its three vectors,
    /// scaled to `packing_fraction`; the supercell is the box.
    Crystal {
        /// The lattice.
        lattice: space::Lattice,
        /// Unit cells along each lattice vector.
        cells: (usize, usize, usize),
        /// The packing fraction.
        packing_fraction: f64,
    },
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
        /// Writes βP_αβ by the scale distribution to `/stats` (each of its
        /// six components costs about what the scalar pressure does; not
        /// with walls, which the scale distribution has no term for).
        #[serde(default)]
        pressure_tensor: bool,
        /// Size swaps tried per body per sweep, after its N trial moves
        /// (polydisperse species; default 0: none).
        #[serde(default, skip_serializing_if = "is_zero")]
        swaps: f64,
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
        /// Every body turns with its own principal moments of inertia
        /// (asymmetric tops in closed form; the default); `false` turns
        /// them as spherical tops with the mean moment, which leaves
        /// equilibrium averages as they are and costs less.
        #[serde(default = "yes")]
        true_inertia: bool,
        /// Report the mean-squared displacement in `/stats`.
        #[serde(default)]
        msd: bool,
        /// Report the orientational correlation C₂(t) in `/stats`.
        #[serde(default)]
        c2: bool,
    },
    /// A jammed packing by event-driven growth (Lubachevsky–Stillinger,
    /// as Donev, Torquato and Stillinger): every body's linear size grows
    /// at `growth_rate` relative to its size while the bodies move at
    /// kT = 1, until βPV/N passes `pressure` (or the packing fraction
    /// reaches `packing_fraction`). The stages after it go on with the
    /// grown bodies.
    Jam {
        /// γ, per unit time (default 10⁻³).
        #[serde(default)]
        growth_rate: Option<f64>,
        /// The rate until βPV/N = 10³ (default: `growth_rate`); faster
        /// keeps bodies that would order random.
        #[serde(default)]
        fluid_rate: Option<f64>,
        /// The bound on βPV/N that ends it (default 10¹²).
        #[serde(default)]
        pressure: Option<f64>,
        /// Stop growing at this packing fraction if the pressure bound is
        /// not reached first (default: grow to the bound).
        #[serde(default)]
        packing_fraction: Option<f64>,
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
            ..
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
            Stage::Jam { .. } => "jam",
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
        /// Box moves one axis at a time (the same as `box_moves: Axes`).
        #[serde(default)]
        anisotropic: bool,
        /// Which box moves: `Isotropic` (ln V, the default), `Axes` (ln L
        /// of one edge) or `Triclinic` (edges and shears).
        #[serde(default)]
        box_moves: Option<crate::mc::box_moves::BoxMoves>,
    },
}

impl Ensemble {
    /// The box moves of an NPT ensemble (`anisotropic: true` is `Axes`).
    pub fn box_moves(&self) -> Option<crate::mc::box_moves::BoxMoves> {
        use crate::mc::box_moves::BoxMoves;
        match self {
            Ensemble::Nvt => None,
            Ensemble::Npt {
                anisotropic,
                box_moves,
                ..
            } => Some(box_moves.unwrap_or(if *anisotropic {
                BoxMoves::Axes
            } else {
                BoxMoves::Isotropic
            })),
        }
    }
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

impl Scene {
    /// The index of the first `Jam` stage: its frames and those of the
    /// stages after it hold the grown species.
    pub fn first_jam(&self) -> Option<usize> {
        self.stages
            .iter()
            .position(|s| matches!(s, Stage::Jam { .. }))
    }

    /// Parses and validates a scene.
    ///
    /// ```
    /// use hardbody::scene::{Scene, SceneError};
    ///
    /// let text = r#"Scene(
    ///     box: (8.0, 8.0, 8.0),
    ///     species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 64)],
    ///     stages: [MonteCarlo(ensemble: Nvt, sweeps: 10)],
    /// )"#;
    /// let scene = Scene::parse(text)?;
    /// assert_eq!(scene.stages.len(), 1);
    /// // A refusal names the field that is wrong.
    /// let bad = Scene::parse(&text.replace("sweeps: 10", "sweeps: 0"));
    /// assert!(matches!(bad, Err(SceneError::Invalid { field, .. }) if field == "stages[0].sweeps"));
    /// # Ok::<(), SceneError>(())
    /// ```
    pub fn parse(text: &str) -> Result<ValidScene, SceneError> {
        // A byte-order mark some editors write is no part of the scene.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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
            .map_err(|problems| SceneError::invalid(problems, |field| outline.line_of(field)))?;
        Ok(ValidScene(scene))
    }

    /// Validates a scene built in code (or deserialized from another
    /// format, or edited after [`ValidScene::into_scene`]) as
    /// [`Scene::parse`] validates a scene file; the error names the field,
    /// without a line.
    pub fn validated(self) -> Result<ValidScene, SceneError> {
        self.validate()
            .map_err(|problems| SceneError::invalid(problems, |_| None))?;
        Ok(ValidScene(self))
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

    /// Σ vᵢ over all particles (at their sizes).
    pub fn particle_volume(&self) -> f64 {
        if let Some(sizes) = self.body_sizes() {
            let volumes = self.body_species().map(|s| s.shape.volume());
            return volumes.zip(sizes).map(|(v, f)| v * f.powi(3)).sum();
        }
        self.species
            .iter()
            .map(|s| s.count as f64 * s.shape.volume())
            .sum()
    }

    /// The largest bounding radius of any body.
    pub fn largest_bounding_radius(&self) -> f64 {
        if let Some(sizes) = self.body_sizes() {
            let radii = self.body_species().map(|s| s.shape.bounding_radius());
            return radii.zip(sizes).map(|(r, f)| r * f).fold(0.0, f64::max);
        }
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
        let all_same = self
            .species
            .iter()
            .all(|s| s.shape == *first && s.sizes.is_none());
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

    /// The starting box's edges (of a scene whose box and start passed
    /// validation: see [`ValidScene::box_vector`]).
    fn box_vector(&self) -> nalgebra::Vector3<f64> {
        self.periodic_box().lengths()
    }

    /// The crystal of a `Crystal` start.
    pub fn crystal(
        &self,
    ) -> Option<Result<crate::state::crystal::CrystalSpec, crate::state::crystal::CrystalError>>
    {
        let Start::Crystal {
            lattice,
            cells,
            packing_fraction,
        } = &self.start
        else {
            return None;
        };
        let shape = self.species.first()?.shape;
        Some(
            lattice
                .unit_cell(&shape)
                .map(|cell| crate::state::crystal::CrystalSpec {
                    cell,
                    cells: [cells.0, cells.1, cells.2],
                    packing_fraction: *packing_fraction,
                }),
        )
    }

    /// The box and sites of a `Crystal` start, each body at its size if
    /// the species give sizes.
    pub fn crystal_sites(
        &self,
    ) -> Option<
        Result<
            (crate::space::PeriodicBox, Vec<crate::state::Particle>),
            crate::state::crystal::CrystalError,
        >,
    > {
        let sizes = self.body_sizes();
        let species = self.mc_species();
        Some(
            self.crystal()?
                .and_then(|c| c.build_sized(&species, &self.counts(), sizes.as_deref())),
        )
    }

    /// The species' counts, in scene order.
    pub fn counts(&self) -> Vec<usize> {
        self.species.iter().map(|s| s.count).collect()
    }

    /// The packing fraction stage `index` starts at, where it is known
    /// before running: the start's (not a resumed state's), then each
    /// compression's target; unknown after an NPT stage, or after a
    /// compression that may end elsewhere (to a pressure, or to the jam).
    fn packing_fraction_before(&self, index: usize) -> Option<f64> {
        let mut phi = match &self.start {
            Start::Resume(_) => None,
            Start::Crystal {
                packing_fraction, ..
            } => Some(*packing_fraction),
            _ => Some(self.particle_volume() / self.periodic_box().volume()),
        };
        for stage in &self.stages[..index.min(self.stages.len())] {
            phi = match stage {
                Stage::Compress {
                    packing_fraction: Some(target),
                    until_jammed: false,
                    ..
                } => Some(*target),
                Stage::Compress { .. } => None,
                Stage::MonteCarlo {
                    ensemble: Ensemble::Npt { .. },
                    ..
                } => None,
                Stage::MonteCarlo { .. } | Stage::Dynamics { .. } => phi,
                Stage::Jam { .. } => None,
            };
        }
        phi
    }

    /// The dynamics' neighbour shell (`None`: cells), as
    /// `accuracy.neighbours` asks, for a dynamics stage that starts at
    /// `packing_fraction`.
    pub fn neighbour_shell(&self, packing_fraction: f64) -> Option<f64> {
        self.neighbour_shell_of(&self.mc_species(), packing_fraction)
    }

    /// The same for bodies of `species` (the scene's grown by a jam stage).
    pub fn neighbour_shell_of(
        &self,
        species: &[crate::state::Species],
        packing_fraction: f64,
    ) -> Option<f64> {
        match self.accuracy.neighbours {
            Neighbours::Auto => {
                let polydisperse = self.species.iter().any(|s| s.sizes.is_some());
                crate::edmd::automatic_neighbour_shell(species, packing_fraction, polydisperse)
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

    /// The starting box, with its walls (of a scene whose box and start
    /// passed validation: see [`ValidScene::periodic_box`]).
    fn periodic_box(&self) -> crate::space::PeriodicBox {
        if let Some(sites) = self.crystal_sites() {
            return sites.expect("a validated crystal").0;
        }
        let spec = self.box_spec.expect("a validated box");
        let v = |t: (f64, f64, f64)| nalgebra::Vector3::new(t.0, t.1, t.2);
        crate::space::PeriodicBox::triclinic(v(spec.lengths), v(spec.tilts))
            .and_then(|b| b.with_walls(self.wall_axes()))
            .expect("a validated box and walls")
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

    /// A scene wrong in several parts is refused with the first problem of
    /// each part, every one with its field and line, in the order of the
    /// scene; the stages, which need a valid start, are left unchecked
    /// while the species are wrong.
    #[test]
    fn every_part_that_is_wrong_is_named_with_its_line() {
        let text = GOOD
            .replace("count: 256", "count: 0")
            .replace("\"run.mcap\"", "\"\"")
            .replace("frames_every: 1000", "frames_every: 0")
            .replace("sweeps: 20000", "sweeps: 0");
        let Err(SceneError::Invalid {
            field, line, more, ..
        }) = Scene::parse(&text)
        else {
            panic!("refused");
        };
        assert_eq!((field.as_str(), line), ("species[0].count", Some(6)));
        let more: Vec<_> = more.iter().map(|p| (p.field.as_str(), p.line)).collect();
        // One problem a part: the log's path, not its frames too; no
        // stage problem while the species are wrong.
        assert_eq!(more, [("log.path", Some(15))]);
        let shown = Scene::parse(&text).unwrap_err().to_string();
        assert_eq!(shown.lines().count(), 2, "{shown}");
        assert!(
            shown.ends_with("line 15: log.path: must not be empty"),
            "{shown}"
        );
        // With the species mended, the stages are checked and named.
        let Err(SceneError::Invalid { field, more, .. }) =
            Scene::parse(&text.replace("count: 0", "count: 256"))
        else {
            panic!("refused");
        };
        assert_eq!(field, "stages[1].sweeps");
        assert_eq!(more.len(), 1);
    }

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
        assert_eq!(s.clone().into_scene().validated().as_ref(), Ok(&s));
        let mut bad = s.into_scene();
        bad.species[0].count = 0;
        match bad.validated() {
            Err(SceneError::Invalid { field, line, .. }) => {
                assert_eq!((field.as_str(), line), ("species[0].count", None));
            }
            other => panic!("{other:?}"),
        }
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
