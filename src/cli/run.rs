//! `run`, `run --resume` and `check`: a scene from file to log, Ctrl-C
//! handled, and the same refusals before anything runs.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use std::sync::atomic::{AtomicBool, Ordering};

use hardbody::log::file::check_output;
use hardbody::run::{Progress, RunError, RunSummary, check_start, resume_run, run_scene};
use hardbody::scene::plan::{Plan, Report};
use hardbody::scene::{Scene, ValidScene};

use super::*;

/// The built-in default scene.
pub(super) const DEFAULT_SCENE: &str = include_str!("../../data/scenes/default.ron");

/// Why a scene file, or a log found where a job's log goes, is refused.
#[derive(Debug, thiserror::Error)]
pub(super) enum Refusal {
    /// The scene file cannot be read.
    #[error("cannot read scene {}: {source}", .path.display())]
    Unreadable {
        path: PathBuf,
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The scene does not parse or validate.
    #[error("{}: {source}", .path.display())]
    Invalid {
        path: PathBuf,
        source: hardbody::scene::SceneError,
    },
    /// The scene is valid but cannot run as written: the message names
    /// the file, the line and the field ([`scene_refusal`]).
    #[error("{0}")]
    CannotRun(String),
    /// A log with no scene in its metadata.
    #[error("{}: no readable scene in its metadata", .0.display())]
    LogWithoutScene(PathBuf),
    /// A log of another scene or seed than the job's.
    #[error(
        "{}: is a run of {what}; refusing to continue it or take it as this job's result (move it away to run {name} afresh)",
        .log.display()
    )]
    LogOfAnotherRun {
        log: PathBuf,
        what: String,
        name: String,
    },
}

/// Reads and validates a scene file; the error names the file, the line
/// and the field.
pub(super) fn load_scene(path: &std::path::Path) -> Result<(ValidScene, String), Refusal> {
    let unreadable = |source: Box<dyn std::error::Error + Send + Sync>| Refusal::Unreadable {
        path: path.to_path_buf(),
        source,
    };
    hardbody::log::file::check_input(path).map_err(|e| unreadable(Box::new(e)))?;
    let text = std::fs::read_to_string(path).map_err(|e| unreadable(Box::new(e)))?;
    let scene = Scene::parse(&text).map_err(|source| Refusal::Invalid {
        path: path.to_path_buf(),
        source,
    })?;
    Ok((scene, text))
}

pub(super) fn run(
    scene_path: Option<PathBuf>,
    out: Option<PathBuf>,
    seed: Option<u64>,
    resume: Option<PathBuf>,
) -> ExitCode {
    if let (Some(log), None) = (&resume, &scene_path) {
        return resume_log(log, out, seed);
    }
    let (mut scene, text) = match &scene_path {
        Some(p) => match load_scene(p) {
            Ok(s) => s,
            Err(e) => return bad_input(e),
        },
        None => (
            Scene::parse(DEFAULT_SCENE).expect("the default scene is valid"),
            DEFAULT_SCENE.to_string(),
        ),
    };
    if let Some(seed) = seed {
        scene = scene.with_seed(seed);
    }
    if let Some(log) = &resume {
        // Another start: the scene is checked again with it.
        let mut edited = scene.into_scene();
        edited.start = hardbody::scene::Start::Resume(log.display().to_string());
        scene = match edited.validated() {
            Ok(s) => s,
            Err(e) => return bad_input(e),
        };
    }
    if let Some(p) = &scene_path
        && let Err(e) = preflight(p, &text, &scene, out.is_some())
    {
        return bad_input(e);
    }
    let log_path = out.unwrap_or_else(|| PathBuf::from(&scene.log.path));
    let mut inputs: Vec<&std::path::Path> = scene_path
        .iter()
        .chain(&resume)
        .map(|p| p.as_path())
        .collect();
    if let hardbody::scene::Start::Resume(start) = &scene.start {
        inputs.push(std::path::Path::new(start));
    }
    if let Err(e) = check_output(&log_path, true, &inputs) {
        return bad_input(e);
    }
    handle_ctrl_c();
    let name = scene_path
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|| "the default scene".into());
    esay(&format!(
        "hardbody {}: running {name} ({} particles, {} stages, seed {}), log {}",
        env!("CARGO_PKG_VERSION"),
        scene.particle_count(),
        scene.stages.len(),
        scene.seed,
        log_path.display()
    ));
    let mut progress = progress_display();
    finish_run(run_scene(
        &scene,
        &text,
        &log_path,
        progress.as_mut(),
        &STOP,
    ))
}

