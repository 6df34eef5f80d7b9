//! What a contact search is given besides the pair's motion, and what it
//! returns: how it ended ([`Search`], [`Found`]), where an unfinished one
//! stopped ([`Progress`]), why it failed ([`SearchError`]), and the
//! bodies' growth ([`Growth`]). The search itself is in [`super::search`].

use nalgebra::Vector3;

use super::motion::FreeTop;
use crate::geometry::{Contact, Shape, Status, WarmStart};

type V3 = Vector3<f64>;

/// How a search for a contact ended.
// Returned once per search and moved, never stored in bulk: the few hundred
// bytes of an unfinished search's state cost less than a box for it.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Search {
    /// The bodies touch at this time.
    Contact(f64),
    /// They stay apart up to the horizon.
    Apart,
    /// Out of budget: apart up to `progress.time()` at least; the search
    /// resumes from `progress` exactly as if it had not stopped.
    Unfinished(Progress),
}

/// How a search ended, without its progress (see
/// [`super::Predictor::search_into`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Found {
    /// The bodies touch at this time.
    Contact(f64),
    /// They stay apart up to the horizon.
    Apart,
    /// Out of budget, apart up to this time at least; the progress to
    /// resume from is in the caller's slot.
    Stopped(f64),
}

/// Where an unfinished search stopped: the step it had reached and the
/// solver state it carries (warm starts), so that a resumed search takes
/// the same steps, to the bit, as one that never stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    pub(super) t: f64,
    pub(super) distance: f64,
    pub(super) normal: V3,
    pub(super) warm: Option<WarmStart>,
    pub(super) hint: Option<V3>,
    pub(super) last: Option<(f64, Contact)>,
    pub(super) earlier: Option<(f64, Contact)>,
}

impl Progress {
    /// The time (from the search's origin) it got to.
    pub fn time(&self) -> f64 {
        self.t
    }
}

/// Uniform growth of both bodies (Lubachevsky–Stillinger): at τ the
/// bodies are their shapes scaled by `scale + rate τ`, which stays at most
/// 1 over the times the caller acts on (the shapes given are the largest
/// the bodies become: bounding spheres and turn bounds are those of the
/// shapes, and only the distances and support planes are scaled).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Growth {
    /// The scale at the origin (of the search, or of the clock).
    pub scale: f64,
    /// d scale / dτ.
    pub rate: f64,
}

impl Growth {
    /// The scale at τ = `t`.
    #[inline]
    pub fn at(&self, t: f64) -> f64 {
        self.scale + self.rate * t
    }

    /// The same growth seen from τ = `t` as its origin.
    #[inline]
    pub fn since(&self, t: f64) -> Growth {
        Growth {
            scale: self.at(t),
            rate: self.rate,
        }
    }

    /// When the scale reaches 1.
    #[inline]
    pub fn ends(&self) -> f64 {
        (1.0 - self.scale) / self.rate
    }
}

/// A body's shape and rotation, for prediction: (shape, its free rotation
/// from its orientation at the search's origin, or at a given time before
/// it for [`super::Predictor::search_into`]).
pub type Rotor<'a> = (&'a Shape, &'a FreeTop);

/// Why a contact search could not follow the distance.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SearchError {
    /// The distance solver gave no finite distance.
    #[error("{status:?} at τ = {at}")]
    Solver {
        /// How the solve ended.
        status: Status,
        /// The time from the search's origin.
        at: f64,
    },
    /// The pair overlaps where the search starts.
    #[error("the pair overlaps by {depth:e} at τ = {at}")]
    Overlap {
        /// How deep.
        depth: f64,
        /// The time from the search's origin.
        at: f64,
    },
    /// A distance came out NaN without a solver report.
    #[error("distance is NaN")]
    NotANumber,
}
