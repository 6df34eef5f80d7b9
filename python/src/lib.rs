//! The extension module of the `hardbody` Python package (`hardbody._core`):
//! scenes checked and converted by the Rust crate, runs with the GIL
//! released, and logs read into numpy arrays. The Python layer in
//! `python/hardbody/` builds the public API on these functions.

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

mod free_energy;
mod log;
mod run;
mod scene;
mod simulation;

create_exception!(
    _core,
    SceneError,
    PyValueError,
    "A scene that cannot run; `field` names the field (`species[0].count`) and `line` its line in the scene text, where known."
);
create_exception!(
    _core,
    LogError,
    PyValueError,
    "A log that cannot be read (not an MCAP log of hardbody, or damaged before its first record)."
);
create_exception!(
    _core,
    RunError,
    PyRuntimeError,
    "A run that failed; the message says why and where the log up to the failure was kept."
);

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("LogError", m.py().get_type::<LogError>())?;
    m.add("RunError", m.py().get_type::<RunError>())?;
    m.add_function(wrap_pyfunction!(scene::scene_from_ron, m)?)?;
    m.add_function(wrap_pyfunction!(scene::scene_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(scene::scene_to_ron, m)?)?;
    m.add_function(wrap_pyfunction!(scene::scene_plan, m)?)?;
    m.add_function(wrap_pyfunction!(run::run_scene, m)?)?;
    m.add_function(wrap_pyfunction!(run::resume_log, m)?)?;
    m.add_function(wrap_pyfunction!(free_energy::free_energy_json, m)?)?;
    m.add_function(wrap_pyfunction!(free_energy::coexistence_json, m)?)?;
    m.add_function(wrap_pyfunction!(log::read_log, m)?)?;
    m.add_function(wrap_pyfunction!(log::export_gsd, m)?)?;
    m.add_function(wrap_pyfunction!(log::analyze_logs, m)?)?;
    m.add_function(wrap_pyfunction!(log::analyze_packing, m)?)?;
    m.add_class::<log::Frame>()?;
    m.add_class::<simulation::Simulation>()?;
    Ok(())
}
