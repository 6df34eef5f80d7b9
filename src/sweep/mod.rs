//! Studies as signac workspaces that row runs. Parameter sweeps
//! (`hardbody sweep`): a template scene, the values of some of its fields
//! and replicas make one job folder each, with its state point and scene;
//! `collect` reads their logs back into one row per state point.
//! Coexistence studies (`hardbody coexistence --workspace`): a job per
//! part of a coexistence.
//!
//! - `mod.rs`: fields addressed by path, the jobs of a sweep and their
//!   workspace;
//! - `workspace.rs`: a project's folders and files written in place;
//! - `signac.rs`: job ids as signac computes them;
//! - `collect.rs`: the jobs' status and averages over replicas;
//! - `coexistence.rs`: a coexistence study's jobs, run and read back.

pub mod coexistence;
pub mod collect;
pub mod signac;
mod workspace;

pub use workspace::Written;
pub(crate) use workspace::{JobFolder, Project, io, quoted, read_record, write_new, write_project};

use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use crate::scene::{Scene, ValidScene};

/// Why a sweep cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// A `--set` that is not `KEY=V1,V2,...`.
    #[error("--set {0:?}: expected KEY=V1,V2,... (e.g. stages[1].ensemble.pressure=1,2,4)")]
    Syntax(String),
    /// A key that names no field of the scene.
    #[error("--set {key}: {reason}")]
    Key {
        /// The key given.
        key: String,
        /// What is wrong.
        reason: KeyError,
    },
    /// A value the scene refuses.
    #[error("--set {key}={value}: {reason}")]
    Value {
        /// The key.
        key: String,
        /// The value.
        value: String,
        /// The scene's refusal.
        reason: ValueError,
    },
    /// Replicas and seeds both given, or none of either.
    #[error("{0}")]
    Replicas(String),
    /// The workspace could not be written, or holds another sweep.
    #[error("{path}: {message}")]
    Workspace {
        /// The file or folder.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A file or folder of the workspace could not be made (a full or
    /// read-only file system among the reasons).
    #[error(transparent)]
    Output(#[from] crate::log::file::OutputError),
}

/// Why a `--set` key names no field of the scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KeyError {
    /// A part of the path that is no field name.
    #[error("{0:?} is not a field name")]
    NotAFieldName(String),
    /// `[` without its `]`.
    #[error("{0:?}: an unclosed [")]
    Unclosed(String),
    /// Brackets around something other than an index.
    #[error("{part:?}: {index:?} is not an index")]
    NotAnIndex {
        /// The part of the path.
        part: String,
        /// Between the brackets.
        index: String,
    },
    /// Text after a part's last `]`.
    #[error("{part:?}: unexpected {rest:?}")]
    Trailing {
        /// The part of the path.
        part: String,
        /// What follows.
        rest: String,
    },
    /// A table without the field named.
    #[error("{within} has no field {name:?} (its fields: {fields})")]
    NoField {
        /// The table (`the scene` at the top).
        within: String,
        /// The field asked for.
        name: String,
        /// The fields it has.
        fields: String,
    },
    /// An index past a list's end.
    #[error("{within} has {entries} entries, no [{index}]")]
    NoEntry {
        /// The list.
        within: String,
        /// Its length.
        entries: usize,
        /// The index asked for.
        index: usize,
    },
    /// A field asked of a value.
    #[error("{within} is a value, not a table with {name:?}")]
    NotATable {
        /// The value.
        within: String,
        /// The field asked for.
        name: String,
    },
    /// An index taken of something that is no list.
    #[error("{within} is not a list to take [{index}] of")]
    NotAList {
        /// What was indexed.
        within: String,
        /// The index.
        index: usize,
    },
    /// The same key twice.
    #[error("given twice")]
    GivenTwice,
}

