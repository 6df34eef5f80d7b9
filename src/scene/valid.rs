//! The scene that passed validation: the only kind a plan or a run takes.

use serde::Serialize;

use super::Scene;

/// A scene that passed every check of [`Scene::parse`] or
/// [`Scene::validated`]: only this can be planned or run. It reads as the
/// scene it holds; to edit it, take the scene out with
/// [`ValidScene::into_scene`] and validate it again.
///
/// A scene taken out to edit is not accepted by a run until it is checked
/// again (this does not compile):
///
/// ```compile_fail,E0308
/// use hardbody::run::{Silent, run_scene};
/// use hardbody::scene::Scene;
///
/// let text = r#"Scene(
///     box: (8.0, 8.0, 8.0),
///     species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 64)],
///     stages: [MonteCarlo(ensemble: Nvt, sweeps: 10)],
/// )"#;
/// let mut edited = Scene::parse(text).unwrap().into_scene();
/// edited.species[0].count = 0;
/// let stop = std::sync::atomic::AtomicBool::new(false);
/// run_scene(&edited, text, "out.mcap".as_ref(), &mut Silent, &stop);
/// ```
///
/// Checked again, it is refused by name:
///
/// ```
/// # use hardbody::scene::{Scene, SceneError};
/// # let text = r#"Scene(
/// #     box: (8.0, 8.0, 8.0),
/// #     species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 64)],
/// #     stages: [MonteCarlo(ensemble: Nvt, sweeps: 10)],
/// # )"#;
/// let mut edited = Scene::parse(text).unwrap().into_scene();
/// edited.species[0].count = 0;
/// assert!(matches!(edited.validated(), Err(SceneError::Invalid { field, .. }) if field == "species[0].count"));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(transparent)]
pub struct ValidScene(pub(super) Scene);

impl std::ops::Deref for ValidScene {
    type Target = Scene;
    fn deref(&self) -> &Scene {
        &self.0
    }
}

impl ValidScene {
    /// The scene, to edit (it must be validated again to run).
    pub fn into_scene(self) -> Scene {
        self.0
    }

    /// The starting box, with its walls.
    pub fn periodic_box(&self) -> crate::space::PeriodicBox {
        self.0.periodic_box()
    }

    /// The starting box's edges.
    pub fn box_vector(&self) -> nalgebra::Vector3<f64> {
        self.0.box_vector()
    }

    /// The packing fraction stage `index` starts at, where it is known
    /// before running: the start's (not a resumed state's), then each
    /// compression's target; unknown after an NPT stage, or after a
    /// compression that may end elsewhere (to a pressure, or to the jam).
    pub fn packing_fraction_before(&self, index: usize) -> Option<f64> {
        self.0.packing_fraction_before(index)
    }

    /// The same scene with another seed (every seed is valid).
    pub fn with_seed(mut self, seed: u64) -> ValidScene {
        self.0.seed = seed;
        self
    }
}
