//! MCAP logs (the README's "Logs" is their reference): `/stats` (JSON), `/scene`
//! (`foxglove.SceneUpdate`, protobuf, for the 3D panel) and `/state` (JSON,
//! full precision), with the scene text and the program version in the
//! metadata, in zstd chunks. A run that fails in a dynamics stage adds one
//! `/failure` message (JSON): the error and the dynamics' stored state at
//! it, to replay it ([`FailureRecord`]).
//!
//! Log time: Monte Carlo stages advance it by 1 ms per sweep, dynamics
//! stages by 1 s per unit of simulated time; stages follow one another on
//! that clock from 0. Messages carry these explicit times, never the wall
//! clock, so a replay plays sweeps and simulated time at a steady pace.
//!
//! Safety: the log is written to `<path>.partial` and renamed over `<path>`
//! only when the run completes, so a failed run never damages an existing
//! file; each frame closes an MCAP chunk, so a killed run leaves a partial
//! log readable up to its last frame.

pub mod averages;
mod error;
pub mod file;
pub mod gsd;
pub mod packing;
pub mod read;
mod schema;
pub mod view;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use foxglove::Encode;
use serde::{Deserialize, Serialize};

use crate::geometry::Shape;
use nalgebra::Vector3;

use rand_pcg::Pcg64;

use crate::mc::compress::CompressorState;
use crate::mc::moves::{Counts, MoveSizes};
use crate::space::PeriodicBox;
use crate::state::{Particle, Species};

use error::io_reason;
pub use error::{InconsistentState, LogError, StorageFailure, io_cause};

/// Nanoseconds of log time per Monte Carlo sweep.
pub const NS_PER_SWEEP: u64 = 1_000_000;
/// Nanoseconds of log time per unit of simulated time.
pub const NS_PER_TIME_UNIT: f64 = 1e9;
/// The frame id of every `/scene` entity.
pub const FRAME_ID: &str = "hardbody";
/// The name of the metadata records in which a run notes what each
/// stage's driver was built with ([`LogWriter::stage_plan`]).
pub const STAGE_PLAN_METADATA: &str = "hardbody.stage";

/// One `/stats` message. Fields that a stage does not measure are null.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// `compress`, `monte_carlo`, `dynamics` or `jam`.
    pub stage: String,
    /// Index of the stage in the scene.
    pub stage_index: usize,
    /// Sweeps done in the stage (Monte Carlo).
    pub sweep: Option<u64>,
    /// Simulated time in the stage (dynamics).
    pub time: Option<f64>,
    /// φ.
    pub packing_fraction: f64,
    /// βP: imposed (NPT), from the scale distribution function (NVT), from
    /// the collision virial over the interval (dynamics); null otherwise.
    pub pressure: Option<f64>,
    /// βP_αβ, the symmetric pressure tensor as HOOMD-blue orders it
    /// (xx, xy, xz, yy, yz, zz), from the collision virial over the
    /// interval (dynamics in a periodic box; `pressure` is a third of its
    /// trace); left out otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pressure_tensor: Option<[f64; 6]>,
    /// Box edges.
    #[serde(rename = "box")]
    pub box_lengths: [f64; 3],
    /// Box tilt factors (xy, xz, yz); left out where all are zero.
    #[serde(default, skip_serializing_if = "no_tilt")]
    pub tilts: [f64; 3],
    /// Acceptance of translations over the interval (Monte Carlo).
    pub acceptance_translate: Option<f64>,
    /// Acceptance of rotations over the interval (Monte Carlo).
    pub acceptance_rotate: Option<f64>,
    /// Acceptance of box moves over the interval (Monte Carlo, NPT).
    pub acceptance_volume: Option<f64>,
    /// Acceptance of shear box moves over the interval (Monte Carlo, NPT
    /// with triclinic box moves); left out otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceptance_shear: Option<f64>,
    /// Acceptance of size swaps over the interval (Monte Carlo stages with
    /// `swaps`); left out otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceptance_swap: Option<f64>,
    /// Collisions since the stage began (dynamics).
    pub collisions: Option<u64>,
    /// kT from the kinetic energy (dynamics).
    pub temperature: Option<f64>,
    /// S₂ of the molecular axes; null without turning anisotropic bodies.
    pub nematic_order: Option<f64>,
    /// Mean-squared displacement since the stage began (on request).
    pub msd: Option<f64>,
    /// C₂(t) since the stage began (on request).
    pub c2: Option<f64>,
    /// The collision searches' work since the stage began (dynamics):
    /// distances, iterations, and the evaluations that did not go the
    /// first way (fallbacks, iteration caps, grazing refinements,
    /// round-off contacts). Absent in logs of earlier versions.
    #[serde(default)]
    pub solver: Option<crate::edmd::SolverWork>,
    /// Overlap tests over the interval that the boolean test could not
    /// decide (Monte Carlo): settled by the distance, or taken as
    /// overlaps. Absent in logs of earlier versions.
    #[serde(default)]
    pub overlap_strains: Option<crate::geometry::pair::OverlapStrains>,
}

