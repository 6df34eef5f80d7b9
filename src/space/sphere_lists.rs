//! Verlet lists for Monte Carlo moves of spheres: each sphere lists the
//! spheres whose reference centres lie within their contact distance plus
//! a skin of its own reference centre. While every centre stays within
//! half the skin of its reference, a sphere at a trial centre within half
//! the skin of its reference can only touch spheres on its list (the two
//! half-skins make up the skin), about a tenth of the slots the 27 cells
//! around it hold. A sphere that ends a move farther out takes its new
//! centre as reference and is relisted (and struck from, or added to, the
//! others' lists), through cells of its own over the reference centres,
//! as wide as the largest contact distance plus the skin: the moves' own
//! cells stay as wide as the interaction range.
//!
//! A box change scales the references with the centres, and the lists
//! stand: the gap they guarantee between unlisted references (the skin,
//! at first) shrinks with every shrink of the box, and half of it is what
//! a centre may stray from its reference; centres farther out then are
//! relisted at once. Lists whose gap has fallen below half the skin are
//! given up (and built afresh later).

use nalgebra::Vector3;

use std::ops::Index;

use super::slots::Slots;
use super::{NeighbourLists, PackedCells, PeriodicBox};

type V3 = Vector3<f64>;

/// Per-sphere neighbour lists with a skin (see the module docs).
#[derive(Debug, Clone)]
pub struct SphereLists {
    skin: f64,
    /// The largest contact distance.
    sigma_max: f64,
    /// Unlisted references are farther apart than their contact distance
    /// plus this (the skin until the box shrinks); a centre may stray half
    /// of it from its reference.
    gap: f64,
    /// Reference centres (in the box).
    reference: Slots<V3>,
    /// The reference centres binned, to relist from.
    references: PackedCells,
    radii: Vec<f64>,
    /// Symmetric: j is on i's list iff i is on j's.
    lists: NeighbourLists,
}

impl SphereLists {
    /// Lists for spheres at `positions` (in the box) with `radii`.
    pub fn new(box_: &PeriodicBox, positions: &[V3], radii: &[f64], skin: f64) -> Self {
        let n = positions.len();
        let largest = radii.iter().copied().fold(0.0, f64::max);
        let mut this = Self {
            skin,
            sigma_max: 2.0 * largest,
            gap: skin,
            reference: positions.to_vec().into(),
            references: PackedCells::new(box_, 2.0 * largest + skin, positions, radii),
            radii: radii.to_vec(),
            lists: NeighbourLists::new(n, 16),
        };
        for i in 0..n {
            this.link_neighbours(i, |j| j > i);
        }
        this
    }

    /// Room for at least `per_cell` references in each of their cells and
    /// `per_list` entries in each list.
    pub fn reserve(&mut self, per_cell: usize, per_list: usize) {
        self.references.reserve(per_cell);
        self.lists.reserve(per_list);
    }

    /// The room per reference cell and per list before they must grow.
    pub fn room(&self) -> (usize, usize) {
        (self.references.capacity(), self.lists.capacity())
    }

    /// The reference cells along each axis.
    pub fn reference_dims(&self) -> [usize; 3] {
        self.references.dims()
    }

    /// From now on a reference cell or a list that would outgrow its room
    /// panics instead of growing (see [`PackedCells::fix_capacity`]).
    pub fn fix_capacity(&mut self) {
        self.references.fix_capacity();
        self.lists.fix_capacity();
    }

    /// Links sphere `i` with every sphere j ≠ i with `wanted(j)` whose
    /// reference lies within the contact distance plus the skin of i's
    /// reference (the reference cells are that wide).
    fn link_neighbours(&mut self, i: usize, wanted: impl Fn(usize) -> bool) {
        let Self {
            skin,
            reference,
            references,
            radii,
            lists,
            ..
        } = self;
        references.any_near(&reference[i], |j, d| {
            if j != i && wanted(j) {
                let reach = radii[i] + radii[j] + *skin;
                if d.norm_squared() <= reach * reach {
                    lists.link(i, j);
                }
            }
            false
        });
    }

    /// Whether sphere `i` at `centre` (in the box) touches a listed sphere
    /// j at `positions[j]` with `keep(j)`; `None` if `centre` is more than
    /// half the gap (the skin until the box shrinks) from i's reference,
    /// where the list does not reach.
    #[inline]
    pub fn overlaps(
        &self,
        i: usize,
        centre: &V3,
        positions: &(impl Index<usize, Output = V3> + ?Sized),
        box_: &PeriodicBox,
        keep: impl Fn(usize) -> bool,
    ) -> Option<bool> {
        let half = 0.5 * self.gap;
        let drift = box_.minimum_image_near(&(centre - self.reference[i]));
        if drift.norm_squared() > half * half {
            return None;
        }
        Some(self.touches_listed(i, centre, positions, box_, keep))
    }

