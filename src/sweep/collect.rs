//! A sweep's results (`hardbody sweep collect`): each job's status from
//! its log, and per state point the averages of one stage over the
//! replicas that finished.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::{Map, Value};

use super::{JOB_LOG, STATEPOINT, SWEEP_FILE, SweepError, SweepRecord};
use crate::analysis::eos::carnahan_starling_packing_fraction;
use crate::geometry::Shape;
use crate::log::averages::{ReplicaAverage, StageAverages, stage_averages, stages_over_replicas};
use crate::log::partial_path;
use crate::log::read::{LogContents, read_log};
use crate::scene::{Ensemble, Scene, Stage, ValidScene};

/// Where a job stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JobStatus {
    /// Its log is complete, every stage run.
    Finished,
    /// A partial log (killed or stopped): submitting it again resumes it.
    Partial,
    /// A stage failed (the partial log holds why).
    Failed,
    /// No log yet.
    NotStarted,
    /// Its log is of another scene than the job's own (a state point's
    /// folder regenerated, or a log copied in): never averaged.
    Foreign,
}

/// One job read back.
#[derive(Debug, Clone)]
pub struct JobResult {
    /// The job's folder name (its id).
    pub id: String,
    /// Its state point.
    pub statepoint: Map<String, Value>,
    /// Where it stands.
    pub status: JobStatus,
    /// Its stages' averages, when finished.
    pub stages: Option<Vec<StageAverages>>,
    /// Its scene.
    pub scene: Option<ValidScene>,
}

/// One state point: the replicas of one set of values.
#[derive(Debug, Clone, Serialize)]
pub struct StatePointRow {
    /// The swept values (the state point without its seed).
    pub parameters: Map<String, Value>,
    /// Jobs by status.
    pub finished: usize,
    /// Jobs whose log is of another scene ([`JobStatus::Foreign`]).
    pub foreign: usize,
    /// See [`JobStatus::Partial`].
    pub partial: usize,
    /// See [`JobStatus::Failed`].
    pub failed: usize,
    /// See [`JobStatus::NotStarted`].
    pub not_started: usize,
    /// The stage averaged.
    pub stage_index: usize,
    /// Its observables over the finished replicas (empty if none).
    pub observables: BTreeMap<String, ReplicaAverage>,
    /// Whether the stage equilibrated in every finished replica.
    pub equilibrated: bool,
    /// For one species of spheres in an NPT stage: the packing fraction
    /// Carnahan–Starling gives at its pressure.
    pub carnahan_starling: Option<f64>,
}

/// The folders of a sweep's workspace: its jobs, read, and the folders
/// that are not jobs of a sweep (no scene and state point, or a state
/// point that does not read), each with why.
pub struct Workspace {
    /// The jobs.
    pub jobs: Vec<JobResult>,
    /// The folders left out, and why.
    pub strays: Vec<(PathBuf, String)>,
}

/// Reads every job of the sweep at `dir`.
pub fn read_jobs(dir: &Path) -> Result<Workspace, SweepError> {
    let (folders, mut strays) = workspace_folders(dir)?;
    let mut jobs = Vec::with_capacity(folders.len());
    for folder in folders {
        match read_job(&folder) {
            Ok(job) => jobs.push(job),
            Err(e) => strays.push((folder, e.to_string())),
        }
    }
    strays.sort();
    Ok(Workspace { jobs, strays })
}

/// The workspace's folders that hold a job's scene and state point, and
/// the others with why they are not jobs.
type Folders = (Vec<PathBuf>, Vec<(PathBuf, String)>);

