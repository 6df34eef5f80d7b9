//! A signac project with a row workflow written in place: the project
//! marker, its record, its `workflow.toml` and a folder per job, each
//! file through a temporary file, nothing there overwritten.

use std::path::Path;

use serde_json::Value;

use super::{STATEPOINT, SweepError, signac};

/// What `write_workspace` did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// Job folders made.
    pub made: usize,
    /// Job folders already there (left as they were).
    pub kept: usize,
}

pub(crate) fn io(path: &Path) -> impl Fn(std::io::Error) -> SweepError + '_ {
    move |e| SweepError::Output(crate::log::file::OutputError::io(path, &e))
}

/// `exe` as a shell word: as it is if plain, else in single quotes.
pub(crate) fn quoted(exe: &Path) -> String {
    let exe = exe.display().to_string();
    if exe
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || "/._-+".contains(c))
    {
        exe
    } else {
        format!("'{}'", exe.replace('\'', r"'\''"))
    }
}

/// A signac project with a row workflow, as `write_project` makes it.
pub(crate) struct Project {
    /// The record of what the project is, at its root.
    pub record_file: &'static str,
    /// Its text.
    pub record: String,
    /// What it is (`sweep`).
    pub kind: &'static str,
    /// What would make a record there another project's.
    pub other: &'static str,
    /// Its `workflow.toml`.
    pub workflow: String,
}

/// One job's folder: its id, its state point and the files beside it.
pub(crate) struct JobFolder {
    /// signac's id of the state point.
    pub id: String,
    /// The state point.
    pub statepoint: Value,
    /// Other files, by name.
    pub files: Vec<(&'static str, String)>,
}

/// The JSON record at `path`; a file that cannot be read is asked
/// whether it is `folder`, one that does not parse is said not to be
/// `record`.
pub(crate) fn read_record<T: serde::de::DeserializeOwned>(
    path: &Path,
    folder: &str,
    record: &str,
) -> Result<T, SweepError> {
    let text = std::fs::read_to_string(path).map_err(|e| SweepError::Workspace {
        path: path.to_path_buf(),
        message: format!("{e} (is this {folder}?)"),
    })?;
    serde_json::from_str(&text).map_err(|e| SweepError::Workspace {
        path: path.to_path_buf(),
        message: format!("not {record}: {e}"),
    })
}

/// Writes `project` at `dir` and a folder per job, keeping the
/// `workflow.toml` and job folders already there; a record there that
/// `same` does not take for this project's is refused. A project this
/// call began (no folder, or an empty one) that cannot be finished is
/// removed again, so that the next call starts it afresh.
pub(crate) fn write_project(
    dir: &Path,
    project: &Project,
    same: impl Fn(&str) -> Result<bool, serde_json::Error>,
    jobs: &[JobFolder],
) -> Result<Written, SweepError> {
    let new = !dir.exists() || std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_none());
    let written = write_into(dir, project, same, jobs);
    if new && written.is_err() {
        let _ = std::fs::remove_dir_all(dir);
    }
    written
}

fn write_into(
    dir: &Path,
    project: &Project,
    same: impl Fn(&str) -> Result<bool, serde_json::Error>,
    jobs: &[JobFolder],
) -> Result<Written, SweepError> {
    let kind = project.kind;
    let record_path = dir.join(project.record_file);
    if record_path.exists() {
        let text = std::fs::read_to_string(&record_path).map_err(io(&record_path))?;
        let same = same(&text).map_err(|e| SweepError::Workspace {
            path: record_path.clone(),
            message: format!("not a {kind}'s record: {e}"),
        })?;
        if !same {
            return Err(SweepError::Workspace {
                path: dir.to_path_buf(),
                message: format!(
                    "holds another {kind} ({}): choose another --workspace",
                    project.other
                ),
            });
        }
    } else if dir.exists() && std::fs::read_dir(dir).map_err(io(dir))?.next().is_some() {
        return Err(SweepError::Workspace {
            path: dir.to_path_buf(),
            message: format!(
                "exists and is not a {kind}'s workspace: choose a new or empty folder"
            ),
        });
    }
    let signac_dir = dir.join(".signac");
    std::fs::create_dir_all(&signac_dir).map_err(io(&signac_dir))?;
    let config = signac_dir.join("config");
    if !config.exists() {
        write_new(&config, signac::PROJECT_CONFIG)?;
    }
    if !record_path.exists() {
        write_new(&record_path, &project.record)?;
    }
    let workflow = dir.join("workflow.toml");
    if !workflow.exists() {
        write_new(&workflow, &project.workflow)?;
    }
    let workspace = dir.join("workspace");
    let mut written = Written { made: 0, kept: 0 };
    for job in jobs {
        let folder = workspace.join(&job.id);
        if folder.join(STATEPOINT).exists() {
            written.kept += 1;
            continue;
        }
        std::fs::create_dir_all(&folder).map_err(io(&folder))?;
        for (name, text) in &job.files {
            write_new(&folder.join(name), text)?;
        }
        // The state point last: a folder with one is complete.
        write_new(
            &folder.join(STATEPOINT),
            &signac::python_json(&job.statepoint),
        )?;
        written.made += 1;
    }
    Ok(written)
}

/// Writes `text` to `path` through a temporary file renamed into place.
pub(crate) fn write_new(path: &Path, text: &str) -> Result<(), SweepError> {
    crate::log::file::write_replacing(path, text.as_bytes()).map_err(SweepError::from)
}