    /// Whether sphere `i` at `centre` touches a listed sphere j at
    /// `positions[j]` with `keep(j)`.
    #[inline]
    fn touches_listed(
        &self,
        i: usize,
        centre: &V3,
        positions: &(impl Index<usize, Output = V3> + ?Sized),
        box_: &PeriodicBox,
        keep: impl Fn(usize) -> bool,
    ) -> bool {
        let ri = self.radii[i];
        let touches = |j: u32, d: V3| {
            let reach = ri + self.radii[j as usize];
            d.norm_squared() <= reach * reach && keep(j as usize)
        };
        let listed = self.lists.of(i);
        // One loop per kind of box: the untilted one tests no tilt per sphere.
        if box_.is_tilted() {
            listed.iter().any(|&j| {
                touches(
                    j,
                    box_.minimum_image_near_as::<true>(&(positions[j as usize] - centre)),
                )
            })
        } else {
            listed.iter().any(|&j| {
                touches(
                    j,
                    box_.minimum_image_near_as::<false>(&(positions[j as usize] - centre)),
                )
            })
        }
    }

    /// Records that sphere `i` now sits at `centre` (in the box):
    /// relisted if it left half the gap around its reference.
    pub fn moved(&mut self, i: usize, centre: &V3, box_: &PeriodicBox) {
        let half = 0.5 * self.gap;
        let drift = box_.minimum_image_near(&(centre - self.reference[i]));
        if drift.norm_squared() <= half * half {
            return;
        }
        self.relist(i, centre);
    }

    /// Sphere `i` takes `centre` as its reference and is listed afresh
    /// (with the whole skin: its unlisted pairs are then farther apart than
    /// the gap asks).
    fn relist(&mut self, i: usize, centre: &V3) {
        self.lists.unlink_all(i);
        self.reference[i] = *centre;
        self.references.update(i, centre);
        self.link_neighbours(i, |_| true);
    }

    /// Sphere `i`, now of radius `radius` (no larger than the largest the
    /// lists were built for) and at `centre`: listed afresh if it grew (a
    /// sphere that shrank keeps its list, which then holds every pair it
    /// must and more).
    pub fn resized(&mut self, i: usize, radius: f64, centre: &V3) {
        debug_assert!(2.0 * radius <= self.sigma_max * (1.0 + 1e-12));
        let grew = radius > self.radii[i];
        self.radii[i] = radius;
        self.references.set_radius(i, radius);
        if grew {
            self.relist(i, centre);
        }
    }

    /// The box has become `box_` from `old`, every centre taken with it
    /// (the same fractional coordinates) to `positions` (in the box): the
    /// references are mapped the same way and the lists kept. The gap
    /// shrinks by the largest contact distance's share of the shrink:
    /// references d apart, with d above σ + gap, end up at least f·d apart,
    /// above σ + (f·(σ + gap) − σ), f the smallest stretch of the map. Centres that have strayed more than half the new
    /// gap (strays grow with an expansion) are relisted. Returns `false`,
    /// and the lists are no longer to be used, when the gap left would be
    /// under half the skin.
    pub fn rescaled(&mut self, old: &PeriodicBox, box_: &PeriodicBox, positions: &[V3]) -> bool {
        let gap = self.gap_after(box_.smallest_stretch_from(old));
        if gap < 0.5 * self.skin {
            return false;
        }
        self.gap = gap;
        for r in self.reference.iter_mut() {
            *r = box_.wrap(&box_.map_from(old, r));
        }
        self.references = PackedCells::new(
            box_,
            self.sigma_max + self.skin,
            self.reference.as_slice(),
            &self.radii,
        );
        let half = 0.5 * gap;
        for (i, centre) in positions.iter().enumerate() {
            let drift = box_.minimum_image_near(&(centre - self.reference[i]));
            if drift.norm_squared() > half * half {
                self.relist(i, centre);
            }
        }
        true
    }

    /// The gap the lists would keep after a box change that stretches
    /// separations by at least `stretch`.
    fn gap_after(&self, stretch: f64) -> f64 {
        let shrink = stretch.min(1.0);
        shrink * (self.sigma_max + self.gap) - self.sigma_max
    }