/// A species as `/state` records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeciesRecord {
    /// Name.
    pub name: String,
    /// Shape.
    pub shape: Shape,
    /// Whether it turns.
    pub rotation: bool,
}

/// One `/state` message: the full-precision state (JSON numbers are
/// written in shortest round-trip form, so reading gives back the same
/// bits). Orientations are unit quaternions body → lab as [w, x, y, z].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateRecord {
    /// Index of the stage in the scene.
    pub stage_index: usize,
    /// `compress`, `monte_carlo`, `dynamics` or `jam`.
    pub stage: String,
    /// Sweeps done in the stage (Monte Carlo).
    pub sweep: Option<u64>,
    /// Simulated time in the stage (dynamics).
    pub time: Option<f64>,
    /// Box edges.
    #[serde(rename = "box")]
    pub box_lengths: [f64; 3],
    /// Box tilt factors (xy, xz, yz); left out where all are zero.
    #[serde(default, skip_serializing_if = "no_tilt")]
    pub tilts: [f64; 3],
    /// The species.
    pub species: Vec<SpeciesRecord>,
    /// Species index per particle.
    pub species_of: Vec<u16>,
    /// Centres.
    pub positions: Vec<[f64; 3]>,
    /// [w, x, y, z] per particle.
    pub orientations: Vec<[f64; 4]>,
    /// Each body's size, the scale factor of its species' shape (left
    /// out where every body has its species' size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sizes: Option<Vec<f64>>,
    /// Velocities (dynamics only).
    pub velocities: Option<Vec<[f64; 3]>>,
    /// Angular velocities, lab frame (dynamics only).
    pub angular_velocities: Option<Vec<[f64; 3]>>,
    /// What continuing the stage exactly from this frame needs besides the
    /// state (absent in states written by other tools).
    #[serde(default)]
    pub resume: Option<ResumeInfo>,
}

/// A stage's progress at a frame: with the state, enough to continue the
/// run bit for bit (`hardbody run --resume`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResumeInfo {
    /// Log time at which the stage began (ns).
    pub stage_clock: u64,
    /// Whether the stage was complete at this frame.
    pub stage_complete: bool,
    /// Sweeps done in the stage (Monte Carlo).
    pub sweep: u64,
    /// The translation cap of the stage's move-size tuning (Monte Carlo).
    pub max_translate: f64,
    /// Monte Carlo move sizes.
    pub sizes: MoveSizes,
    /// The stage's random stream after this frame's sweep (Monte Carlo).
    pub rng: Option<Pcg64>,
    /// Move counts since the last `/stats` message.
    pub window: Counts,
    /// Move counts since the last move-size update (Monte Carlo).
    pub tune_window: Counts,
    /// The compression's own state (Compress stages).
    pub compress: Option<CompressorState>,
    /// The dynamics' progress (Dynamics stages).
    pub dynamics: Option<DynamicsProgress>,
    /// Whether an NPT stage's density has settled, and the samples it is
    /// judged from (absent in logs of earlier versions).
    #[serde(default)]
    pub drift: Option<crate::mc::tuning::DriftWatch>,
    /// The growth's progress (Jam stages; absent elsewhere).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jam: Option<crate::edmd::jam::JamProgress>,
}