/// Why the scene refuses a swept value.
#[derive(Debug, thiserror::Error)]
pub enum ValueError {
    /// The value does not fit the field's type.
    #[error("{0}")]
    Type(#[from] serde_json::Error),
    /// The scene it makes does not pass its check (boxed: every part's
    /// problem is in it).
    #[error("{0}")]
    Scene(Box<crate::scene::SceneError>),
    /// The same value twice for one key.
    #[error("given twice")]
    GivenTwice,
}

impl crate::log::StorageFailure for SweepError {
    fn is_storage_failure(&self) -> bool {
        matches!(self, SweepError::Output(e) if e.is_storage_failure())
    }
}

/// One segment of a field path: `stages[1]` is `stages` then index 1.
#[derive(Debug, Clone, PartialEq)]
enum Segment {
    Field(String),
    Index(usize),
}

fn parse_path(key: &str) -> Result<Vec<Segment>, KeyError> {
    let mut segments = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(KeyError::NotAFieldName(part.into()));
        }
        segments.push(Segment::Field(name.to_string()));
        while let Some(stripped) = rest.strip_prefix('[') {
            let close = stripped
                .find(']')
                .ok_or_else(|| KeyError::Unclosed(part.into()))?;
            let index = stripped[..close]
                .parse()
                .map_err(|_| KeyError::NotAnIndex {
                    part: part.into(),
                    index: stripped[..close].into(),
                })?;
            segments.push(Segment::Index(index));
            rest = &stripped[close + 1..];
        }
        if !rest.is_empty() {
            return Err(KeyError::Trailing {
                part: part.into(),
                rest: rest.into(),
            });
        }
    }
    Ok(segments)
}

/// The value at `path` in the JSON of a scene, looking through the tags
/// of enum variants (`stages[1].ensemble.pressure` in `{"MonteCarlo":
/// {"ensemble": {"Npt": {"pressure": ...}}}}`).
fn field_mut<'v>(root: &'v mut Value, path: &[Segment]) -> Result<&'v mut Value, KeyError> {
    let mut here = root;
    let mut walked = String::new();
    for segment in path {
        // Through a variant's tag: an object of one key, a capitalised
        // variant name, holding its fields.
        if let (Segment::Field(name), Value::Object(map)) = (segment, &*here)
            && !map.contains_key(name)
            && map.len() == 1
            && map
                .keys()
                .next()
                .is_some_and(|k| k.starts_with(|c: char| c.is_ascii_uppercase()))
        {
            here = here
                .as_object_mut()
                .and_then(|m| m.values_mut().next())
                .expect("one key");
        }
        here = match (segment, here) {
            (Segment::Field(name), Value::Object(map)) => {
                let fields: Vec<String> = map.keys().cloned().collect();
                map.get_mut(name).ok_or_else(|| KeyError::NoField {
                    within: if walked.is_empty() {
                        "the scene".into()
                    } else {
                        walked.clone()
                    },
                    name: name.clone(),
                    fields: fields.join(", "),
                })?
            }
            (Segment::Index(i), Value::Array(items)) => {
                let n = items.len();
                items.get_mut(*i).ok_or_else(|| KeyError::NoEntry {
                    within: walked.clone(),
                    entries: n,
                    index: *i,
                })?
            }
            (Segment::Field(name), _) => {
                return Err(KeyError::NotATable {
                    within: walked,
                    name: name.clone(),
                });
            }
            (Segment::Index(i), _) => {
                return Err(KeyError::NotAList {
                    within: walked,
                    index: *i,
                });
            }
        };
        match segment {
            Segment::Field(name) if walked.is_empty() => walked.push_str(name),
            Segment::Field(name) => {
                walked.push('.');
                walked.push_str(name);
            }
            Segment::Index(i) => walked.push_str(&format!("[{i}]")),
        }
    }
    Ok(here)
}

/// A value as written after `=`: an integer, a float, true or false, or
/// else a string.
fn parse_value(text: &str) -> Value {
    let t = text.trim();
    if let Ok(i) = t.parse::<i64>() {
        return Value::from(i);
    }
    if let Ok(x) = t.parse::<f64>()
        && x.is_finite()
    {
        return Value::from(x);
    }
    match t {
        "true" => Value::Bool(true),
        "false" => Value::Bool(false),
        _ => Value::String(t.to_string()),
    }
}

/// One swept field: its path in the scene, its name in the state point
/// and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Swept {
    /// The path given (`stages[1].ensemble.pressure`).
    pub key: String,
    /// The state point's name for it (`pressure`).
    pub name: String,
    /// The values, in the order given.
    pub values: Vec<Value>,
}

