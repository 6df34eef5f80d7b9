//! Scenes between Python and Rust: RON text or the JSON the Python classes
//! write, checked by the crate's own validation, so that Python raises the
//! command line's refusals.

use hardbody::scene::{Scene, SceneError as RustSceneError, ValidScene};
use pyo3::prelude::*;

use crate::SceneError;

/// The Python `SceneError` for a refusal: the message, and the field and
/// line as attributes.
pub(crate) fn scene_error(py: Python<'_>, e: &RustSceneError) -> PyErr {
    let (field, line) = match e {
        RustSceneError::Syntax { line, .. } => (None, Some(*line)),
        RustSceneError::Invalid { field, line, .. } => (Some(field.clone()), *line),
    };
    refusal(py, e.to_string(), field, line)
}

fn refusal(py: Python<'_>, message: String, field: Option<String>, line: Option<usize>) -> PyErr {
    let err = SceneError::new_err(message);
    let value = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail.
    let _ = value.setattr("field", field);
    let _ = value.setattr("line", line);
    err
}

fn to_json(scene: &Scene) -> String {
    serde_json::to_string(scene).expect("a scene always serialises")
}

/// Parses and validates RON scene text; returns the scene as JSON (every
/// default filled in).
#[pyfunction]
pub fn scene_from_ron(py: Python<'_>, text: &str) -> PyResult<String> {
    let scene = Scene::parse(text).map_err(|e| scene_error(py, &e))?;
    Ok(to_json(&scene))
}

/// Reads a scene from the JSON the Python classes write and validates it;
/// returns it as JSON with every default filled in. Errors name the
/// field (`species[0].count`).
#[pyfunction]
pub fn scene_from_json(py: Python<'_>, json: &str) -> PyResult<String> {
    let scene = parse_json(py, json)?;
    Ok(to_json(&scene))
}

/// The plan of the scene (JSON, as `scene_from_json` takes), as JSON:
/// what `hardbody check --json` prints.
#[pyfunction]
pub fn scene_plan(py: Python<'_>, json: &str) -> PyResult<String> {
    let scene = parse_json(py, json)?;
    Ok(hardbody::scene::plan::Plan::of(&scene)
        .to_json()
        .to_string())
}

/// The scene (JSON, as `scene_from_json` takes) as RON text.
#[pyfunction]
pub fn scene_to_ron(py: Python<'_>, json: &str) -> PyResult<String> {
    Ok(parse_json(py, json)?.to_ron())
}

pub(crate) fn parse_json(py: Python<'_>, json: &str) -> PyResult<ValidScene> {
    let mut reader = serde_json::Deserializer::from_str(json);
    let scene: Scene = serde_path_to_error::deserialize(&mut reader).map_err(|e| {
        let field = e.path().to_string();
        let message = e.inner().to_string();
        // serde_json's own position is in the generated JSON, not useful.
        let message = message
            .rsplit_once(" at line ")
            .map_or(message.as_str(), |(m, _)| m)
            .to_string();
        refusal(py, format!("{field}: {message}"), Some(field), None)
    })?;
    scene.validated().map_err(|e| scene_error(py, &e))
}