    /// Whether spheres at `positions`, the centres taken from box `old`
    /// into `box_` (the lists not yet rescaled), overlap: listed pairs are
    /// measured; unlisted pairs of centres within half the gap left of
    /// their scaled references cannot touch; `overlaps(i)` answers for
    /// sphere i against every other where its centre strayed farther (or
    /// for every sphere when no gap would be left).
    pub fn overlap_after_rescale(
        &self,
        old: &PeriodicBox,
        box_: &PeriodicBox,
        positions: &[V3],
        overlaps: impl FnMut(usize) -> bool,
    ) -> bool {
        self.listed_overlap_after_rescale(old, box_, positions)
            || self
                .strays_after_rescale(old, box_, positions)
                .any(overlaps)
    }

    /// The first half of [`SphereLists::overlap_after_rescale`]: whether
    /// a sphere within half the gap left of its scaled reference touches a
    /// listed one (none when no gap would be left).
    pub fn listed_overlap_after_rescale(
        &self,
        old: &PeriodicBox,
        box_: &PeriodicBox,
        positions: &[V3],
    ) -> bool {
        let Some(half) = self.half_gap_after(box_.smallest_stretch_from(old)) else {
            return false;
        };
        (positions.iter().enumerate()).any(|(i, centre)| {
            !self.strayed_after_rescale(i, centre, old, box_, half)
                && self.touches_listed(i, centre, positions, box_, |_| true)
        })
    }

