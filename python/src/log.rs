//! Logs read into Python: the `/stats` messages as columns, the frames
//! (`/state`) as objects whose arrays are numpy arrays.

use std::collections::BTreeMap;
use std::path::PathBuf;

use hardbody::log::read::read_log as read_contents;
use hardbody::log::{LogError as RustLogError, StateRecord, Stats, StorageFailure};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use crate::LogError;

fn log_error(path: &std::path::Path, e: RustLogError) -> PyErr {
    match &e {
        RustLogError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(format!("{}: no such file", path.display()))
        }
        RustLogError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ if e.is_storage_failure() => PyOSError::new_err(e.to_string()),
        _ => LogError::new_err(e.to_string()),
    }
}

/// One frame of a log: the state at one log time.
#[pyclass(module = "hardbody._core", frozen)]
pub struct Frame {
    pub(crate) log_time: u64,
    pub(crate) record: StateRecord,
}

fn rows<'py, const K: usize>(py: Python<'py>, rows: &[[f64; K]]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    Array2::from_shape_vec((rows.len(), K), flat)
        .expect("rows of K")
        .into_pyarray(py)
}

#[pymethods]
impl Frame {
    /// The log time (ns): sweeps × 10⁶ in Monte Carlo stages, simulated
    /// time × 10⁹ in dynamics, offset by the stages before.
    #[getter]
    fn log_time(&self) -> u64 {
        self.log_time
    }
    /// Index of the stage in the scene.
    #[getter]
    fn stage_index(&self) -> usize {
        self.record.stage_index
    }
    /// Kind of the stage (`"compress"`, `"monte_carlo"`, `"dynamics"`,
    /// `"jam"`).
    #[getter]
    fn stage(&self) -> &str {
        &self.record.stage
    }
    /// The sweep in the stage (Monte Carlo stages), else None.
    #[getter]
    fn sweep(&self) -> Option<u64> {
        self.record.sweep
    }
    /// The simulated time in the stage (dynamics), else None.
    #[getter]
    fn time(&self) -> Option<f64> {
        self.record.time
    }
    /// Box edges, shape (3,).
    #[getter(r#box)]
    fn box_lengths<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.record.box_lengths)
    }
    /// Box tilt factors (xy, xz, yz), shape (3,): zeros for an
    /// orthorhombic box.
    #[getter]
    fn tilts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.record.tilts)
    }
    /// Centres, shape (N, 3).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.record.positions)
    }
    /// Unit quaternions [w, x, y, z] from body to lab, shape (N, 4).
    #[getter]
    fn orientations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.record.orientations)
    }
    /// Velocities, shape (N, 3); None in Monte Carlo frames.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.record.velocities.as_deref().map(|v| rows(py, v))
    }
    /// Angular velocities (lab frame), shape (N, 3); None in Monte Carlo
    /// frames.
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.record
            .angular_velocities
            .as_deref()
            .map(|v| rows(py, v))
    }
    /// Each body's size, the scale factor of its species' shape, shape
    /// (N,); None where every body has its species' size.
    #[getter]
    fn sizes<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.record
            .sizes
            .as_deref()
            .map(|s| PyArray1::from_slice(py, s))
    }
    /// The species index of every particle, shape (N,).
    #[getter]
    fn species_of<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let ids: Vec<i64> = self.record.species_of.iter().map(|&s| s as i64).collect();
        Array1::from_vec(ids).into_pyarray(py)
    }
    /// The species of the frame as JSON (`[{"name", "shape", "rotation"}]`;
    /// a jam stage's frames hold the grown shapes).
    #[getter]
    fn species_json(&self) -> String {
        serde_json::to_string(&self.record.species).expect("species serialise")
    }
    /// Number of particles.
    fn __len__(&self) -> usize {
        self.record.positions.len()
    }
}