/// See [`ResumeInfo`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DynamicsProgress {
    /// Absolute simulated time of the frame (the stage's own clock starts
    /// at `start_time`).
    pub time: f64,
    /// Absolute simulated time at which the stage began.
    pub start_time: f64,
    /// Collisions since the dynamics began, at the frame.
    pub collisions: u64,
    /// Collisions when the stage began.
    pub start_collisions: u64,
    /// Index of the next `/stats` message and frame of the stage.
    pub next_stats: u64,
    /// See `next_stats`.
    pub next_frame: u64,
    /// kT of the stage.
    pub temperature: f64,
    /// The solver's counts since the stage began (absent in logs of
    /// earlier versions).
    #[serde(default)]
    pub solver_work: Option<crate::edmd::SolverWork>,
    /// The sums of the `/stats` interval the frame falls in (absent in
    /// logs of earlier versions: the first interval after a resume then
    /// starts at the frame).
    #[serde(default)]
    pub interval: Option<crate::edmd::dynamics::Interval>,
}

fn no_tilt(tilts: &[f64; 3]) -> bool {
    *tilts == [0.0; 3]
}

impl StateRecord {
    /// The box the record holds, with `walls`.
    pub fn periodic_box(
        &self,
        walls: [bool; 3],
    ) -> Result<PeriodicBox, crate::space::periodic_box::BoxError> {
        PeriodicBox::triclinic(self.box_lengths.into(), self.tilts.into())?.with_walls(walls)
    }

    /// The box, species, positions and orientations (no velocities), as
    /// stage 0 `start`; set the stage fields with struct update syntax.
    pub fn of_particles(box_: &PeriodicBox, species: &[Species], particles: &[Particle]) -> Self {
        StateRecord {
            stage_index: 0,
            stage: "start".into(),
            sweep: None,
            time: None,
            box_lengths: box_.lengths().into(),
            tilts: box_.tilts().into(),
            species: species
                .iter()
                .map(|s| SpeciesRecord {
                    name: s.name.clone(),
                    shape: s.shape,
                    rotation: s.rotation,
                })
                .collect(),
            species_of: particles.iter().map(|p| p.species).collect(),
            positions: particles.iter().map(|p| p.position.into()).collect(),
            orientations: particles
                .iter()
                .map(|p| {
                    let q = p.orientation.quaternion();
                    [q.w, q.i, q.j, q.k]
                })
                .collect(),
            sizes: None,
            velocities: None,
            angular_velocities: None,
            resume: None,
        }
    }

    /// The size of body `i` (1 without sizes).
    pub fn size_of(&self, i: usize) -> f64 {
        self.sizes.as_ref().map_or(1.0, |s| s[i])
    }

    /// The shapes the bodies have, whether each turns, and each body's
    /// index into them (see [`crate::analysis::packing::body_shapes`]).
    pub fn body_shapes(&self) -> (Vec<Shape>, Vec<bool>, Vec<usize>) {
        let shapes: Vec<Shape> = self.species.iter().map(|s| s.shape).collect();
        let turns: Vec<bool> = self.species.iter().map(|s| s.rotation).collect();
        let species_of: Vec<usize> = self.species_of.iter().map(|&k| k as usize).collect();
        crate::analysis::packing::body_shapes(&shapes, &turns, &species_of, self.sizes.as_deref())
    }

    /// [`StateRecord::of_particles`] of a system, with its bodies' sizes.
    pub fn of_system(system: &crate::state::System) -> Self {
        StateRecord {
            sizes: system.sizes().map(<[f64]>::to_vec),
            ..Self::of_particles(system.periodic_box(), system.species(), system.particles())
        }
    }