fn workspace_folders(dir: &Path) -> Result<Folders, SweepError> {
    let workspace = dir.join("workspace");
    let entries = std::fs::read_dir(&workspace).map_err(|e| SweepError::Workspace {
        path: workspace.clone(),
        message: format!("{e} (is this a sweep's folder?)"),
    })?;
    let (mut jobs, mut foreign) = (Vec::new(), Vec::new());
    for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        if !path.is_dir() {
            continue;
        }
        if path.join(STATEPOINT).is_file() && path.join(super::JOB_SCENE).is_file() {
            jobs.push(path);
        } else {
            foreign.push((path, "no job scene and state point".into()));
        }
    }
    jobs.sort();
    Ok((jobs, foreign))
}

fn read_job(folder: &Path) -> Result<JobResult, SweepError> {
    let sp_path = folder.join(STATEPOINT);
    let bad = |message: String| SweepError::Workspace {
        path: sp_path.clone(),
        message,
    };
    let text = std::fs::read_to_string(&sp_path).map_err(|e| bad(e.to_string()))?;
    let Value::Object(statepoint) = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?
    else {
        return Err(bad("not a JSON object".into()));
    };
    let id = folder
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let log = folder.join(JOB_LOG);
    let partial = partial_path(&log);
    let scene_of = |c: &LogContents| {
        c.metadata
            .get("scene_resolved")
            .and_then(|t| Scene::parse(t).ok())
    };
    let (status, contents, scene) = if log.exists() {
        match read_log(&log, false) {
            Ok(c) => {
                let scene = scene_of(&c);
                let complete = match (&scene, &c.last_state) {
                    (Some(scene), Some((_, state))) => {
                        state.stage_index + 1 == scene.stages.len()
                            && state.resume.as_ref().is_some_and(|r| r.stage_complete)
                    }
                    _ => false,
                };
                let status = if complete {
                    JobStatus::Finished
                } else {
                    JobStatus::Partial
                };
                (status, Some(c), scene)
            }
            Err(_) => (JobStatus::Failed, None, None),
        }
    } else if partial.exists() {
        match read_log(&partial, false) {
            Ok(c) if c.failure.is_some() => {
                let scene = scene_of(&c);
                (JobStatus::Failed, Some(c), scene)
            }
            _ => (JobStatus::Partial, None, None),
        }
    } else {
        (JobStatus::NotStarted, None, None)
    };
    // A log is this job's only if it is of the job's own scene.
    let own = std::fs::read_to_string(folder.join(super::JOB_SCENE))
        .ok()
        .and_then(|text| Scene::parse(&text).ok());
    let status = match (&scene, &own) {
        (Some(logged), Some(own)) if logged != own => JobStatus::Foreign,
        _ => status,
    };
    let stages = match (status, &contents) {
        (JobStatus::Finished, Some(c)) => {
            let stats: Vec<_> = c.stats.iter().map(|(_, s)| s.clone()).collect();
            Some(stage_averages(&stats))
        }
        _ => None,
    };
    Ok(JobResult {
        id,
        statepoint,
        status,
        stages,
        scene,
    })
}

/// The record of the sweep at `dir`.
pub fn sweep_record(dir: &Path) -> Result<SweepRecord, SweepError> {
    super::read_record(
        &dir.join(SWEEP_FILE),
        "a sweep's folder",
        "a sweep's record",
    )
}

/// The last stage of `scene` that is not a compression (the one a sweep
/// measures, unless told).
pub fn measured_stage(scene: &Scene) -> usize {
    scene
        .stages
        .iter()
        .rposition(|s| !matches!(s, Stage::Compress { .. }))
        .unwrap_or(scene.stages.len().saturating_sub(1))
}

