//! Free energies and coexistence from Python: the scenes run and the
//! paths integrated in a thread of their own (GIL released, progress
//! relayed, Ctrl-C a stop), the result handed back as JSON.

use std::path::PathBuf;

use hardbody::free_energy::{
    FreeEnergyError, PathChoices, PhaseScene, scene_coexistence, scene_free_energy,
};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;

use crate::RunError;
use crate::run::{prepare, supervise};

/// The error a failed free energy raises: bad input a `ValueError`, a
/// failed computation a `RunError`, a stop the error raised meanwhile.
fn raised((result, raised): (Result<String, FreeEnergyError>, Option<PyErr>)) -> PyResult<String> {
    match (result, raised) {
        (_, Some(e)) => Err(e),
        (Ok(json), None) => Ok(json),
        (Err(FreeEnergyError::Stopped), None) => Err(PyKeyboardInterrupt::new_err("stopped")),
        (Err(e), None) if e.is_bad_input() => Err(PyValueError::new_err(e.to_string())),
        (Err(e), None) => Err(RunError::new_err(e.to_string())),
    }
}

/// βF/N of the state the scene in `text` ends in (its log at `out`,
/// default the scene's log path), as `hardbody free-energy --json`
/// prints it.
#[pyfunction]
#[pyo3(signature = (text, out=None, seed=None, inputs=Vec::new(), points=None, sweeps=None, spring=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn free_energy_json(
    py: Python<'_>,
    text: String,
    out: Option<PathBuf>,
    seed: Option<u64>,
    inputs: Vec<PathBuf>,
    points: Option<usize>,
    sweeps: Option<u64>,
    spring: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let (scene, out) = prepare(py, &text, out, None, &inputs)?;
    let choices = PathChoices {
        points,
        sweeps,
        spring,
        seed,
    };
    let outcome = supervise(py, progress, move |progress, stop| {
        scene_free_energy(
            &scene,
            &text,
            &out,
            &choices.frenkel_ladd(scene.seed),
            &choices.equation_of_state(scene.seed),
            progress,
            stop,
        )
        .map(|r| serde_json::to_string(&r).expect("plain numbers serialise"))
    })?;
    raised(outcome)
}

/// Coexistence of the fluid scene `fluid` and the crystal scene `solid`
/// (RON texts; their logs at their log paths), as `hardbody coexistence
/// --json` prints it.
#[pyfunction]
#[pyo3(signature = (fluid, solid, seed=None, inputs=Vec::new(), points=None, sweeps=None, spring=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn coexistence_json(
    py: Python<'_>,
    fluid: String,
    solid: String,
    seed: Option<u64>,
    inputs: Vec<PathBuf>,
    points: Option<usize>,
    sweeps: Option<u64>,
    spring: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let (fluid_scene, fluid_log) = prepare(py, &fluid, None, None, &inputs)?;
    let (solid_scene, solid_log) = prepare(py, &solid, None, None, &inputs)?;
    if fluid_log == solid_log {
        return Err(PyValueError::new_err(format!(
            "the fluid and the solid both log to {}: give their scenes different log.path",
            fluid_log.display()
        )));
    }
    let choices = PathChoices {
        points,
        sweeps,
        spring,
        seed,
    };
    let outcome = supervise(py, progress, move |progress, stop| {
        let (eos, springs, branches) = choices.coexistence(fluid_scene.seed);
        scene_coexistence(
            PhaseScene {
                scene: &fluid_scene,
                text: &fluid,
                log: &fluid_log,
            },
            PhaseScene {
                scene: &solid_scene,
                text: &solid,
                log: &solid_log,
            },
            (&eos, &springs, &branches),
            progress,
            stop,
        )
        .map(|r| serde_json::to_string(&r).expect("plain numbers serialise"))
    })?;
    raised(outcome)
}