    /// Whether the record's parts agree: one species index, position and
    /// orientation per particle (and velocities, where present), species
    /// indices that name a species, a box of finite positive edges.
    pub fn check_consistent(&self) -> Result<(), InconsistentState> {
        let n = self.species_of.len();
        let lengths = [
            ("positions", Some(self.positions.len())),
            ("orientations", Some(self.orientations.len())),
            ("sizes", self.sizes.as_ref().map(Vec::len)),
            ("velocities", self.velocities.as_ref().map(Vec::len)),
            (
                "angular_velocities",
                self.angular_velocities.as_ref().map(Vec::len),
            ),
        ];
        for (name, len) in lengths {
            if let Some(len) = len
                && len != n
            {
                return Err(InconsistentState::Count { name, len, n });
            }
        }
        if let Some(k) = self
            .species_of
            .iter()
            .find(|&&k| k as usize >= self.species.len())
        {
            return Err(InconsistentState::Species {
                index: *k,
                species: self.species.len(),
            });
        }
        if !self.box_lengths.iter().all(|l| l.is_finite() && *l > 0.0) {
            return Err(InconsistentState::Box(self.box_lengths));
        }
        if !self.tilts.iter().all(|t| t.is_finite()) {
            return Err(InconsistentState::Tilts(self.tilts));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| !p.iter().all(|x| x.is_finite()))
        {
            return Err(InconsistentState::Position(i, self.positions[i]));
        }
        // Written as unit quaternions, to rounding: a zero or stretched one
        // is damage, not a pose.
        let unit = |q: &[f64; 4]| (q.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-9;
        if let Some(i) = self.orientations.iter().position(|q| !unit(q)) {
            return Err(InconsistentState::Orientation(i, self.orientations[i]));
        }
        Ok(())
    }

    /// With velocities and lab-frame angular velocities.
    pub fn with_velocities(self, velocities: &[(Vector3<f64>, Vector3<f64>)]) -> Self {
        StateRecord {
            velocities: Some(velocities.iter().map(|(v, _)| (*v).into()).collect()),
            angular_velocities: Some(velocities.iter().map(|(_, w)| (*w).into()).collect()),
            ..self
        }
    }
}

/// Why a run stopped, with what replays it: written once, to `/failure`,
/// when a stage fails (the log stays at `<path>.partial`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailureRecord {
    /// Index of the stage in the scene.
    pub stage_index: usize,
    /// The error, as reported.
    pub message: String,
    /// The dynamics as it stood at the failure, every body's stored pose
    /// and time to the bit (`Dynamics::from_dump` predicts the failing
    /// event again from it); absent for failures outside the dynamics.
    pub dump: Option<crate::edmd::DynamicsDump>,
}

/// Writes a log to `<path>.partial` under an exclusive lock;
/// [`LogWriter::finish`] renames it to `<path>`.
pub struct LogWriter {
    /// None once closed.
    writer: Option<mcap::Writer<BufWriter<File>>>,
    path: PathBuf,
    /// The file written to.
    partial: PathBuf,
    /// A log this one replaces once it holds as much (a resume in place:
    /// the partial log it resumes from): renamed over it at the first new
    /// frame, or when the log ends.
    replaces: Option<PathBuf>,
    /// The first error of a write: every later call reports it again
    /// (the MCAP writer cannot go on after a failed write).
    failed: Option<LogError>,
    /// Frames written (new or copied).
    frames: u64,
    stats: u16,
    scene: u16,
    state: u16,
    sequence: u32,
    view: view::SceneView,
}

/// `<path>.partial`, where a log is written until its run completes.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

/// Where a log that replaces the partial log it resumes from is written
/// until it holds as much.
pub fn resuming_path(path: &Path) -> PathBuf {
    let mut name = partial_path(path).into_os_string();
    name.push(".resuming");
    PathBuf::from(name)
}