pub(super) static STOP: AtomicBool = AtomicBool::new(false);

/// A first Ctrl-C (or SIGTERM, what a scheduler sends a job it preempts)
/// ends the run cleanly at the next sweep or output event; a second one
/// exits at once.
pub(super) fn handle_ctrl_c() {
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            std::process::exit(EXIT_INTERRUPTED as i32);
        }
    });
}

pub(super) fn progress_display() -> Box<dyn Progress> {
    if std::io::stderr().is_terminal() {
        Box::new(progress::Bars::default())
    } else {
        Box::new(progress::Lines::default())
    }
}

pub(super) fn resume_log(
    log: &std::path::Path,
    out: Option<PathBuf>,
    seed: Option<u64>,
) -> ExitCode {
    if seed.is_some() {
        return bad_input("--seed: a resumed run keeps the seed of the run it continues");
    }
    let out = out.unwrap_or_else(|| {
        let text = log.display().to_string();
        PathBuf::from(text.strip_suffix(".partial").unwrap_or(&text))
    });
    // The log resumed from may be the output's partial log: it is
    // replaced only once the new log holds as much.
    if let Err(e) = check_output(&out, true, &[]) {
        return bad_input(e);
    }
    handle_ctrl_c();
    esay(&format!(
        "hardbody {}: resuming {} from its last frame, log {}",
        env!("CARGO_PKG_VERSION"),
        log.display(),
        out.display()
    ));
    let mut progress = progress_display();
    finish_run(resume_run(log, &out, progress.as_mut(), &STOP))
}