/// The `/stats` messages as columns: one list per key (nested objects
/// flattened as `solver.distances`), in message order.
fn stats_columns(stats: &[(u64, Stats)]) -> BTreeMap<String, Vec<Value>> {
    fn flatten(prefix: &str, value: Value, row: &mut Vec<(String, Value)>) {
        match value {
            Value::Object(map) => {
                for (k, v) in map {
                    let key = if prefix.is_empty() {
                        k
                    } else {
                        format!("{prefix}.{k}")
                    };
                    flatten(&key, v, row);
                }
            }
            other => row.push((prefix.to_string(), other)),
        }
    }
    let mut columns: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    for (i, (log_time, s)) in stats.iter().enumerate() {
        let mut row = vec![("log_time".to_string(), Value::from(*log_time))];
        flatten(
            "",
            serde_json::to_value(s).expect("stats serialise"),
            &mut row,
        );
        for (key, value) in row {
            let column = columns.entry(key).or_default();
            // A key that first appears in a later message is null before.
            column.resize(i, Value::Null);
            column.push(value);
        }
    }
    for column in columns.values_mut() {
        column.resize(stats.len(), Value::Null);
    }
    // A nested object null in some messages leaves a column of its own
    // name beside its flattened fields: the fields say it all.
    let parents: Vec<String> = columns
        .keys()
        .filter(|k| {
            columns
                .keys()
                .any(|other| other.starts_with(&format!("{k}.")))
        })
        .cloned()
        .collect();
    for parent in parents {
        columns.remove(&parent);
    }
    columns
}

/// A column as numpy: integers without nulls as int64, strings as a
/// list, arrays as a 2-D float array, everything else as float64 with NaN
/// for null.
fn column_to_python<'py>(py: Python<'py>, values: &[Value]) -> PyResult<Bound<'py, PyAny>> {
    let float = |v: &Value| match v {
        Value::Number(n) => n.as_f64().unwrap_or(f64::NAN),
        Value::Bool(b) => f64::from(u8::from(*b)),
        _ => f64::NAN,
    };
    if values.iter().any(Value::is_string) {
        let strings: Vec<Option<&str>> = values.iter().map(Value::as_str).collect();
        return Ok(strings.into_pyobject(py)?.into_any());
    }
    if let Some(width) = values.iter().find_map(|v| v.as_array().map(Vec::len)) {
        let mut flat = Vec::with_capacity(values.len() * width);
        for v in values {
            match v.as_array() {
                Some(a) if a.len() == width => flat.extend(a.iter().map(float)),
                _ => flat.extend(std::iter::repeat_n(f64::NAN, width)),
            }
        }
        let array = Array2::from_shape_vec((values.len(), width), flat).expect("rows of width");
        return Ok(array.into_pyarray(py).into_any());
    }
    if values.iter().all(|v| v.as_i64().is_some()) {
        let ints: Vec<i64> = values.iter().filter_map(Value::as_i64).collect();
        return Ok(Array1::from_vec(ints).into_pyarray(py).into_any());
    }
    let floats: Vec<f64> = values.iter().map(float).collect();
    Ok(Array1::from_vec(floats).into_pyarray(py).into_any())
}

/// Reads the log at `path` (complete, or cut off by a killed run: read to
/// its last complete record). Returns a dict: `metadata` (the scene text,
/// the resolved scene, the version), `counts` (messages per topic),
/// `stats` (columns), `frames` (a list of `Frame`), `failure` (the
/// failure message of a failed run, or None), `truncated`, `damage`.
#[pyfunction]
pub fn read_log<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let contents = py
        .detach(|| read_contents(&path, true))
        .map_err(|e| log_error(&path, e))?;
    let out = PyDict::new(py);
    out.set_item("metadata", contents.metadata.clone())?;
    out.set_item("counts", contents.counts.clone())?;
    let stats = PyDict::new(py);
    for (key, values) in stats_columns(&contents.stats) {
        stats.set_item(key, column_to_python(py, &values)?)?;
    }
    out.set_item("stats", stats)?;
    let frames: Vec<Frame> = contents
        .states
        .into_iter()
        .map(|(log_time, record)| Frame { log_time, record })
        .collect();
    out.set_item("frames", frames)?;
    out.set_item(
        "failure",
        contents
            .failure
            .map(|(_, f)| format!("stage {}: {}", f.stage_index, f.message)),
    )?;
    out.set_item("truncated", contents.truncated)?;
    out.set_item("damage", contents.damage.map(|d| d.to_string()))?;
    Ok(out)
}

