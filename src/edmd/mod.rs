//! Event-driven molecular dynamics of hard rigid bodies (De Michele,
//! Secs. 2–3): an event calendar ([`calendar`]), free motion between events
//! ([`motion`]), collision prediction ([`predict`]; two spheres in closed
//! form through the geometry layer; [`search`] for the others), the elastic collision ([`collision`])
//! and the event loop ([`dynamics`]). Pair geometry comes from the geometry
//! layer's dispatch only.

mod bounds;
pub mod calendar;
pub mod collision;
pub mod dynamics;
mod elliptic;
pub mod jam;
pub mod motion;
mod outcome;
pub mod predict;
mod prefetch;
pub mod search;

pub use dynamics::{
    BodyDump, Dynamics, DynamicsDump, DynamicsOptions, EdmdError, Sample, automatic_neighbour_shell,
};
pub use predict::{Predictor, PredictorOptions, SolverWork};
pub use search::{Found, Progress, Rotor, Search, SearchError};
