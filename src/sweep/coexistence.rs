//! Coexistence as a signac/row study (`hardbody coexistence
//! --workspace`): one job per part (each phase's anchor, each branch
//! point), each running its phase's scene again and writing its result to
//! `part.json`; `--collect` crosses the parts.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use serde_json::Value;

use super::{JobFolder, Project, STATEPOINT, SweepError, Written, io, quoted, signac};
use crate::free_energy::{
    BranchPoint, Coexistence, CoexistenceOptions, CoexistencePart, EquationOfState,
    FreeEnergyError, FrenkelLadd, PartResult, PathChoices, Phase, PhaseScene, check_phases,
    coexistence_of_parts, coexistence_part,
};
use crate::run::Progress;
use crate::scene::{Scene, ValidScene};

/// The study's description, at the workspace's root.
pub const STUDY_FILE: &str = "coexistence.json";
/// A part's result, in its job's folder.
pub const PART_FILE: &str = "part.json";
/// The log of a part's scene run, in its job's folder.
pub const PART_LOG: &str = "log.mcap";

/// What `coexistence.json` records: both scenes and the path choices,
/// all a job needs to run its part.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoexistenceStudy {
    /// The fluid's scene text.
    pub fluid: String,
    /// The crystal's scene text.
    pub solid: String,
    /// The paths' flags.
    pub choices: PathChoices,
    /// The hardbody that made it.
    pub version: String,
}

/// A study's scenes, checked, and the options its paths run with.
pub struct StudyPlan {
    /// The fluid's scene.
    pub fluid: ValidScene,
    /// The crystal's scene.
    pub solid: ValidScene,
    /// The fluid's path, the crystal's and the branches'.
    pub options: (EquationOfState, FrenkelLadd, CoexistenceOptions),
}

impl CoexistenceStudy {
    /// The scenes validated and the options resolved (the seed is the
    /// fluid scene's unless chosen, as the local command does).
    pub fn plan(&self) -> Result<StudyPlan, SweepError> {
        let scene = |text: &str, role: &str| {
            Scene::parse(text).map_err(|e| SweepError::Workspace {
                path: PathBuf::from(STUDY_FILE),
                message: format!("its {role} scene: {e}"),
            })
        };
        let fluid = scene(&self.fluid, "fluid")?;
        let solid = scene(&self.solid, "solid")?;
        check_phases(&fluid, &solid).map_err(|e| SweepError::Workspace {
            path: PathBuf::from(STUDY_FILE),
            message: e.to_string(),
        })?;
        let options = self.choices.coexistence(fluid.seed);
        options.2.check().map_err(|e| SweepError::Workspace {
            path: PathBuf::from(STUDY_FILE),
            message: e.to_string(),
        })?;
        Ok(StudyPlan {
            fluid,
            solid,
            options,
        })
    }
}

/// A part's state point and signac id.
pub fn part_job(part: CoexistencePart) -> (Value, String) {
    let statepoint = serde_json::to_value(part).expect("a part serialises");
    let id = signac::job_id(&statepoint);
    (statepoint, id)
}

/// Writes the study at `dir`: the signac project, `coexistence.json`, a
/// row `workflow.toml` running `hardbody` at `exe`, and a folder per
/// part. As for a sweep, what is there is kept and another study there
/// is refused.
pub fn write_study(
    dir: &Path,
    study: &CoexistenceStudy,
    exe: &Path,
) -> Result<Written, SweepError> {
    let plan = study.plan()?;
    let jobs: Vec<JobFolder> = (CoexistencePart::all(&plan.options.2).into_iter())
        .map(|part| {
            let (statepoint, id) = part_job(part);
            JobFolder {
                id,
                statepoint,
                files: Vec::new(),
            }
        })
        .collect();
    super::write_project(
        dir,
        &Project {
            record_file: STUDY_FILE,
            record: serde_json::to_string_pretty(study).expect("a study serialises"),
            kind: "coexistence study",
            other: "other scenes or path flags",
            workflow: workflow_toml(exe),
        },
        |old| {
            let old: CoexistenceStudy = serde_json::from_str(old)?;
            Ok(
                old.fluid == study.fluid
                    && old.solid == study.solid
                    && old.choices == study.choices,
            )
        },
        &jobs,
    )
}

/// The `workflow.toml` of a study: the anchors (each a Frenkel–Ladd or
/// equation-of-state path, parallel over its points) and the branch
/// points (one core each) as two actions.
pub fn workflow_toml(exe: &Path) -> String {
    let exe = quoted(exe);
    let action = |name: &str, threads: usize, walltime: &str| {
        format!(
            r#"
[[action]]
name = "{name}"
command = "{exe} coexistence --job {{workspace_path}}/{{directory}} --threads $ACTION_THREADS_PER_PROCESS"
products = ["{PART_FILE}"]
[action.resources]
threads_per_process = {threads}
walltime.per_directory = "{walltime}"
[action.group]
maximum_size = 1
[[action.group.include]]
condition = ["/part", "==", "{name}"]
"#
        )
    };
    format!(
        r#"# A hardbody coexistence study, for row (https://row.readthedocs.io):
# `row submit` runs every part (`--cluster=none`: here, one after the
# other). Each part runs its phase's scene again, then its anchor's free
# energy or one point of its branch; `hardbody coexistence --collect .`
# crosses them once all are done.

[workspace]
path = "workspace"
value_file = "{STATEPOINT}"
{}{}"#,
        action("anchor", 4, "04:00:00"),
        action("branch", 1, "01:00:00")
    )
}

