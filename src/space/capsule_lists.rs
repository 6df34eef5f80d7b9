//! Verlet lists for Monte Carlo moves of bodies of any shape, over their
//! bounding capsules (a segment and a radius; a sphere is a capsule of no
//! length): each body keeps a reference segment, its core segment when it
//! was last listed, and lists the bodies whose reference segments lie
//! within the sum of their radii plus twice the `pad`. Every body at rest
//! keeps its segment's ends within a `slack` ≤ `pad` of its reference
//! segment (then, the points within a distance of a segment being convex,
//! the whole segment does, and the body lies in its capsule grown by the
//! slack); a body that ends a move farther out is relisted about its new
//! segment (and struck from, or added to, the others' lists). A trial pose
//! of body i whose segment ends lie within 2 pad − slack of i's reference
//! can then only meet the capsules of bodies on i's list (the distances
//! add up to the radii plus twice the pad): a few slots where the AABB
//! cells hold dozens. A trial that reaches farther is answered by the
//! lists' own cells over the reference capsules' AABBs grown by the pad,
//! which hold every body where it is (so that the moves need no other
//! cells kept up to date while the lists are on). A slack under the pad
//! trades relists of accepted moves for fewer trials beyond the lists.

use nalgebra::Vector3;

use super::{AabbCells, NeighbourLists, PeriodicBox};
use crate::geometry::capsule::segment_distance_squared;

type V3 = Vector3<f64>;

/// A body's core segment: its centre (in the box), the unit direction and
/// the half-length along it, and the capsule radius about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Midpoint.
    pub centre: V3,
    /// Unit direction.
    pub axis: V3,
    /// Half the length.
    pub half_length: f64,
    /// Radius of the capsule about it.
    pub radius: f64,
}

impl Segment {
    /// The AABB half-extents of the capsule grown by `pad`.
    fn aabb_half_extents(&self, pad: f64) -> V3 {
        (self.axis.abs() * self.half_length).add_scalar(self.radius + pad)
    }
}

/// Per-body neighbour lists over reference capsules (see the module docs).
#[derive(Debug, Clone)]
pub struct CapsuleLists {
    pad: f64,
    slack: f64,
    reference: Vec<Segment>,
    /// The reference capsules' AABBs, grown by the pad, binned to relist
    /// from.
    references: AabbCells,
    /// Symmetric: j is on i's list iff i is on j's.
    lists: NeighbourLists,
}

impl CapsuleLists {
    /// Lists for bodies with core `segments` (centres in the box), the
    /// reference capsules grown by `pad`, bodies relisted beyond `slack`
    /// (at most `pad`), binned in cells at least `cell_width` wide.
    pub fn new(
        box_: &PeriodicBox,
        segments: &[Segment],
        pad: f64,
        slack: f64,
        cell_width: f64,
    ) -> Self {
        assert!(slack <= pad, "slack {slack} over the pad {pad}");
        let centres: Vec<V3> = segments.iter().map(|s| s.centre).collect();
        let halves: Vec<V3> = segments.iter().map(|s| s.aabb_half_extents(pad)).collect();
        let mut this = Self {
            pad,
            slack,
            reference: segments.to_vec(),
            references: AabbCells::new(box_, cell_width, &centres, &halves),
            lists: NeighbourLists::new(segments.len(), 16),
        };
        for i in 0..segments.len() {
            this.link_neighbours(box_, i, |j| j > i);
        }
        this
    }