impl LogWriter {
    /// Starts a log for `path` (written to `<path>.partial`), recording in
    /// the metadata the scene text as given (`scene`), the scene as run,
    /// with command-line overrides and defaults filled in
    /// (`scene_resolved`), and the program version. Refused with
    /// [`LogError::Busy`] while another process writes the same log.
    pub fn create(
        path: &Path,
        scene_text: &str,
        scene_resolved: &str,
        species: &[Species],
    ) -> Result<Self, LogError> {
        Self::open(path, None, scene_text, scene_resolved, species)
    }

    /// Like [`LogWriter::create`] for a run resumed from `<path>.partial`
    /// itself: the new log is written beside it and takes its place only
    /// once it holds at least as much (its first new frame), so that a
    /// resume killed early leaves the partial log as it was.
    pub fn create_replacing_partial(
        path: &Path,
        scene_text: &str,
        scene_resolved: &str,
        species: &[Species],
    ) -> Result<Self, LogError> {
        let replaced = partial_path(path);
        Self::open(path, Some(replaced), scene_text, scene_resolved, species)
    }

    fn open(
        path: &Path,
        replaces: Option<PathBuf>,
        scene_text: &str,
        scene_resolved: &str,
        species: &[Species],
    ) -> Result<Self, LogError> {
        let partial = match replaces {
            Some(_) => resuming_path(path),
            None => partial_path(path),
        };
        let file = file::create_locked(&partial)?;
        let result = Self::start(file, &partial, scene_text, scene_resolved);
        let (writer, [stats, state, scene]) = match result {
            Ok(w) => w,
            Err(e) => {
                // Nothing of the log is in the file yet.
                let _ = std::fs::remove_file(&partial);
                return Err(e);
            }
        };
        Ok(Self {
            writer: Some(writer),
            path: path.to_path_buf(),
            partial,
            replaces,
            failed: None,
            frames: 0,
            stats,
            scene,
            state,
            sequence: 0,
            view: view::SceneView::new(species),
        })
    }