/// The study at `dir`.
pub fn read_study(dir: &Path) -> Result<CoexistenceStudy, SweepError> {
    super::read_record(
        &dir.join(STUDY_FILE),
        "a coexistence study's folder",
        "a coexistence study's record",
    )
}

/// Why a part could not be run.
#[derive(Debug, thiserror::Error)]
pub enum PartError {
    /// The job's folder or its study.
    #[error(transparent)]
    Workspace(#[from] SweepError),
    /// The part's computation.
    #[error(transparent)]
    FreeEnergy(#[from] FreeEnergyError),
}

impl PartError {
    /// Whether the input (the folder, the study) is at fault rather
    /// than the computation.
    pub fn is_bad_input(&self) -> bool {
        match self {
            PartError::Workspace(_) => true,
            PartError::FreeEnergy(e) => e.is_bad_input(),
        }
    }
}

/// The part of the job at `job` (a folder of a study's workspace) and
/// the study's root.
pub fn job_part(job: &Path) -> Result<(CoexistencePart, PathBuf), SweepError> {
    let part = super::read_record(
        &job.join(STATEPOINT),
        "a job's folder of a coexistence study",
        "a coexistence part's state point",
    )?;
    let root = job
        .parent()
        .and_then(Path::parent)
        .ok_or_else(|| SweepError::Workspace {
            path: job.to_path_buf(),
            message: "not in a study's workspace folder".into(),
        })?;
    Ok((part, root.to_path_buf()))
}

/// Runs the part of the job at `job` and writes its result to
/// `part.json` there (through a temporary file: a part killed part way
/// leaves none); the scene's log goes to `log.mcap` beside it.
pub fn run_job(
    job: &Path,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<(CoexistencePart, PartResult), PartError> {
    let (part, root) = job_part(job)?;
    let study = read_study(&root)?;
    let plan = study.plan()?;
    if !CoexistencePart::all(&plan.options.2).contains(&part) {
        return Err(SweepError::Workspace {
            path: job.join(STATEPOINT),
            message: format!("{part} is no part of this study"),
        }
        .into());
    }
    let log = job.join(PART_LOG);
    let (o0, o1, o2) = &plan.options;
    let result = coexistence_part(
        PhaseScene {
            scene: &plan.fluid,
            text: &study.fluid,
            log: &log,
        },
        PhaseScene {
            scene: &plan.solid,
            text: &study.solid,
            log: &log,
        },
        (o0, o1, o2),
        part,
        progress,
        stop,
    )?;
    let text = serde_json::to_string_pretty(&result).expect("a result serialises");
    super::write_new(&job.join(PART_FILE), &text)?;
    Ok((part, result))
}

/// The parts of a study read back: each phase's anchor and branch.
pub struct CollectedParts {
    /// The study.
    pub study: CoexistenceStudy,
    /// The branches' options.
    pub options: CoexistenceOptions,
    /// The fluid's anchor and its branch's points in order.
    pub fluid: (PartResult, Vec<BranchPoint>),
    /// The crystal's.
    pub solid: (PartResult, Vec<BranchPoint>),
}

impl CollectedParts {
    /// The coexistence the parts give.
    pub fn crossed(&self) -> Result<Coexistence, FreeEnergyError> {
        coexistence_of_parts(
            (&self.fluid.0, &self.fluid.1),
            (&self.solid.0, &self.solid.1),
            &self.options,
        )
    }
}

/// Every part of the study at `dir` read from its job's `part.json`; a
/// part not done (or whose result is of another kind) is named with its
/// folder.
pub fn collect_parts(dir: &Path) -> Result<CollectedParts, SweepError> {
    let study = read_study(dir)?;
    let options = study.plan()?.options.2;
    let parts = CoexistencePart::all(&options);
    let mut missing = Vec::new();
    let mut fluid = (None, Vec::new());
    let mut solid = (None, Vec::new());
    for &part in &parts {
        let (_, id) = part_job(part);
        let path = dir.join("workspace").join(&id).join(PART_FILE);
        let result = match std::fs::read_to_string(&path) {
            Ok(text) => {
                serde_json::from_str::<PartResult>(&text).map_err(|e| SweepError::Workspace {
                    path: path.clone(),
                    message: format!("not a part's result: {e}"),
                })?
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                missing.push(format!("{part} (workspace/{id})"));
                continue;
            }
            Err(e) => return Err(io(&path)(e)),
        };
        let branch = match part.phase() {
            Phase::Fluid => &mut fluid,
            Phase::Crystal => &mut solid,
        };
        match (part, result) {
            (CoexistencePart::Anchor { .. }, anchor @ PartResult::Anchor { .. }) => {
                branch.0 = Some(anchor)
            }
            (CoexistencePart::Branch { .. }, PartResult::Point(point)) => branch.1.push(point),
            _ => {
                return Err(SweepError::Workspace {
                    path,
                    message: format!("holds another kind of result than {part}"),
                });
            }
        }
    }
    if !missing.is_empty() {
        return Err(SweepError::Workspace {
            path: dir.to_path_buf(),
            message: format!(
                "{} of the study's {} parts are not done: {}; run them (`row submit`, or \
                 `hardbody coexistence --job FOLDER` each) and collect again",
                missing.len(),
                parts.len(),
                missing.join(", ")
            ),
        });
    }
    let done = |(anchor, points): (Option<PartResult>, Vec<BranchPoint>)| {
        (anchor.expect("every part is there"), points)
    };
    Ok(CollectedParts {
        study,
        options,
        fluid: done(fluid),
        solid: done(solid),
    })
}
