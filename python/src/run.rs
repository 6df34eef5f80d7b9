//! Runs from Python: the run goes on in a thread of its own with the GIL
//! released; the calling thread relays its progress to a Python callback
//! and watches for Ctrl-C, which stops the run as the command line's does
//! (cleanly, at the next sweep or output event, with a final frame).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use hardbody::log::StorageFailure;
use hardbody::log::file::check_output;
use hardbody::run::{Progress, RunError as RustRunError, RunSummary, check_start};
use hardbody::scene::{Scene, Start, ValidScene};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::scene::scene_error;
use crate::{RunError, SceneError};

/// How often the waiting thread looks for Ctrl-C.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// A progress event, sent from the running thread.
enum Event {
    Stage(usize, usize, String, u64),
    Tick(u64, String),
    Done(String),
}

struct Relay(mpsc::Sender<Event>);

impl Progress for Relay {
    fn stage(&mut self, index: usize, count: usize, description: &str, ticks: u64) {
        let _ = self
            .0
            .send(Event::Stage(index, count, description.into(), ticks));
    }
    fn tick(&mut self, tick: u64, message: &str) {
        let _ = self.0.send(Event::Tick(tick, message.into()));
    }
    fn stage_done(&mut self, message: &str) {
        let _ = self.0.send(Event::Done(message.into()));
    }
}

/// Runs `work` in its own thread while this one relays progress to
/// `progress` (called as `progress("stage", index, count, description,
/// ticks)`, `progress("tick", tick, message)`, `progress("done",
/// message)`) and turns Ctrl-C into a stop. A Python error raised by the
/// callback or by a signal handler stops the run too and is raised once it
/// has ended.
pub(crate) fn supervise<F, T>(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    work: F,
) -> PyResult<(T, Option<PyErr>)>
where
    F: FnOnce(&mut dyn Progress, &AtomicBool) -> T + Send + 'static,
    T: Send + 'static,
{
    let stop = Arc::new(AtomicBool::new(false));
    let (sender, mut events) = mpsc::channel();
    let handle = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || work(&mut Relay(sender), &stop))
    };
    let mut raised: Option<PyErr> = None;
    loop {
        // (The receiver is not `Sync`: it goes into the released section
        // and comes back.)
        let (event, receiver) = py.detach(move || (events.recv_timeout(SIGNAL_POLL), events));
        events = receiver;
        let delivered = match event {
            Ok(event) => match &progress {
                Some(callback) => deliver(py, callback, event),
                None => Ok(()),
            },
            Err(mpsc::RecvTimeoutError::Timeout) => Ok(()),
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        };
        if let Err(e) = delivered.and_then(|()| py.check_signals()) {
            stop.store(true, Ordering::SeqCst);
            raised.get_or_insert(e);
        }
    }
    let result = py
        .detach(|| handle.join())
        .map_err(|_| RunError::new_err("the run's thread panicked"))?;
    Ok((result, raised))
}

/// A whole run's outcome: its summary, or the error of the run or (the
/// run having stopped cleanly) the one raised while it ran.
fn summary_of(
    py: Python<'_>,
    (result, raised): (Result<RunSummary, RustRunError>, Option<PyErr>),
) -> PyResult<RunSummary> {
    match (result, raised) {
        (Ok(summary), Some(e)) => {
            // The run stopped cleanly: say where its log is.
            let _ = e.value(py).setattr("log", &summary.log);
            Err(e)
        }
        (Ok(summary), None) => Ok(summary),
        (Err(e), _) => Err(run_error(py, e)),
    }
}

fn deliver(py: Python<'_>, callback: &Py<PyAny>, event: Event) -> PyResult<()> {
    match event {
        Event::Stage(index, count, description, ticks) => {
            callback.call1(py, ("stage", index, count, description, ticks))?
        }
        Event::Tick(tick, message) => callback.call1(py, ("tick", tick, message))?,
        Event::Done(message) => callback.call1(py, ("done", message))?,
    };
    Ok(())
}

pub(crate) fn run_error(py: Python<'_>, e: RustRunError) -> PyErr {
    match &e {
        RustRunError::Request(m) => PyValueError::new_err(m.clone()),
        RustRunError::Output(o) if o.is_storage_failure() => PyOSError::new_err(e.to_string()),
        RustRunError::Output(_) => PyValueError::new_err(e.to_string()),
        RustRunError::Start(_) | RustRunError::Resume(_) | RustRunError::Phase(_) => {
            let err = SceneError::new_err(e.to_string());
            let _ = err.value(py).setattr("field", "start");
            let _ = err.value(py).setattr("line", py.None());
            err
        }
        _ => RunError::new_err(e.to_string()),
    }
}

pub(crate) fn summary_dict<'py>(
    py: Python<'py>,
    summary: RunSummary,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("log", summary.log)?;
    dict.set_item("stages", summary.stages)?;
    dict.set_item("interrupted", summary.interrupted)?;
    dict.set_item("notes", summary.notes)?;
    Ok(dict)
}

/// Runs every stage of the scene in `text` (RON, as recorded in the log)
/// to `out` (default: the scene's log path), with `seed` replacing the
/// scene's; `inputs` are files the output must not replace (the scene
/// file). Returns the run's summary: `log`, `stages` (a line each),
/// `interrupted`, `notes`.
#[pyfunction]
#[pyo3(signature = (text, out=None, seed=None, inputs=Vec::new(), progress=None))]
pub fn run_scene<'py>(
    py: Python<'py>,
    text: String,
    out: Option<PathBuf>,
    seed: Option<u64>,
    inputs: Vec<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (scene, out) = prepare(py, &text, out, seed, &inputs)?;
    let outcome = supervise(py, progress, move |progress, stop| {
        hardbody::run::run_scene(&scene, &text, &out, progress, stop)
    })?;
    summary_dict(py, summary_of(py, outcome)?)
}

/// The scene in `text` with `seed` applied, and its log path, both
/// checked as the command line checks them before a run.
pub(crate) fn prepare(
    py: Python<'_>,
    text: &str,
    out: Option<PathBuf>,
    seed: Option<u64>,
    inputs: &[PathBuf],
) -> PyResult<(ValidScene, PathBuf)> {
    let mut scene = Scene::parse(text).map_err(|e| scene_error(py, &e))?;
    if let Some(seed) = seed {
        scene = scene.with_seed(seed);
    }
    check_start(&scene).map_err(|e| run_error(py, e))?;
    let out = out.unwrap_or_else(|| PathBuf::from(&scene.log.path));
    let mut guarded: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    if let Start::Resume(p) = &scene.start {
        guarded.push(Path::new(p));
    }
    check_output(&out, true, &guarded).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok((scene, out))
}

/// Continues the run logged in `log` from its last frame, writing `out`
/// (default: the log's path without `.partial`).
#[pyfunction]
#[pyo3(signature = (log, out=None, progress=None))]
pub fn resume_log<'py>(
    py: Python<'py>,
    log: PathBuf,
    out: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = out.unwrap_or_else(|| {
        let text = log.display().to_string();
        PathBuf::from(text.strip_suffix(".partial").unwrap_or(&text))
    });
    check_output(&out, true, &[]).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let outcome = supervise(py, progress, move |progress, stop| {
        hardbody::run::resume_run(&log, &out, progress, stop)
    })?;
    summary_dict(py, summary_of(py, outcome)?)
}
