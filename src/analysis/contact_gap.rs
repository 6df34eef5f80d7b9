//! The gap at which a packing's contacts are read, from the packing
//! itself. Bodies of a packing jammed to a reduced pressure Z = βPV/N
//! touch at gaps near 1/Z of their size, and their nearest neighbours
//! that do not touch sit orders of magnitude farther: the count of pairs
//! closer than a gap g has a plateau against g between the two, and any
//! g on it gives nearly the same contact network (Donev, Torquato &
//! Stillinger, Phys. Rev. E 71, 011105 (2005), read the contacts of their
//! grown packings there). The gap is read in the middle (on a log scale)
//! of the flattest range of [`PLATEAU_DECADES`] decades, among those
//! below which the bodies have at least two contacts each; a range whose
//! count grows by more than [`PLATEAU_GROWTH`] is no plateau: the packing
//! is not jammed, or jammed too loosely (by compression, gaps near 10⁻³)
//! for a gap to separate its contacts from its near neighbours.

use serde::Serialize;

use super::packing::{ContactNetwork, PackedBody, contact_network_turning, near_pairs};
use crate::geometry::Shape;
use crate::space::PeriodicBox;

/// The largest gap considered, relative to the smaller body's smallest
/// half-extent.
pub const MAX_GAP: f64 = 0.1;
/// The gap used where there is no plateau (the near neighbours of
/// packings jammed by compression sit within it).
pub const FALLBACK_GAP: f64 = 1e-2;
/// How many decades of gap a plateau spans.
pub const PLATEAU_DECADES: f64 = 2.0;
/// How much the pair count may grow across a plateau, relative to the
/// count at its start: 1 %, a change of the contact number of 0.06 at
/// z = 6.
pub const PLATEAU_GROWTH: f64 = 0.01;
/// Gaps below this (round-off of touching bodies, overlaps) count as it.
const SMALLEST_GAP: f64 = 1e-16;
/// Steps of the gap per decade where plateaus are sought.
const STEPS_PER_DECADE: i32 = 10;

/// A range of gaps and the pairs closer than its ends.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GapRange {
    /// Its lower end.
    pub from: f64,
    /// Its upper end.
    pub to: f64,
    /// Pairs closer than `from`: the contacts, on a plateau.
    pub contacts: usize,
    /// Pairs with gaps between `from` and `to`.
    pub added: usize,
}

impl GapRange {
    /// How much the count grows across it, relative to its start.
    pub fn growth(&self) -> f64 {
        self.added as f64 / self.contacts.max(1) as f64
    }
}

/// How the gap of a contact network was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GapSource {
    /// Given by the user (`--gap`).
    Given,
    /// In the middle of the plateau of the contact count.
    Plateau,
    /// No plateau: [`FALLBACK_GAP`], and the network is no certificate.
    NoPlateau,
}

/// The gap of a contact network and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GapChoice {
    /// The gap used, relative to the smaller body's smallest half-extent.
    pub gap: f64,
    /// How it was chosen.
    pub source: GapSource,
    /// The flattest range of [`PLATEAU_DECADES`] decades (with at least
    /// two contacts per body below it), plateau or not.
    pub flattest: Option<GapRange>,
    /// The frame's reduced pressure βPV/N, where the log holds it: its
    /// contacts are expected near 1/Z.
    pub reduced_pressure: Option<f64>,
    /// The count of pairs closer than each gap, half a decade apart from
    /// 10⁻¹⁶ to [`MAX_GAP`]: (gap, pairs).
    pub curve: Vec<(f64, usize)>,
    /// Why the network is no certificate, where it is not.
    pub warning: Option<String>,
}

/// The gaps of every pair of `bodies` (shapes `shapes`) closer than
/// [`MAX_GAP`], relative to the smaller body's smallest half-extent, in
/// increasing order (overlaps and round-off at 10⁻¹⁶).
pub fn relative_gaps(box_: &PeriodicBox, shapes: &[Shape], bodies: &[PackedBody]) -> Vec<f64> {
    let mut gaps = Vec::new();
    near_pairs(box_, shapes, bodies, MAX_GAP, |_, _, scale, _, contact| {
        let gap = contact.distance / scale;
        if gap < MAX_GAP {
            gaps.push(gap.max(SMALLEST_GAP));
        }
    });
    gaps.sort_unstable_by(f64::total_cmp);
    gaps
}

