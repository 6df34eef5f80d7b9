//! Event-driven molecular dynamics of hard rigid bodies (De Michele,
//! Secs. 2–3): an event calendar ([`calendar`]), free motion between events
//! ([`motion`]), collision prediction ([`predict`]; two spheres in closed
//! form through the geometry layer), the elastic collision ([`collision`])
//! and the event loop ([`dynamics`]). Pair geometry comes from the geometry
//! layer's dispatch only.

pub mod calendar;
pub mod collision;
pub mod dynamics;
pub mod motion;
pub mod predict;

pub use dynamics::{
    BodyDump, Dynamics, DynamicsDump, DynamicsOptions, EdmdError, Sample, automatic_neighbour_shell,
};
pub use predict::{Predictor, PredictorOptions, Progress, Search, SolverWork};