/// Reads `--set KEY=V1,V2,...` arguments and checks every value against
/// the template: each must give a scene the template's validation
/// accepts.
pub fn parse_sets(template: &Scene, sets: &[String]) -> Result<Vec<Swept>, SweepError> {
    let base = serde_json::to_value(template).expect("a scene serialises");
    let mut swept: Vec<Swept> = Vec::new();
    for set in sets {
        let (key, values) = set
            .split_once('=')
            .ok_or_else(|| SweepError::Syntax(set.clone()))?;
        let key = key.trim();
        let values: Vec<&str> = values.split(',').map(str::trim).collect();
        if key.is_empty() || values.iter().any(|v| v.is_empty()) {
            return Err(SweepError::Syntax(set.clone()));
        }
        let path = parse_path(key).map_err(|reason| SweepError::Key {
            key: key.into(),
            reason,
        })?;
        if swept.iter().any(|s| s.key == key) {
            return Err(SweepError::Key {
                key: key.into(),
                reason: KeyError::GivenTwice,
            });
        }
        let mut parsed = Vec::with_capacity(values.len());
        for value in values {
            let v = parse_value(value);
            let mut scene = base.clone();
            *field_mut(&mut scene, &path).map_err(|reason| SweepError::Key {
                key: key.into(),
                reason,
            })? = v.clone();
            scene_of(scene).map_err(|reason| SweepError::Value {
                key: key.into(),
                value: value.into(),
                reason,
            })?;
            if parsed.contains(&v) {
                return Err(SweepError::Value {
                    key: key.into(),
                    value: value.into(),
                    reason: ValueError::GivenTwice,
                });
            }
            parsed.push(v);
        }
        swept.push(Swept {
            key: key.into(),
            name: String::new(),
            values: parsed,
        });
    }
    name_swept(&mut swept);
    Ok(swept)
}

/// State-point names: each key's last field, or as many of its last
/// fields as tell it from the others (`ensemble_pressure`), joined by
/// `_`, indices included (`species_0_shape_a`).
fn name_swept(swept: &mut [Swept]) {
    let words = |key: &str| -> Vec<String> {
        parse_path(key)
            .expect("checked")
            .into_iter()
            .map(|s| match s {
                Segment::Field(f) => f,
                Segment::Index(i) => i.to_string(),
            })
            .collect()
    };
    let all: Vec<Vec<String>> = swept.iter().map(|s| words(&s.key)).collect();
    for (k, s) in swept.iter_mut().enumerate() {
        let mine = &all[k];
        let mut take = 1;
        // The shortest tail no other key shares (indices count as fields
        // but never stand alone).
        loop {
            let tail = |w: &Vec<String>| w[w.len().saturating_sub(take)..].to_vec();
            let unique = all
                .iter()
                .enumerate()
                .all(|(j, other)| j == k || tail(other) != tail(mine));
            let starts_with_index = mine[mine.len().saturating_sub(take)]
                .chars()
                .all(|c| c.is_ascii_digit());
            if (unique && !starts_with_index) || take >= mine.len() {
                break;
            }
            take += 1;
        }
        s.name = mine[mine.len().saturating_sub(take)..].join("_");
    }
}

fn scene_of(value: Value) -> Result<ValidScene, ValueError> {
    let scene: Scene = serde_json::from_value(value)?;
    scene
        .validated()
        .map_err(|e| ValueError::Scene(Box::new(e)))
}

/// One job of a sweep: its state point, its id and its scene.
#[derive(Debug, Clone)]
pub struct Job {
    /// The swept values by name, and the seed.
    pub statepoint: Value,
    /// signac's id of the state point.
    pub id: String,
    /// The template with the values and the seed set, logging to
    /// `log.mcap` in the job's folder, validated again.
    pub scene: ValidScene,
}

/// The most jobs one sweep may make (each a folder of the workspace).
pub const MAX_JOBS: u64 = 100_000;