pub(super) fn finish_run(result: Result<RunSummary, RunError>) -> ExitCode {
    match result {
        Ok(summary) => {
            for note in &summary.notes {
                esay(&format!("hardbody: {note}"));
            }
            for line in &summary.stages {
                say(line);
            }
            say(&format!("log written: {}", summary.log.display()));
            if summary.interrupted {
                esay("hardbody: interrupted; the log is complete up to the last frame");
                ExitCode::from(EXIT_INTERRUPTED)
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) if e.is_bad_input() => bad_input(e),
        Err(e) => {
            esay(&format!("hardbody: {e}"));
            ExitCode::from(EXIT_FAILED)
        }
    }
}

/// A refusal of the scene file `path` (text `text`) at `field`, with the
/// line the field is on.
pub(super) fn scene_refusal(
    path: &std::path::Path,
    text: &str,
    field: &str,
    e: impl std::fmt::Display,
) -> String {
    let line = hardbody::scene::outline::Outline::of(text)
        .line_of(field)
        .map(|l| format!("line {l}: "))
        .unwrap_or_default();
    format!("{}: {line}{field}: {e}", path.display())
}

/// What a scene file needs besides parsing to run: a start that can be
/// made (a `Resume` log that holds a state of these species) and, unless
/// `--out` replaces it, a log path that may be written. `run` and `check`
/// refuse the same scenes.
pub(super) fn preflight(
    path: &std::path::Path,
    text: &str,
    scene: &ValidScene,
    out_given: bool,
) -> Result<(), Refusal> {
    if let Err(e) = check_start(scene) {
        return Err(Refusal::CannotRun(scene_refusal(path, text, "start", e)));
    }
    let mut inputs = vec![path];
    if let hardbody::scene::Start::Resume(start) = &scene.start {
        inputs.push(std::path::Path::new(start));
    }
    if !out_given && let Err(e) = check_output(std::path::Path::new(&scene.log.path), true, &inputs)
    {
        return Err(Refusal::CannotRun(scene_refusal(path, text, "log.path", e)));
    }
    Ok(())
}

pub(super) fn check(path: &std::path::Path, json: bool) -> ExitCode {
    let (scene, text) = match load_scene(path) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    if let Err(e) = preflight(path, &text, &scene, false) {
        return bad_input(e);
    }
    let plan = Plan::of(&scene);
    if json {
        print_json(&plan.to_json());
        return ExitCode::SUCCESS;
    }
    say(&format!("{}: valid", path.display()));
    say(&Report {
        scene: &scene,
        plan: &plan,
    }
    .to_string());
    ExitCode::SUCCESS
}

/// `run [SCENE] --out OUT --continue`: a job that may have run before.
/// A partial log with a frame is resumed (bit for bit as if never
/// stopped); a complete log means there is nothing to do; otherwise the
/// scene runs from the start. A run stopped by Ctrl-C leaves its log as
/// OUT.partial, so that only a finished run puts OUT in place.
///
/// Every log found must be of SCENE (with `--seed`, of that seed): a log
/// of another scene is never resumed, never taken for this job's result
/// and never replaced; a complete OUT is never replaced by a partial one.
pub(super) fn continue_run(
    scene_path: Option<PathBuf>,
    out: Option<PathBuf>,
    seed: Option<u64>,
) -> ExitCode {
    let Some(out) = out else {
        return bad_input("--continue needs --out");
    };
    let mut scene = match &scene_path {
        Some(p) => match load_scene(p) {
            Ok((scene, _)) => scene,
            Err(e) => return bad_input(e),
        },
        None => Scene::parse(DEFAULT_SCENE).expect("the default scene is valid"),
    };
    if let Some(seed) = seed {
        scene = scene.with_seed(seed);
    }
    let scene_name = scene_path
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|| "the default scene".into());
    let partial = hardbody::log::partial_path(&out);
    if out.exists() {
        let contents = match hardbody::log::read::read_log(&out, false) {
            Ok(c) => c,
            Err(e) => return bad_input(e),
        };
        if let Err(e) = log_of_scene(&out, &contents, &scene, &scene_name) {
            return bad_input(e);
        }
        if let Some(damage) = contents.damage.map(|d| d.to_string()) {
            // Kept as it is beside, and continued from its last intact
            // frame: the job recovers and nothing is lost.
            let mut kept = out.clone().into_os_string();
            kept.push(".damaged");
            let kept = PathBuf::from(kept);
            if kept.exists() {
                return bad_input(format!(
                    "{}: damaged ({damage}), and {} is there already: move one of them away",
                    out.display(),
                    kept.display()
                ));
            }
            if let Err(e) = std::fs::rename(&out, &kept) {
                return bad_input(format!("{}: {e}", out.display()));
            }
            esay(&format!(
                "hardbody: {}: damaged ({damage}); kept as {}, continued from its last intact frame",
                out.display(),
                kept.display()
            ));
            return resume_log(&kept, Some(out.clone()), None);
        }
        say(&format!("{}: complete; nothing to do", out.display()));
        if partial.exists() {
            esay(&format!(
                "hardbody: {} is left as it is: {} is complete",
                partial.display(),
                out.display()
            ));
        }
        return ExitCode::SUCCESS;
    }
    let resumable = if partial.exists() {
        let contents = hardbody::log::read::read_log(&partial, false)
            .ok()
            .filter(|c| {
                c.last_state
                    .as_ref()
                    .is_some_and(|(_, s)| s.resume.is_some())
            });
        if let Some(contents) = &contents
            && let Err(e) = log_of_scene(&partial, contents, &scene, &scene_name)
        {
            return bad_input(e);
        }
        contents.is_some()
    } else {
        false
    };
    let code = if resumable {
        resume_log(&partial, Some(out.clone()), None)
    } else {
        run(scene_path, Some(out.clone()), seed, None)
    };
    if STOP.load(Ordering::SeqCst) && out.exists() && !partial.exists() {
        // Stopped, not finished: kept where the next --continue resumes it.
        if let Err(e) = std::fs::rename(&out, &partial) {
            esay(&format!(
                "hardbody: {}: could not be renamed to {}: {e}",
                out.display(),
                partial.display()
            ));
        } else {
            esay(&format!(
                "hardbody: stopped; {} is kept to continue from",
                partial.display()
            ));
        }
    }
    code
}

/// Whether the log at `log`, read as `contents`, is a run of `scene`
/// (seed included), as its metadata records it; the refusal says what
/// differs.
fn log_of_scene(
    log: &std::path::Path,
    contents: &hardbody::log::read::LogContents,
    scene: &ValidScene,
    name: &str,
) -> Result<(), Refusal> {
    let logged = contents
        .metadata
        .get("scene_resolved")
        .and_then(|text| Scene::parse(text).ok())
        .ok_or_else(|| Refusal::LogWithoutScene(log.to_path_buf()))?;
    if logged == *scene {
        return Ok(());
    }
    let what = if logged.seed != scene.seed {
        format!("seed {} where {name} has seed {}", logged.seed, scene.seed)
    } else {
        format!("a scene other than {name}")
    };
    Err(Refusal::LogOfAnotherRun {
        log: log.to_path_buf(),
        what,
        name: name.to_string(),
    })
}