    /// The MCAP header, schemas, channels (`/stats`, `/state`, `/scene`)
    /// and metadata.
    fn start(
        file: File,
        partial: &Path,
        scene_text: &str,
        scene_resolved: &str,
    ) -> Result<(mcap::Writer<BufWriter<File>>, [u16; 3]), LogError> {
        let mcap_err = |source| LogError::from_mcap(partial, source);
        let options = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            // Level 1: frames compress about as well, at a fraction of the
            // time of the default level 3 (a visible share of a short run).
            .compression_level(1)
            .chunk_size(Some(4 << 20))
            .profile("")
            .library(format!("hardbody {}", env!("CARGO_PKG_VERSION")));
        let mut writer = options.create(BufWriter::new(file)).map_err(mcap_err)?;
        let no_meta = BTreeMap::new();
        let json_schema = |w: &mut mcap::Writer<_>, name: &str, text: &str| {
            w.add_schema(name, "jsonschema", text.as_bytes())
        };
        let stats_schema =
            json_schema(&mut writer, "hardbody.Stats", schema::STATS_SCHEMA).map_err(mcap_err)?;
        let state_schema =
            json_schema(&mut writer, "hardbody.State", schema::STATE_SCHEMA).map_err(mcap_err)?;
        let scene_schema = foxglove::messages::SceneUpdate::get_schema()
            .expect("foxglove publishes the SceneUpdate schema");
        let scene_schema = writer
            .add_schema(
                &scene_schema.name,
                &scene_schema.encoding,
                &scene_schema.data,
            )
            .map_err(mcap_err)?;
        let stats = writer
            .add_channel(stats_schema, "/stats", "json", &no_meta)
            .map_err(mcap_err)?;
        let state = writer
            .add_channel(state_schema, "/state", "json", &no_meta)
            .map_err(mcap_err)?;
        let scene = writer
            .add_channel(scene_schema, "/scene", "protobuf", &no_meta)
            .map_err(mcap_err)?;
        let metadata = BTreeMap::from([
            ("version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
            ("scene".to_string(), scene_text.to_string()),
            ("scene_resolved".to_string(), scene_resolved.to_string()),
            (
                "log_time".to_string(),
                format!(
                    "{NS_PER_SWEEP} ns per Monte Carlo sweep and per chunk of a jam stage, {NS_PER_TIME_UNIT} ns per unit of simulated time"
                ),
            ),
        ]);
        writer
            .write_metadata(&mcap::records::Metadata {
                name: "hardbody".into(),
                metadata,
            })
            .map_err(mcap_err)?;
        // On disk at once: a run that cannot write its log's start fails
        // before its first sweep.
        writer.flush().map_err(mcap_err)?;
        Ok((writer, [stats, state, scene]))
    }

    /// Runs one write on the MCAP writer, remembering its first failure.
    fn attempt(
        &mut self,
        op: impl FnOnce(&mut mcap::Writer<BufWriter<File>>) -> mcap::McapResult<()>,
    ) -> Result<(), LogError> {
        if let Some(e) = &self.failed {
            return Err(e.again());
        }
        let Some(writer) = self.writer.as_mut() else {
            return Err(LogError::Content {
                path: self.partial.clone(),
                message: "the log is closed".into(),
            });
        };
        op(writer).map_err(|source| {
            let e = LogError::from_mcap(&self.partial, source);
            self.failed = Some(e.again());
            e
        })
    }

    fn write(&mut self, channel: u16, log_time: u64, data: &[u8]) -> Result<(), LogError> {
        self.sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        self.attempt(|w| w.write_to_known_channel(&header, data))
    }

    /// A message copied from another log (the part of an interrupted run
    /// that a resumed run keeps).
    pub fn copy(&mut self, topic: &str, log_time: u64, data: &[u8]) -> Result<(), LogError> {
        let channel = match topic {
            "/stats" => self.stats,
            "/scene" => self.scene,
            "/state" => {
                self.frames += 1;
                self.state
            }
            other => {
                return Err(LogError::Content {
                    path: self.partial.clone(),
                    message: format!("cannot copy a message of unknown topic {other}"),
                });
            }
        };
        self.write(channel, log_time, data)
    }

    /// A `/stats` message at `log_time`.
    pub fn stats(&mut self, log_time: u64, stats: &Stats) -> Result<(), LogError> {
        let data = serde_json::to_vec(stats).expect("stats serialise");
        self.write(self.stats, log_time, &data)
    }

    /// What stage `index`'s driver was built with (`entry`, JSON), as a
    /// metadata record `hardbody.stage` (keys `index` and `plan`) written
    /// as the stage starts: the plan the run used, beside what `hardbody
    /// check --json` planned.
    pub fn stage_plan(&mut self, index: usize, entry: &serde_json::Value) -> Result<(), LogError> {
        let metadata = BTreeMap::from([
            ("index".to_string(), index.to_string()),
            ("plan".to_string(), entry.to_string()),
        ]);
        self.attempt(|w| {
            w.write_metadata(&mcap::records::Metadata {
                name: STAGE_PLAN_METADATA.into(),
                metadata,
            })
        })
    }

    /// A frame at `log_time`: `/scene` for viewers and `/state` for
    /// resuming; the chunk is closed so that the frame survives a crash.
    pub fn frame(&mut self, log_time: u64, state: &StateRecord) -> Result<(), LogError> {
        let update = self.view.update(log_time, state);
        let mut buf = Vec::with_capacity(update.encoded_len().unwrap_or(1 << 16));
        update
            .encode(&mut buf)
            .expect("a Vec grows to hold any message");
        self.write(self.scene, log_time, &buf)?;
        let data = serde_json::to_vec(state).expect("states serialise");
        self.write(self.state, log_time, &data)?;
        self.attempt(|w| w.flush())?;
        self.frames += 1;
        // Now more than the log it replaces holds.
        self.take_place()
    }

    /// Renames the file written over the partial log it replaces (if it
    /// replaces one and has not yet).
    fn take_place(&mut self) -> Result<(), LogError> {
        if let Some(replaced) = self.replaces.take() {
            std::fs::rename(&self.partial, &replaced).map_err(|source| LogError::Io {
                path: replaced.clone(),
                source,
            })?;
            self.partial = replaced;
        }
        Ok(())
    }

    /// The `/failure` message at `log_time` (its channel is added here:
    /// logs of runs that succeed have none).
    pub fn failure(&mut self, log_time: u64, failure: &FailureRecord) -> Result<(), LogError> {
        let data = serde_json::to_vec(failure).expect("failures serialise");
        let sequence = self.sequence + 1;
        self.attempt(|w| {
            let schema = w.add_schema(
                "hardbody.Failure",
                "jsonschema",
                schema::FAILURE_SCHEMA.as_bytes(),
            )?;
            let channel = w.add_channel(schema, "/failure", "json", &BTreeMap::new())?;
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence,
                log_time,
                publish_time: log_time,
            };
            w.write_to_known_channel(&header, &data)?;
            w.flush()
        })?;
        self.sequence = sequence;
        Ok(())
    }