/// The jobs of a sweep: the product of the swept values, each with
/// `replicas` seeds (the template's seed, then the next ones), unless
/// the seed itself is swept.
pub fn jobs(template: &Scene, swept: &[Swept], replicas: u64) -> Result<Vec<Job>, SweepError> {
    let seed_swept = swept.iter().any(|s| s.key == "seed");
    if replicas == 0 {
        return Err(SweepError::Replicas("--replicas must be at least 1".into()));
    }
    if seed_swept && replicas > 1 {
        return Err(SweepError::Replicas(
            "--replicas with --set seed=...: the seeds given are the replicas".into(),
        ));
    }
    // Counted before anything is made: every job is a folder.
    let count = swept
        .iter()
        .try_fold(replicas, |n, s| n.checked_mul(s.values.len() as u64))
        .filter(|&n| n <= MAX_JOBS);
    if count.is_none() {
        return Err(SweepError::Replicas(format!(
            "{} state points times {replicas} replicas: at most {MAX_JOBS} jobs in one sweep",
            swept
                .iter()
                .map(|s| s.values.len().to_string())
                .collect::<Vec<_>>()
                .join(" x ")
        )));
    }
    let base = serde_json::to_value(template).expect("a scene serialises");
    let mut combinations: Vec<Vec<&Value>> = vec![Vec::new()];
    for s in swept {
        combinations = combinations
            .into_iter()
            .flat_map(|c| {
                s.values.iter().map(move |v| {
                    let mut c = c.clone();
                    c.push(v);
                    c
                })
            })
            .collect();
    }
    let mut out = Vec::new();
    for combination in combinations {
        for replica in 0..replicas {
            let mut value = base.clone();
            let mut statepoint = Map::new();
            for (s, v) in swept.iter().zip(&combination) {
                let path = parse_path(&s.key).expect("checked");
                *field_mut(&mut value, &path).expect("checked") = (*v).clone();
                statepoint.insert(s.name.clone(), (*v).clone());
            }
            if !seed_swept {
                let seed = template.seed.wrapping_add(replica);
                value["seed"] = Value::from(seed);
                statepoint.insert("seed".into(), Value::from(seed));
            }
            value["log"]["path"] = Value::from(JOB_LOG);
            let scene = scene_of(value).map_err(|reason| SweepError::Value {
                key: swept
                    .iter()
                    .map(|s| s.key.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                value: combination
                    .iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                reason,
            })?;
            let statepoint = Value::Object(statepoint);
            out.push(Job {
                id: signac::job_id(&statepoint),
                statepoint,
                scene,
            });
        }
    }
    Ok(out)
}

/// A job's log, in its folder.
pub const JOB_LOG: &str = "log.mcap";
/// A job's scene, in its folder.
pub const JOB_SCENE: &str = "scene.ron";
/// A job's state point, in its folder (signac's name).
pub const STATEPOINT: &str = "signac_statepoint.json";
/// The sweep's description, at the workspace's root.
pub const SWEEP_FILE: &str = "sweep.json";

/// What `sweep.json` records of a sweep.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepRecord {
    /// The template's text.
    pub template: String,
    /// Swept fields: state-point name to scene path.
    pub keys: Vec<(String, String)>,
    /// The hardbody that made it.
    pub version: String,
}

/// The `workflow.toml` of a sweep, running `hardbody` at `exe`.
pub fn workflow_toml(exe: &Path) -> String {
    let quoted = quoted(exe);
    format!(
        r#"# A hardbody sweep, for row (https://row.readthedocs.io): `row submit`
# runs every job (`--cluster=none`: here, one after the other); a job
# killed part way (preempted, out of time) resumes from its partial log
# when submitted again. `hardbody sweep collect .` gathers the results.
# Each job is one submission of one core; docs/CLUSTER.md in hardbody's
# repository shows how to pack many jobs into one submission instead.

[workspace]
path = "workspace"
value_file = "{STATEPOINT}"

[[action]]
name = "run"
command = "{quoted} run {{workspace_path}}/{{directory}}/{JOB_SCENE} --out {{workspace_path}}/{{directory}}/{JOB_LOG} --continue --threads $ACTION_THREADS_PER_PROCESS"
products = ["{JOB_LOG}"]
[action.resources]
threads_per_process = 1
walltime.per_directory = "01:00:00"
[action.group]
maximum_size = 1

[[action]]
name = "analyze"
command = "{quoted} analyze {{workspace_path}}/{{directory}}/{JOB_LOG} --json > {{workspace_path}}/{{directory}}/analysis.json.partial && mv {{workspace_path}}/{{directory}}/analysis.json.partial {{workspace_path}}/{{directory}}/analysis.json"
previous_actions = ["run"]
products = ["analysis.json"]
[action.resources]
walltime.per_directory = "00:05:00"
"#
    )
}