/// The gap at which to read the contacts of a packing of `bodies` bodies
/// whose pair gaps are `gaps` (from [`relative_gaps`]), at reduced
/// pressure `reduced_pressure` where known.
pub fn choose_gap(gaps: &[f64], bodies: usize, reduced_pressure: Option<f64>) -> GapChoice {
    let below = |gap: f64| gaps.partition_point(|&g| g < gap);
    let at_step = |step: i32| 10f64.powf(-16.0 + f64::from(step) / f64::from(STEPS_PER_DECADE));
    let width = (PLATEAU_DECADES * f64::from(STEPS_PER_DECADE)) as i32;
    let last = (MAX_GAP.log10() + 16.0) as i32 * STEPS_PER_DECADE;
    // Contacts sit near 1/Z: a range that ends below that lies among the
    // contacts themselves.
    let contact_scale = reduced_pressure
        .filter(|z| z.is_finite() && *z > 0.0)
        .map_or(0.0, |z| 1.0 / z);
    let flattest = (0..=last - width)
        .map(|step| {
            let (from, to) = (at_step(step), at_step(step + width));
            let contacts = below(from);
            GapRange {
                from,
                to,
                contacts,
                added: below(to) - contacts,
            }
        })
        .filter(|r| r.contacts >= bodies.max(1) && r.to > contact_scale)
        // The flattest; of equals, the first (nearest the contacts).
        .min_by(|a, b| a.growth().total_cmp(&b.growth()));
    let curve = (0..=30)
        .map(|step| {
            let gap = 10f64.powf(-16.0 + 0.5 * f64::from(step));
            (gap, below(gap))
        })
        .collect();
    let (gap, source, warning) = match flattest {
        Some(r) if r.growth() <= PLATEAU_GROWTH => {
            ((r.from * r.to).sqrt(), GapSource::Plateau, None)
        }
        _ => (
            FALLBACK_GAP,
            GapSource::NoPlateau,
            Some(format!(
                "no plateau of the contact count against the gap ({}): the packing is not jammed, or jammed too loosely (by compression) for a gap to tell its contacts from its near neighbours; the contacts at the fallback gap {FALLBACK_GAP:e} are no certificate",
                match flattest {
                    Some(r) => format!(
                        "across the flattest {PLATEAU_DECADES} decades, from {:.1e} to {:.1e}, the pairs grow by {:.1} %, more than the {:.0} % a plateau allows",
                        r.from,
                        r.to,
                        100.0 * r.growth(),
                        100.0 * PLATEAU_GROWTH
                    ),
                    None => "fewer than two pairs per body are within reach".into(),
                }
            )),
        ),
    };
    GapChoice {
        gap,
        source,
        flattest,
        reduced_pressure,
        curve,
        warning,
    }
}

/// The contact network of `bodies` (shapes `shapes`, those of shape k
/// turning if `turns[k]`) in `box_`, read at `gap` if given, else at the
/// gap the packing shows ([`choose_gap`], guided by `reduced_pressure`);
/// with the choice of the gap.
pub fn read_contact_network(
    box_: &PeriodicBox,
    shapes: &[Shape],
    turns: &[bool],
    bodies: &[PackedBody],
    gap: Option<f64>,
    reduced_pressure: Option<f64>,
) -> (GapChoice, ContactNetwork) {
    let gaps = relative_gaps(box_, shapes, bodies);
    let choice = match gap {
        Some(gap) => given_gap(gap, &gaps, bodies.len(), reduced_pressure),
        None => choose_gap(&gaps, bodies.len(), reduced_pressure),
    };
    let network = contact_network_turning(box_, shapes, turns, bodies, choice.gap);
    (choice, network)
}

/// The choice of a gap the user gave.
pub fn given_gap(
    gap: f64,
    gaps: &[f64],
    bodies: usize,
    reduced_pressure: Option<f64>,
) -> GapChoice {
    GapChoice {
        gap,
        source: GapSource::Given,
        warning: None,
        ..choose_gap(gaps, bodies, reduced_pressure)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ten bodies, 30 contacts at gaps 10⁻¹² to 10⁻¹¹, one pair at 10⁻⁸
    /// and near neighbours from 10⁻³ up: the plateau from 10⁻¹¹ on, the
    /// gap in its first flat two decades.
    #[test]
    fn the_gap_is_read_on_the_plateau() {
        let mut gaps: Vec<f64> = (0..30).map(|k| 1e-12 * (1.0 + 0.3 * k as f64)).collect();
        gaps.push(1e-8);
        gaps.extend((0..20).map(|k| 1e-3 * (1.0 + k as f64)));
        let choice = choose_gap(&gaps, 10, Some(1e12));
        assert_eq!(choice.source, GapSource::Plateau);
        let r = choice.flattest.unwrap();
        assert_eq!((r.contacts, r.added), (30, 0));
        assert!(r.from > gaps[29] && r.to < 1e-8, "{r:?}");
        assert!(choice.gap > gaps[29] && choice.gap < 1e-8);
        assert!(choice.warning.is_none());
        // 30 contacts of which one more than 1 % may join: still flat.
        let one_more = choose_gap(&[&gaps[..30], &[1e-9], &gaps[31..]].concat(), 10, None);
        assert_eq!(one_more.source, GapSource::Plateau);
    }

    /// Gaps spread evenly over the decades (a fluid, or a packing jammed
    /// by compression): no plateau, the fallback gap and a warning.
    #[test]
    fn gaps_without_a_plateau_give_a_warning() {
        let gaps: Vec<f64> = (0..200)
            .map(|k| 10f64.powf(-6.0 + 0.025 * k as f64))
            .collect();
        let choice = choose_gap(&gaps, 50, None);
        assert_eq!(choice.source, GapSource::NoPlateau);
        assert_eq!(choice.gap, FALLBACK_GAP);
        assert!(choice.warning.unwrap().contains("no plateau"));
    }

    /// A few pairs at round-off among the contacts leave the decades
    /// below the rest of the contacts flat; with fewer than two contacts
    /// per body below them, those are not the plateau.
    #[test]
    fn a_flat_range_among_the_contacts_is_not_the_plateau() {
        let mut gaps = vec![1e-16; 3];
        gaps.extend((0..30).map(|k| 1e-10 * (1.0 + 0.1 * k as f64)));
        gaps.extend((0..20).map(|k| 1e-5 * (1.0 + k as f64)));
        let choice = choose_gap(&gaps, 10, Some(1e10));
        assert_eq!(choice.source, GapSource::Plateau);
        assert_eq!(choice.flattest.unwrap().contacts, 33);
        assert!(choice.gap > 4e-10 && choice.gap < 1e-5);
    }
}