    /// Whether a write to the log has failed (it then takes no more).
    pub fn has_failed(&self) -> bool {
        self.failed.is_some()
    }

    /// The first failed write's error, if one failed.
    pub fn error(&self) -> Option<LogError> {
        self.failed.as_ref().map(LogError::again)
    }

    /// Completes the log and renames it to its path.
    pub fn finish(mut self) -> Result<PathBuf, LogError> {
        self.close()?;
        std::fs::rename(&self.partial, &self.path).map_err(|source| LogError::Io {
            path: self.path.clone(),
            source,
        })?;
        // A resume in place that ends before a new frame: the complete log
        // supersedes the partial one.
        if let Some(replaced) = self.replaces.take() {
            let _ = std::fs::remove_file(replaced);
        }
        Ok(self.path.clone())
    }

    /// Completes the log but leaves it at `<path>.partial` (a run that
    /// failed: the file at `path`, if any, is left untouched), and returns
    /// where the partial log is. A log whose writing failed (a full disk)
    /// and that holds no frame is removed, having nothing to resume from;
    /// one that would replace the log it resumed from is removed if its
    /// writing failed, that log holding at least as much.
    pub fn abandon(mut self) -> Result<Option<PathBuf>, LogError> {
        let closed = self.close();
        if self.has_failed() {
            if self.frames == 0 || self.replaces.is_some() {
                let _ = std::fs::remove_file(&self.partial);
                return Ok(self.replaces.take());
            }
            // Readable, and resumable, up to its last complete frame.
            return Ok(Some(self.partial.clone()));
        }
        closed?;
        self.take_place()?;
        Ok(Some(self.partial.clone()))
    }

    /// Writes the summary and flushes the file to disk.
    fn close(&mut self) -> Result<(), LogError> {
        use std::io::Write;
        self.attempt(|w| w.finish().map(|_| ()))?;
        let mut file = self.writer.take().expect("open until closed").into_inner();
        file.flush()
            .and_then(|_| file.get_ref().sync_all())
            .map_err(|source| {
                let e = LogError::Io {
                    path: self.partial.clone(),
                    source,
                };
                self.failed = Some(e.again());
                e
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_disk_is_named_with_the_path() {
        // /dev/full refuses every write with ENOSPC.
        let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
            return;
        };
        let path = Path::new("/dev/full");
        let error = match LogWriter::start(full, path, "scene", "scene") {
            Err(e) => e,
            Ok(_) => panic!("a write to /dev/full succeeded"),
        };
        assert!(error.is_disk_full(), "{error:?}");
        let message = error.to_string();
        assert_eq!(message, "/dev/full: no space left on device");
        // Every later report of a failed writer says the same.
        assert_eq!(error.again().to_string(), message);
    }
}