/// Writes the frames of the log at `path` to the GSD file `out`; returns
/// the number of frames written.
#[pyfunction]
pub fn export_gsd(py: Python<'_>, path: PathBuf, out: PathBuf) -> PyResult<usize> {
    py.detach(|| {
        let contents = read_contents(&path, true)?;
        hardbody::log::gsd::export(&contents, &out)
    })
    .map_err(|e| log_error(&path, e))
}

/// `hardbody analyze` of the logs at `paths` as JSON: one log's stages
/// (`{"log", "stages"}`), or several replicas' (`{"logs", "stages"}`
/// over all of them, and `"replicas"`, each one's); with `damage`, what
/// was said of damaged logs (their `/stats` before the damage are used).
#[pyfunction]
pub fn analyze_logs(py: Python<'_>, paths: Vec<PathBuf>) -> PyResult<String> {
    use hardbody::log::averages::{replica_averages, stage_averages};
    let mut contents = Vec::with_capacity(paths.len());
    for path in &paths {
        let c = py
            .detach(|| read_contents(path, false))
            .map_err(|e| log_error(path, e))?;
        contents.push((path.display().to_string(), c));
    }
    let damage: Vec<String> = contents
        .iter()
        .filter_map(|(name, c)| c.damage.as_ref().map(|d| format!("{name}: {d}")))
        .collect();
    let value = match contents.as_slice() {
        [] => {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "no logs to analyze",
            ));
        }
        [(name, c)] => {
            let stats: Vec<Stats> = c.stats.iter().map(|(_, s)| s.clone()).collect();
            serde_json::json!({
                "log": name,
                "truncated": c.truncated,
                "damage": c.damage.as_ref().map(|d| d.to_string()),
                "stages": stage_averages(&stats),
                "damages": damage,
            })
        }
        many => {
            let logs: Vec<_> = many.iter().map(|(name, c)| (name.clone(), c)).collect();
            let replicas = replica_averages(&logs).map_err(|e| LogError::new_err(e.to_string()))?;
            serde_json::json!({
                "logs": logs.iter().map(|(name, _)| name).collect::<Vec<_>>(),
                "stages": replicas.combined,
                "replicas": replicas.runs,
                "damages": damage,
            })
        }
    };
    Ok(value.to_string())
}

/// `hardbody analyze --packing` of frame `frame` (default the last) of
/// the log at `path`, as JSON.
#[pyfunction]
#[pyo3(signature = (path, frame=None, gap=None))]
pub fn analyze_packing(
    py: Python<'_>,
    path: PathBuf,
    frame: Option<isize>,
    gap: Option<f64>,
) -> PyResult<String> {
    use hardbody::log::packing::PackingReport;
    use pyo3::exceptions::{PyIndexError, PyValueError};
    if let Some(gap) = gap
        && !(gap.is_finite() && gap >= 0.0)
    {
        return Err(PyValueError::new_err(format!(
            "gap must be a finite number >= 0, got {gap}"
        )));
    }
    let contents = py
        .detach(|| read_contents(&path, true))
        .map_err(|e| log_error(&path, e))?;
    let frames = contents.states.len() as isize;
    let index = frame.unwrap_or(-1);
    let index = if index < 0 { index + frames } else { index };
    if !(0..frames).contains(&index) {
        return Err(PyIndexError::new_err(format!(
            "{}: frame {}: the log holds {frames} frames",
            path.display(),
            frame.unwrap_or(-1)
        )));
    }
    let report = py
        .detach(|| {
            PackingReport::of_log_frame(&contents, index as usize, gap).expect("a frame in range")
        })
        .map_err(|e| LogError::new_err(format!("{}: frame {index}: {e}", path.display())))?;
    let mut value = serde_json::to_value(&report).expect("a report serialises");
    value["frame"] = index.into();
    Ok(value.to_string())
}