/// Writes the sweep at `dir`: the signac project marker, `sweep.json`,
/// `workflow.toml` (kept if there: it may have been edited) and a folder
/// per job (kept if there: it may hold a run). A `dir` holding another
/// sweep (another template or other keys) is refused. A workspace this
/// call began (no folder, or an empty one) that cannot be finished is
/// removed again, so that the next call starts it afresh.
pub fn write_workspace(
    dir: &Path,
    template_text: &str,
    swept: &[Swept],
    jobs: &[Job],
    exe: &Path,
) -> Result<Written, SweepError> {
    let record = SweepRecord {
        template: template_text.to_string(),
        keys: swept
            .iter()
            .map(|s| (s.name.clone(), s.key.clone()))
            .collect(),
        version: env!("CARGO_PKG_VERSION").into(),
    };
    let folders: Vec<JobFolder> = (jobs.iter())
        .map(|job| JobFolder {
            id: job.id.clone(),
            statepoint: job.statepoint.clone(),
            files: vec![(JOB_SCENE, job.scene.to_ron())],
        })
        .collect();
    write_project(
        dir,
        &Project {
            record_file: SWEEP_FILE,
            record: serde_json::to_string_pretty(&record).expect("a record serialises"),
            kind: "sweep",
            other: "another template or other --set keys",
            workflow: workflow_toml(exe),
        },
        |old| {
            let old: SweepRecord = serde_json::from_str(old)?;
            Ok(old.template == record.template && old.keys == record.keys)
        },
        &folders,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEMPLATE: &str = r#"Scene(
        box: (8.0, 8.0, 8.0),
        species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 64)],
        stages: [
            Compress(packing_fraction: 0.2),
            MonteCarlo(ensemble: Npt(pressure: 1.0), sweeps: 100),
        ],
    )"#;

    #[test]
    fn keys_address_fields_through_enum_tags() {
        let template = Scene::parse(TEMPLATE).unwrap();
        let sets = vec![
            "stages[1].ensemble.pressure=1,2.5".to_string(),
            "species[0].shape.radius=0.5, 0.45".to_string(),
        ];
        let swept = parse_sets(&template, &sets).unwrap();
        assert_eq!(swept[0].name, "pressure");
        assert_eq!(swept[1].name, "radius");
        let jobs = jobs(&template, &swept, 3).unwrap();
        assert_eq!(jobs.len(), 2 * 2 * 3);
        let last = &jobs[11];
        assert_eq!(
            last.statepoint,
            serde_json::json!({"pressure": 2.5, "radius": 0.45, "seed": 3})
        );
        assert_eq!(last.scene.seed, 3);
        assert_eq!(last.scene.log.path, JOB_LOG);
        let ids: std::collections::BTreeSet<_> = jobs.iter().map(|j| &j.id).collect();
        assert_eq!(ids.len(), jobs.len());
    }

    #[test]
    fn bad_keys_and_values_are_refused_naming_them() {
        let template = Scene::parse(TEMPLATE).unwrap();
        let refuse = |set: &str| {
            parse_sets(&template, &[set.to_string()])
                .unwrap_err()
                .to_string()
        };
        assert!(refuse("stages[1].ensemble.presure=1").contains("no field \"presure\""));
        assert!(refuse("stages[5].sweeps=1").contains("has 2 entries"));
        assert!(refuse("stages[1].ensemble.pressure=-1").contains("pressure"));
        assert!(refuse("stages[1].sweeps=many").contains("sweeps=many"));
        assert!(refuse("stages[1].sweeps").contains("KEY=V1,V2"));
        assert!(refuse("stages[1].sweeps=1,,2").contains("KEY=V1,V2"));
        assert!(refuse("stages[1].sweeps=5,5").contains("given twice"));
        // The reasons are types a caller can match.
        let reason = |set: &str| parse_sets(&template, &[set.to_string()]).unwrap_err();
        assert!(matches!(
            reason("stages[5].sweeps=1"),
            SweepError::Key {
                reason: KeyError::NoEntry {
                    entries: 2,
                    index: 5,
                    ..
                },
                ..
            }
        ));
        assert!(matches!(
            reason("stages[1.sweeps=1"),
            SweepError::Key {
                reason: KeyError::Unclosed(_),
                ..
            }
        ));
        assert!(matches!(
            reason("stages[1].ensemble.pressure=-1"),
            SweepError::Value {
                reason: ValueError::Scene(_),
                ..
            }
        ));
        assert!(matches!(
            reason("stages[1].sweeps=many"),
            SweepError::Value {
                reason: ValueError::Type(_),
                ..
            }
        ));
        let swept = parse_sets(&template, &["seed=1,2".to_string()]).unwrap();
        assert!(jobs(&template, &swept, 2).is_err());
    }

    #[test]
    fn names_tell_keys_with_the_same_last_field_apart() {
        let template = Scene::parse(&TEMPLATE.replace(
            "sweeps: 100),",
            "sweeps: 100), MonteCarlo(ensemble: Npt(pressure: 2.0), sweeps: 100),",
        ))
        .unwrap();
        let swept = parse_sets(
            &template,
            &[
                "stages[1].ensemble.pressure=1".into(),
                "stages[2].ensemble.pressure=3".into(),
            ],
        )
        .unwrap();
        assert_eq!(swept[0].name, "stages_1_ensemble_pressure");
        assert_eq!(swept[1].name, "stages_2_ensemble_pressure");
    }
}