    /// The neighbours of body `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        self.lists.of(i)
    }

    /// Moves entry `at` of body `i`'s list to the front: the partner a
    /// trial of i last overlapped, which the next trial most likely
    /// overlaps too (a rejected trial then stops after one test).
    #[inline]
    pub fn to_front(&mut self, i: usize, at: usize) {
        self.lists.to_front(i, at);
    }

    /// Links body `i` with every body j ≠ i with `wanted(j)` whose
    /// reference segment lies within the radii plus twice the pad of i's.
    fn link_neighbours(&mut self, box_: &PeriodicBox, i: usize, wanted: impl Fn(usize) -> bool) {
        let Self {
            pad,
            reference,
            references,
            lists,
            ..
        } = self;
        let si = reference[i];
        references.any_near(&si.centre, &si.aabb_half_extents(*pad), |j| {
            if j != i && wanted(j) {
                let sj = &reference[j];
                let d = box_.minimum_image_near(&(sj.centre - si.centre));
                // A part in 10⁹ over: a capsule at the list's edge to
                // rounding is listed all the same.
                let reach = (si.radius + sj.radius + 2.0 * *pad) * (1.0 + 1e-9);
                let gap = segment_distance_squared(
                    &d,
                    &si.axis,
                    si.half_length,
                    &sj.axis,
                    sj.half_length,
                );
                if gap <= reach * reach {
                    lists.link(i, j);
                }
            }
            false
        });
    }

    /// Whether the lists answer for body `i` with its segment at
    /// `centre ± half_length · axis` (centre in the box or within half a
    /// box of it): both ends lie within 2 pad − slack of i's reference
    /// segment.
    #[inline]
    pub fn reach(&self, box_: &PeriodicBox, i: usize, centre: &V3, axis: &V3) -> bool {
        self.within(box_, i, centre, axis, 2.0 * self.pad - self.slack)
    }

    /// Whether both ends of body `i`'s segment at `centre ± half_length ·
    /// axis` lie within `distance` of its reference segment.
    #[inline]
    fn within(&self, box_: &PeriodicBox, i: usize, centre: &V3, axis: &V3, distance: f64) -> bool {
        let r = &self.reference[i];
        let d = box_.minimum_image_near(&(centre - r.centre));
        let end = axis * r.half_length;
        let within = |p: V3| {
            let s = p.dot(&r.axis).clamp(-r.half_length, r.half_length);
            (p - r.axis * s).norm_squared() <= distance * distance
        };
        within(d + end) && within(d - end)
    }

    /// Calls `f` once with every body whose reference capsule's AABB grown
    /// by the pad meets the AABB `c ± h` (every body whose AABB does, and
    /// more); stops early and returns true as soon as `f` does.
    pub fn any_near(&self, c: &V3, h: &V3, f: impl FnMut(usize) -> bool) -> bool {
        self.references.any_near(c, h, f)
    }

    /// Records that body `i` now has its segment at `centre ±
    /// half_length · axis` (centre in the box): relisted if an end lies
    /// beyond the slack about its reference.
    pub fn moved(&mut self, box_: &PeriodicBox, i: usize, centre: &V3, axis: &V3) {
        if self.within(box_, i, centre, axis, self.slack) {
            return;
        }
        self.lists.unlink_all(i);
        let r = &mut self.reference[i];
        r.centre = *centre;
        r.axis = *axis;
        let half = r.aabb_half_extents(self.pad);
        self.references.update(i, centre, &half);
        self.link_neighbours(box_, i, |_| true);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_unit(rng: &mut rand_pcg::Pcg64) -> V3 {
        V3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        )
        .normalize()
    }

    /// Random walks and turns of needles and spheres (overlaps allowed:
    /// the lists do not care): after every step, every pair of meeting
    /// capsules of a body the lists reach is listed, and now and then
    /// every list is exactly the set its definition says and every
    /// segment lies within the pad of its reference.
    #[test]
    fn lists_hold_every_meeting_pair_through_random_walks() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let box_ = PeriodicBox::new(V3::new(9.0, 10.0, 11.0)).unwrap();
        let n = 150;
        let mut segments: Vec<Segment> = (0..n)
            .map(|i| Segment {
                centre: box_.wrap(&V3::new(
                    rng.gen_range(-5.0..5.0),
                    rng.gen_range(-5.0..5.0),
                    rng.gen_range(-6.0..6.0),
                )),
                axis: random_unit(&mut rng),
                half_length: if i % 3 == 0 { 0.0 } else { 1.5 },
                radius: if i % 2 == 0 { 0.3 } else { 0.5 },
            })
            .collect();
        let (pad, slack) = (0.3, 0.2);
        let mut lists = CapsuleLists::new(&box_, &segments, pad, slack, 1.0);
        let meet = |a: &Segment, b: &Segment, grow: f64| {
            let d = box_.minimum_image(&(b.centre - a.centre));
            let reach = a.radius + b.radius + grow;
            segment_distance_squared(&d, &a.axis, a.half_length, &b.axis, b.half_length)
                <= reach * reach
        };
        let (mut beyond, mut answered, mut relisted) = (0, 0, 0);
        for step in 0..3000 {
            let i = rng.gen_range(0..n);
            let mut moved = segments[i];
            let shift = random_unit(&mut rng) * rng.gen_range(0.0..0.4);
            moved.centre = box_.wrap(&(moved.centre + shift));
            moved.axis = (moved.axis + random_unit(&mut rng) * 0.1).normalize();
            let meeting: Vec<usize> = (0..n)
                .filter(|&j| j != i && meet(&moved, &segments[j], 0.0))
                .collect();
            if lists.reach(&box_, i, &moved.centre, &moved.axis) {
                answered += 1;
                for &j in &meeting {
                    assert!(
                        lists.of(i).contains(&(j as u32)),
                        "step {step}: {i} meets {j} unlisted"
                    );
                }
            } else {
                beyond += 1;
                let mut found = vec![false; n];
                lists.any_near(&moved.centre, &moved.aabb_half_extents(0.0), |j| {
                    found[j] = true;
                    false
                });
                for &j in &meeting {
                    assert!(found[j], "step {step}: the cells miss {j} meeting {i}");
                }
            }
            let before = lists.reference[i];
            segments[i] = moved;
            lists.moved(&box_, i, &moved.centre, &moved.axis);
            if lists.reference[i] != before {
                relisted += 1;
            }
            if step % 500 == 0 || step == 2999 {
                for (a, s) in segments.iter().enumerate() {
                    assert!(
                        lists.within(&box_, a, &s.centre, &s.axis, slack),
                        "{a} beyond the slack"
                    );
                    let mut want: Vec<u32> = (0..n)
                        .filter(|&b| {
                            b != a && meet(&lists.reference[a], &lists.reference[b], 2.0 * pad)
                        })
                        .map(|b| b as u32)
                        .collect();
                    let mut got = lists.of(a).to_vec();
                    want.sort_unstable();
                    got.sort_unstable();
                    assert_eq!(got, want, "step {step}: list of {a}");
                }
            }
        }
        assert!(
            beyond > 100 && answered > 1000 && relisted > 300,
            "beyond {beyond}, answered {answered}, relisted {relisted}"
        );
    }
}