    /// The second half: the spheres farther than half the gap left from
    /// their scaled references (all of them when no gap would be left),
    /// for which the lists do not answer.
    pub fn strays_after_rescale<'a>(
        &'a self,
        old: &'a PeriodicBox,
        box_: &'a PeriodicBox,
        positions: &'a [V3],
    ) -> impl Iterator<Item = usize> + 'a {
        let half = self.half_gap_after(box_.smallest_stretch_from(old));
        (0..positions.len()).filter(move |&i| {
            half.is_none_or(|half| self.strayed_after_rescale(i, &positions[i], old, box_, half))
        })
    }

    /// Half the gap the lists would keep after a box change that
    /// stretches separations by at least `stretch`; `None` when none would
    /// be left.
    fn half_gap_after(&self, stretch: f64) -> Option<f64> {
        let gap = self.gap_after(stretch);
        (gap > 0.0).then_some(0.5 * gap)
    }

    /// Whether sphere `i` at `centre` lies farther than `half` from its
    /// reference taken from box `old` into `box_`.
    fn strayed_after_rescale(
        &self,
        i: usize,
        centre: &V3,
        old: &PeriodicBox,
        box_: &PeriodicBox,
        half: f64,
    ) -> bool {
        let reference = box_.wrap(&box_.map_from(old, &self.reference[i]));
        let drift = box_.minimum_image_near(&(centre - reference));
        drift.norm_squared() > half * half
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// One step of a random walk (overlaps allowed: the lists do not
    /// care): a random sphere tried up to 0.15 away, the lists' answer
    /// compared with all pairs where they answer (then `true`), and the
    /// sphere moved there.
    fn random_step(
        rng: &mut impl Rng,
        lists: &mut SphereLists,
        positions: &mut [V3],
        radii: &[f64],
        box_: &PeriodicBox,
    ) -> bool {
        let n = positions.len();
        let i = rng.gen_range(0..n);
        let trial = box_.wrap(&(positions[i] + V3::from_fn(|_, _| rng.gen_range(-0.15..0.15))));
        let all_pairs = (0..n).any(|j| {
            j != i && box_.minimum_image(&(positions[j] - trial)).norm() <= radii[i] + radii[j]
        });
        let answer = lists.overlaps(i, &trial, positions, box_, |j| j != i);
        if let Some(answer) = answer {
            assert_eq!(answer, all_pairs, "sphere {i} at {trial}");
        }
        positions[i] = trial;
        lists.moved(i, &trial, box_);
        answer.is_some()
    }

    /// Random walks of spheres (overlaps allowed: the lists do not care):
    /// after every step the overlap answer from the lists (where they
    /// reach) equals the all-pairs answer, and every list is exactly the
    /// set its definition says.
    #[test]
    fn lists_answer_as_all_pairs_through_random_walks() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let box_ = PeriodicBox::new(V3::new(6.0, 7.0, 8.0)).unwrap();
        let n = 120;
        let radii: Vec<f64> = (0..n)
            .map(|i| if i % 3 == 0 { 0.25 } else { 0.5 })
            .collect();
        let mut positions: Vec<V3> = (0..n)
            .map(|_| {
                box_.wrap(&V3::new(
                    rng.gen_range(-3.0..3.0),
                    rng.gen_range(-3.5..3.5),
                    rng.gen_range(-4.0..4.0),
                ))
            })
            .collect();
        let skin = 0.3;
        let mut lists = SphereLists::new(&box_, &positions, &radii, skin);
        let mut answered = 0;
        for step in 0..20_000 {
            answered += usize::from(random_step(
                &mut rng,
                &mut lists,
                &mut positions,
                &radii,
                &box_,
            ));
            if step % 1000 == 0 {
                for a in 0..n {
                    let mut listed: Vec<u32> = lists.lists.of(a).to_vec();
                    listed.sort_unstable();
                    let expected: Vec<u32> = (0..n)
                        .filter(|&b| {
                            b != a && {
                                let d =
                                    box_.minimum_image(&(lists.reference[b] - lists.reference[a]));
                                d.norm() <= radii[a] + radii[b] + skin
                            }
                        })
                        .map(|b| b as u32)
                        .collect();
                    assert_eq!(listed, expected, "list of {a} at step {step}");
                }
            }
        }
        assert!(answered > 5_000, "{answered} answered by the lists");
    }

    /// Before a box change, the lists say whether the scaled spheres
    /// overlap as all pairs do (hard spheres from random insertion, box
    /// changes of −3 % to +1 % along all axes or one, or shears of up to
    /// 0.02 in a tilt, each kept only if it overlaps nothing, as a Monte
    /// Carlo box move).
    #[test]
    fn overlaps_after_a_box_change_are_those_of_all_pairs() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        let mut box_ = PeriodicBox::new(V3::new(6.0, 6.5, 7.0)).unwrap();
        let radii: Vec<f64> = (0..150)
            .map(|i| if i % 3 == 0 { 0.3 } else { 0.5 })
            .collect();
        let mut positions: Vec<V3> = Vec::new();
        while positions.len() < radii.len() {
            let k = positions.len();
            let r = box_.wrap(&V3::from_fn(|a, _| {
                rng.gen_range(-3.5..3.5) * box_.lengths()[a] / 7.0
            }));
            if positions
                .iter()
                .enumerate()
                .all(|(j, p)| box_.minimum_image(&(p - r)).norm() > radii[j] + radii[k])
            {
                positions.push(r);
            }
        }
        let mut lists = SphereLists::new(&box_, &positions, &radii, 0.4);
        let (mut refused, mut accepted) = (0, 0);
        for step in 0..400 {
            let f = 1.0 + rng.gen_range(-0.03..0.01);
            let factor = if step % 3 == 0 {
                V3::repeat(f)
            } else {
                V3::from_fn(|a, _| if a == step % 3 { f } else { 1.0 })
            };
            let new_box = if step % 3 == 2 {
                let shear = V3::from_fn(|a, _| if a == step % 7 % 3 { f - 1.0 } else { 0.0 });
                box_.with_tilts(box_.tilts() + shear).unwrap()
            } else {
                box_.with_lengths(box_.lengths().component_mul(&factor))
                    .unwrap()
            };
            let scaled: Vec<V3> = positions
                .iter()
                .map(|r| new_box.wrap(&new_box.map_from(&box_, r)))
                .collect();
            let touching = |i: usize| {
                (0..scaled.len()).any(|j| {
                    j != i
                        && new_box.minimum_image(&(scaled[j] - scaled[i])).norm()
                            <= radii[i] + radii[j]
                })
            };
            let all_pairs = (0..scaled.len()).any(touching);
            assert_eq!(
                lists.overlap_after_rescale(&box_, &new_box, &scaled, touching),
                all_pairs,
                "step {step}"
            );
            if all_pairs {
                refused += 1;
                continue;
            }
            accepted += 1;
            let old = std::mem::replace(&mut box_, new_box);
            positions = scaled;
            if !lists.rescaled(&old, &box_, &positions) {
                lists = SphereLists::new(&box_, &positions, &radii, 0.4);
            }
        }
        assert!(
            refused > 20 && accepted > 20,
            "refused {refused}, accepted {accepted}"
        );
    }

    /// Two spheres listed apart (their references beyond contact plus the
    /// skin), the second since moved half a skin closer: a shrink by a
    /// fifth brings them into contact, which only the strays' own check
    /// (or a gap that ignored the shrink) can see.
    #[test]
    fn a_shrink_that_brings_unlisted_spheres_into_contact_is_seen() {
        let box_ = PeriodicBox::new(V3::repeat(10.0)).unwrap();
        let radii = [0.5, 0.5];
        let skin = 0.4;
        let mut positions = vec![V3::zeros(), V3::new(1.0 + skin + 0.01, 0.0, 0.0)];
        let mut lists = SphereLists::new(&box_, &positions, &radii, skin);
        assert!(lists.lists.of(0).is_empty());
        positions[1].x -= 0.5 * skin - 0.01;
        lists.moved(1, &positions[1], &box_);
        assert!(
            lists.lists.of(0).is_empty(),
            "within half a skin: not relisted"
        );
        let new_box = box_.with_lengths(box_.lengths() * 0.81).unwrap();
        let scaled: Vec<V3> = positions
            .iter()
            .map(|r| new_box.wrap(&(r * 0.81)))
            .collect();
        assert!(new_box.minimum_image(&(scaled[1] - scaled[0])).norm() < 1.0);
        let touching = |i: usize| new_box.minimum_image(&(scaled[1 - i] - scaled[i])).norm() <= 1.0;
        assert!(lists.overlap_after_rescale(&box_, &new_box, &scaled, touching));
    }

    /// What makes a list's answer right: every centre within half the gap
    /// of its reference, and every sphere j unlisted by i farther than
    /// their contact distance from anywhere i may be tried (within half the
    /// gap of its reference).
    fn assert_unlisted_out_of_reach(lists: &SphereLists, positions: &[V3], box_: &PeriodicBox) {
        let n = positions.len();
        for (i, (r, reference)) in positions.iter().zip(&lists.reference).enumerate() {
            let drift = box_.minimum_image(&(r - reference)).norm();
            assert!(
                drift <= 0.5 * lists.gap,
                "{i} strayed {drift} > {}",
                0.5 * lists.gap
            );
        }
        for i in 0..n {
            let listed = lists.lists.of(i);
            for j in (0..n).filter(|&j| j != i && !listed.contains(&(j as u32))) {
                let d = box_
                    .minimum_image(&(positions[j] - lists.reference[i]))
                    .norm();
                let reach = lists.radii[i] + lists.radii[j] + 0.5 * lists.gap;
                assert!(d > reach, "{j} unlisted by {i} within {d} < {reach}");
            }
        }
    }

    /// The same through box changes (isotropic and along one axis, shrinks
    /// and expansions, overlaps allowed): the lists rescaled with the box
    /// answer as all pairs wherever they answer, and every unlisted pair
    /// stays out of reach; a run of shrinks uses up their gap and they give
    /// up, to be built afresh.
    #[test]
    fn rescaled_lists_answer_as_all_pairs() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let mut box_ = PeriodicBox::new(V3::new(6.0, 7.0, 8.0)).unwrap();
        let n = 150;
        let radii: Vec<f64> = (0..n)
            .map(|i| if i % 3 == 0 { 0.25 } else { 0.5 })
            .collect();
        let mut positions: Vec<V3> = (0..n)
            .map(|_| {
                box_.wrap(&V3::from_fn(|k, _| {
                    rng.gen_range(-3.0..3.0) * (1.0 + k as f64 / 6.0)
                }))
            })
            .collect();
        let skin = 0.4;
        let mut lists = SphereLists::new(&box_, &positions, &radii, skin);
        let (mut answered, mut kept, mut given_up) = (0, 0, 0);
        for step in 0..30_000 {
            if step % 50 == 49 {
                // Shrinks more often than expansions: the gap runs out.
                let f = 1.0 + rng.gen_range(-0.012..0.008);
                let factor = if rng.r#gen::<bool>() {
                    V3::repeat(f)
                } else {
                    V3::from_fn(|k, _| if k == step % 3 { f } else { 1.0 })
                };
                let old = box_;
                box_ = box_
                    .with_lengths(box_.lengths().component_mul(&factor))
                    .unwrap();
                for r in &mut positions {
                    *r = box_.wrap(&box_.map_from(&old, r));
                }
                if lists.rescaled(&old, &box_, &positions) {
                    kept += 1;
                    assert_unlisted_out_of_reach(&lists, &positions, &box_);
                } else {
                    given_up += 1;
                    lists = SphereLists::new(&box_, &positions, &radii, skin);
                }
            }
            answered += usize::from(random_step(
                &mut rng,
                &mut lists,
                &mut positions,
                &radii,
                &box_,
            ));
            if step % 1000 == 0 {
                assert_unlisted_out_of_reach(&lists, &positions, &box_);
            }
        }
        assert!(answered > 5_000, "{answered} answered by the lists");
        assert!(
            kept > 100 && given_up > 3,
            "kept {kept}, given up {given_up}"
        );
    }
}
