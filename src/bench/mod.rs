//! Benchmark suites behind `hardbody bench`.

pub mod compress;
pub mod edmd;
pub mod edmd_speed;
pub mod effects;
pub mod jam;
pub mod mc;
pub mod ocsi;
pub mod plot;
pub mod scene;
pub mod speed_plots;

/// Why a benchmark could not run, or found its run wrong.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A shape of the suite did not parse.
    #[error(transparent)]
    Shape(Box<crate::geometry::ShapeParseError>),
    /// A box of the suite is invalid.
    #[error(transparent)]
    PeriodicBox(Box<crate::space::periodic_box::BoxError>),
    /// A start could not be made.
    #[error(transparent)]
    State(Box<crate::state::StateError>),
    /// A lattice start could not be made.
    #[error(transparent)]
    Start(Box<crate::state::start::StartError>),
    /// The dynamics failed.
    #[error(transparent)]
    Dynamics(Box<crate::edmd::EdmdError>),
    /// A compression failed.
    #[error(transparent)]
    Compress(Box<crate::mc::compress::CompressError>),
    /// A log could not be written or read.
    #[error(transparent)]
    Log(Box<crate::log::LogError>),
    /// A scene did not parse or validate.
    #[error(transparent)]
    Scene(Box<crate::scene::SceneError>),
    /// A scene run failed.
    #[error(transparent)]
    Run(Box<crate::run::RunError>),
    /// A plot could not be written.
    #[error(transparent)]
    Plot(Box<plot::PlotError>),
    /// A folder for the results could not be made.
    #[error(transparent)]
    Output(Box<crate::log::file::OutputError>),
    /// A run timed came out wrong (overlaps at the end, no collisions, a
    /// reference that failed): which system, and what.
    #[error("{system}: {what}")]
    Wrong {
        /// The system benchmarked.
        system: String,
        /// What is wrong.
        what: String,
    },
}

/// `From` each error a benchmark meets, boxed (a benchmark's error is
/// rare; its `Result` stays small).
macro_rules! boxed_from {
    ($($variant:ident: $source:ty),* $(,)?) => {
        $(impl From<$source> for BenchError {
            fn from(e: $source) -> Self {
                BenchError::$variant(Box::new(e))
            }
        })*
    };
}

boxed_from! {
    Shape: crate::geometry::ShapeParseError,
    PeriodicBox: crate::space::periodic_box::BoxError,
    State: crate::state::StateError,
    Start: crate::state::start::StartError,
    Dynamics: crate::edmd::EdmdError,
    Compress: crate::mc::compress::CompressError,
    Log: crate::log::LogError,
    Scene: crate::scene::SceneError,
    Run: crate::run::RunError,
    Plot: plot::PlotError,
    Output: crate::log::file::OutputError,
}

impl BenchError {
    /// `self`, said of `system`.
    pub fn of(self, system: &str) -> Self {
        match self {
            BenchError::Wrong { .. } => self,
            other => BenchError::Wrong {
                system: system.to_string(),
                what: other.to_string(),
            },
        }
    }
}

/// A Markdown table: a header of `columns`, its rule, and one line per
/// row, each row given as its cells.
pub fn markdown_table(columns: &[&str], rows: impl IntoIterator<Item = Vec<String>>) -> String {
    let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
    let mut out = line(&columns.iter().map(|c| c.to_string()).collect::<Vec<_>>());
    out += &line(&vec!["---".to_string(); columns.len()]).replace(' ', "");
    for row in rows {
        out += &line(&row);
    }
    out
}