/// One row per state point (in the order of their first job), with the
/// averages of stage `stage` (default: the last that is not a
/// compression) over the finished replicas; and the folders of the
/// workspace left out as no jobs ([`Workspace::strays`]).
pub fn collect(dir: &Path, stage: Option<usize>) -> Result<Collected, SweepError> {
    let record = sweep_record(dir)?;
    let template = Scene::parse(&record.template).map_err(|e| SweepError::Workspace {
        path: dir.join(SWEEP_FILE),
        message: format!("its template: {e}"),
    })?;
    let stage = stage.unwrap_or_else(|| measured_stage(&template));
    if stage >= template.stages.len() {
        return Err(SweepError::Workspace {
            path: dir.to_path_buf(),
            message: format!(
                "--stage {stage}: the template has {} stages",
                template.stages.len()
            ),
        });
    }
    let Workspace { jobs, strays } = read_jobs(dir)?;
    // State points in the order of their first job, keyed by their JSON.
    let mut order: Vec<(String, Map<String, Value>)> = Vec::new();
    let mut groups: BTreeMap<String, Vec<&JobResult>> = BTreeMap::new();
    for job in &jobs {
        let mut parameters = job.statepoint.clone();
        parameters.remove("seed");
        let key = super::signac::python_json(&Value::Object(parameters.clone()));
        if !groups.contains_key(&key) {
            order.push((key.clone(), parameters));
        }
        groups.entry(key).or_default().push(job);
    }
    let mut rows = Vec::with_capacity(order.len());
    for (key, parameters) in order {
        let group = &groups[&key];
        let count = |s: JobStatus| group.iter().filter(|j| j.status == s).count();
        let runs: Vec<Vec<StageAverages>> = group
            .iter()
            .filter_map(|j| j.stages.clone())
            .filter(|stages| stages.iter().any(|s| s.stage_index == stage))
            .collect();
        let (observables, equilibrated) = if runs.is_empty() {
            (BTreeMap::new(), false)
        } else {
            let combined =
                stages_over_replicas(&runs).map_err(|message| SweepError::Workspace {
                    path: dir.to_path_buf(),
                    message: message.to_string(),
                })?;
            combined
                .into_iter()
                .find(|s| s.stage_index == stage)
                .map(|s| (s.observables, s.equilibrated))
                .unwrap_or_default()
        };
        let scene = group.iter().find_map(|j| j.scene.as_ref());
        rows.push(StatePointRow {
            parameters,
            finished: count(JobStatus::Finished),
            partial: count(JobStatus::Partial),
            failed: count(JobStatus::Failed),
            not_started: count(JobStatus::NotStarted),
            foreign: count(JobStatus::Foreign),
            stage_index: stage,
            observables,
            equilibrated,
            carnahan_starling: scene.and_then(|s| hard_sphere_density(s, stage)),
        });
    }
    rows.sort_by(|a, b| compare_parameters(&a.parameters, &b.parameters));
    Ok(Collected { rows, strays })
}

/// What [`collect`] finds.
pub struct Collected {
    /// One row per state point.
    pub rows: Vec<StatePointRow>,
    /// The folders left out as no jobs, and why.
    pub strays: Vec<(PathBuf, String)>,
}

/// State points in order of their values, field by field (numbers by
/// value).
fn compare_parameters(a: &Map<String, Value>, b: &Map<String, Value>) -> std::cmp::Ordering {
    for (key, x) in a {
        let y = b.get(key).unwrap_or(&Value::Null);
        let order = match (x.as_f64(), y.as_f64()) {
            (Some(p), Some(q)) => p.total_cmp(&q),
            _ => x.to_string().cmp(&y.to_string()),
        };
        if order.is_ne() {
            return order;
        }
    }
    std::cmp::Ordering::Equal
}

/// Carnahan–Starling's packing fraction at the pressure of NPT stage
/// `stage`, for a scene of one species of spheres.
fn hard_sphere_density(scene: &Scene, stage: usize) -> Option<f64> {
    let [species] = scene.species.as_slice() else {
        return None;
    };
    let Shape::Sphere(sphere) = species.shape else {
        return None;
    };
    let Some(Stage::MonteCarlo {
        ensemble: Ensemble::Npt { pressure, .. },
        ..
    }) = scene.stages.get(stage)
    else {
        return None;
    };
    let sigma = 2.0 * sphere.radius();
    Some(carnahan_starling_packing_fraction(pressure * sigma.powi(3)))
}
