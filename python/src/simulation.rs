//! A run step by step from Python (`hardbody.Simulation`): each step runs
//! in a thread of its own with the GIL released, as whole runs do.

use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};

use hardbody::run::{Advance, Simulation as RustSimulation, Step};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::log::Frame;
use crate::run::{prepare, run_error, summary_dict, supervise};

/// A scene run step by step, writing its log as it goes.
#[pyclass(module = "hardbody._core")]
pub struct Simulation {
    inner: Mutex<Slot>,
}

/// Where the simulation is: here between steps, away in the thread of a
/// step under way, or finished.
enum Slot {
    Ready(Box<RustSimulation>),
    Running,
    Closed,
}

fn closed() -> PyErr {
    PyValueError::new_err("the simulation is closed (its log was finished)")
}

fn running() -> PyErr {
    PyRuntimeError::new_err(
        "the simulation is running a step (called from another thread?): call again once the step has returned",
    )
}

impl Simulation {
    fn lock(&self) -> MutexGuard<'_, Slot> {
        // A step that panicked leaves no simulation behind, not a broken
        // one: the poison carries nothing.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// `read` of the simulation between steps.
    fn with<R>(&self, read: impl FnOnce(&mut RustSimulation) -> PyResult<R>) -> PyResult<R> {
        match &mut *self.lock() {
            Slot::Ready(sim) => read(sim),
            Slot::Running => Err(running()),
            Slot::Closed => Err(closed()),
        }
    }

    /// The simulation, taken away (for a step, `away` being `Running`,
    /// or to finish it, `Closed`).
    fn take(&self, away: Slot) -> PyResult<RustSimulation> {
        let mut slot = self.lock();
        match std::mem::replace(&mut *slot, away) {
            Slot::Ready(sim) => Ok(*sim),
            other => {
                let error = match other {
                    Slot::Running => running(),
                    _ => closed(),
                };
                *slot = other;
                Err(error)
            }
        }
    }

    /// Runs `work` on the simulation with the GIL released; the
    /// simulation comes back whatever happens.
    fn step<F>(&self, py: Python<'_>, progress: Option<Py<PyAny>>, work: F) -> PyResult<Step>
    where
        F: FnOnce(
                &mut RustSimulation,
                &mut dyn hardbody::run::Progress,
                &std::sync::atomic::AtomicBool,
            ) -> Result<Step, hardbody::run::RunError>
            + Send
            + 'static,
    {
        let mut sim = self.take(Slot::Running)?;
        let outcome = supervise(py, progress, move |progress, stop| {
            let result = work(&mut sim, progress, stop);
            (sim, result)
        });
        let ((sim, result), raised) = match outcome {
            Ok(o) => o,
            Err(e) => {
                // The step's thread panicked: nothing is left to go on with.
                *self.lock() = Slot::Closed;
                return Err(e);
            }
        };
        *self.lock() = Slot::Ready(Box::new(sim));
        match (result, raised) {
            (_, Some(e)) => Err(e),
            (Ok(step), None) => Ok(step),
            (Err(e), None) => Err(run_error(py, e)),
        }
    }
}

fn step_dict(py: Python<'_>, step: Step) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("stage_index", step.stage_index)?;
    d.set_item("stage_done", step.stage_done)?;
    d.set_item("interrupted", step.interrupted)?;
    Ok(d)
}

#[pymethods]
impl Simulation {
    /// Makes the start of the scene in `text` (RON) and opens its log at
    /// `out` (default: the scene's log path).
    #[new]
    #[pyo3(signature = (text, out=None, seed=None, inputs=Vec::new()))]
    fn new(
        py: Python<'_>,
        text: String,
        out: Option<PathBuf>,
        seed: Option<u64>,
        inputs: Vec<PathBuf>,
    ) -> PyResult<Self> {
        let (scene, out) = prepare(py, &text, out, seed, &inputs)?;
        let sim = py
            .detach(|| RustSimulation::new(&scene, &text, &out))
            .map_err(|e| run_error(py, e))?;
        Ok(Self {
            inner: Mutex::new(Slot::Ready(Box::new(sim))),
        })
    }

    /// The stage the next step runs; None once every stage has run.
    #[getter]
    fn stage_index(&self) -> PyResult<Option<usize>> {
        self.with(|sim| Ok(sim.stage_index()))
    }

    /// Whether that stage has begun and paused.
    #[getter]
    fn paused(&self) -> PyResult<bool> {
        self.with(|sim| Ok(sim.paused()))
    }

    /// Runs the rest of the stage under way (or the next one).
    #[pyo3(signature = (progress=None))]
    fn run_stage<'py>(
        &self,
        py: Python<'py>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let step = self.step(py, progress, |sim, progress, stop| {
            sim.run_stage(progress, stop)
        })?;
        step_dict(py, step)
    }

    /// Runs the stage under way on by `sweeps` (Monte Carlo, compression;
    /// growth chunks of a jam) or `time` (dynamics), or to its end.
    #[pyo3(signature = (sweeps=None, time=None, progress=None))]
    fn advance<'py>(
        &self,
        py: Python<'py>,
        sweeps: Option<u64>,
        time: Option<f64>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let by = match (sweeps, time) {
            (Some(n), None) => Advance::Sweeps(n),
            (None, Some(t)) => Advance::Time(t),
            _ => return Err(PyValueError::new_err("give sweeps or time, not both")),
        };
        let step = self.step(py, progress, move |sim, progress, stop| {
            sim.advance(by, progress, stop)
        })?;
        step_dict(py, step)
    }

    /// The state where the run stands, as a frame.
    fn state(&self, py: Python<'_>) -> PyResult<Frame> {
        self.with(|sim| {
            let record = sim.state().map_err(|e| run_error(py, e))?;
            Ok(Frame {
                log_time: sim.log_time(),
                record,
            })
        })
    }

    /// Sets every position (N, 3) and orientation (N, 4, [w, x, y, z]);
    /// refused, the state unchanged, where bodies would overlap.
    fn set_configuration(
        &self,
        py: Python<'_>,
        positions: PyReadonlyArray2<'_, f64>,
        orientations: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<()> {
        let rows = |a: &PyReadonlyArray2<'_, f64>, k: usize, name: &str| -> PyResult<Vec<f64>> {
            let shape = a.shape();
            if shape.len() != 2 || shape[1] != k {
                return Err(PyValueError::new_err(format!(
                    "{name}: shape {shape:?}, expected (N, {k})"
                )));
            }
            Ok(a.as_array().iter().copied().collect())
        };
        let p = rows(&positions, 3, "positions")?;
        let q = rows(&orientations, 4, "orientations")?;
        let p: Vec<[f64; 3]> = p.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        let q: Vec<[f64; 4]> = q.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
        self.with(|sim| sim.set_configuration(&p, &q).map_err(|e| run_error(py, e)))
    }

    /// Ends the run: the log is completed and renamed to its path;
    /// returns the run's summary.
    fn finish<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = self.take(Slot::Closed)?;
        let summary = py.detach(|| sim.finish()).map_err(|e| run_error(py, e))?;
        summary_dict(py, summary)
    }

    /// Whether the log was finished.
    #[getter]
    fn closed(&self) -> bool {
        matches!(*self.lock(), Slot::Closed)
    }

    /// Whether a step is under way (in another thread).
    #[getter]
    fn running(&self) -> bool {
        matches!(*self.lock(), Slot::Running)
    }
}
