//! Closed-form contacts of sphere pairs, computed side by side: a body's
//! partners in batches of [`LANES`], structure of arrays, so that the
//! square roots and divisions of a batch run at once and a batch none of
//! whose pairs can touch in time is skipped whole.

use crate::edmd::motion::position_after;

use super::*;

impl Dynamics {
    /// [`Dynamics::earliest_closed_form`] over a neighbour list, the
    /// partners `keep` lets through: [`LANES`] contact times are computed
    /// side by side, so that their square roots and divisions run at once
    /// instead of one after the other, and a batch none of whose pairs can
    /// touch in time skips them. The same result to the bit, the partners
    /// taken in the list's order (which of equal times wins).
    #[inline(always)]
    pub(super) fn earliest_closed_form_listed(
        &self,
        i: usize,
        list: &[u32],
        keep: impl Fn(usize) -> bool,
        mut horizon: f64,
    ) -> Option<(f64, usize)> {
        let lanes = list.chunks_exact(LANES);
        // The rest as one more batch, its last partner repeated (found
        // twice, kept once: the comparison is strict).
        let rest = lanes.remainder();
        let padded = rest.last().map(|&last| {
            let mut padded = [last; LANES];
            padded[..rest.len()].copy_from_slice(rest);
            padded
        });
        let lanes = lanes.chain(padded.as_ref().map(|p| &p[..]));
        // The common cases apart, each with its constants out of the loop:
        // a body just moved to now (after a collision) and one species.
        // A tilted box takes the general case (moving `i` by zero gives
        // the same bits).
        let at_now = self.bodies[i].time == self.now;
        let sigma = |j| self.sigma(i, j);
        let one_sum = self.species.len() == 1 && self.body_radii.is_empty();
        match (at_now, one_sum, self.box_.is_tilted()) {
            (_, _, true) => {
                self.earliest_in_lanes::<false, true>(i, lanes, &keep, &mut horizon, sigma)
            }
            (true, true, false) => {
                let sigma = self.contact_sums[0].unwrap_or(f64::NAN);
                self.earliest_in_lanes::<true, false>(i, lanes, &keep, &mut horizon, |_| sigma)
            }
            (true, false, false) => {
                self.earliest_in_lanes::<true, false>(i, lanes, &keep, &mut horizon, sigma)
            }
            (false, _, false) => {
                self.earliest_in_lanes::<false, false>(i, lanes, &keep, &mut horizon, sigma)
            }
        }
    }

    /// The batches of [`Dynamics::earliest_closed_form_listed`]: the
    /// earliest contact before `horizon`, which it lowers to it. `AT_NOW`:
    /// body `i` is at the current time.
    #[inline(always)]
    fn earliest_in_lanes<'a, const AT_NOW: bool, const TILTED: bool>(
        &self,
        i: usize,
        lanes: impl Iterator<Item = &'a [u32]>,
        keep: &impl Fn(usize) -> bool,
        horizon: &mut f64,
        sigma: impl Fn(usize) -> f64,
    ) -> Option<(f64, usize)> {
        let mut partner = usize::MAX;
        for lanes in lanes {
            let lanes: [usize; LANES] = std::array::from_fn(|k| lanes[k] as usize);
            let products = self.lane_products::<AT_NOW, TILTED>(i, &lanes, &sigma);
            // Most batches have no partner closing in time: no square
            // roots, no divisions for them.
            let before = lanes.map(|j| earlier(*horizon, self.bodies[j].horizon));
            if self.growth.is_none() && !products.may_meet_before(&before) {
                continue;
            }
            let times = self.lane_times(&products);
            let kept = lanes.map(keep);
            let lane = earliest_lane(times, before, kept, horizon);
            // Conditional moves (which lane, if any, comes first is a coin
            // toss to the branch predictor), and the lanes picked by
            // selection, not by address, so that they stay in registers.
            let found = std::hint::select_unpredictable(lane == 1, lanes[1], lanes[0]);
            partner = std::hint::select_unpredictable(lane < LANES, found, partner);
        }
        (partner != usize::MAX).then_some((*horizon, partner))
    }

    /// [`Dynamics::closed_form_contact`] of body `i` with each of `others`,
    /// to the bit, computed side by side.
    #[cfg(test)]
    pub(super) fn closed_form_contacts(&self, i: usize, others: &[usize; LANES]) -> [f64; LANES] {
        let sigma = |j| self.sigma(i, j);
        self.lane_times(&if self.box_.is_tilted() {
            self.lane_products::<false, true>(i, others, sigma)
        } else {
            self.lane_products::<false, false>(i, others, sigma)
        })
    }

    /// What [`Dynamics::closed_form_contacts`] needs of each pair: the
    /// later of the two stored times, d·Δv, |d|², |Δv|² and σ there.
    /// `AT_NOW`: body `i` is at the current time, which is then the later
    /// time of every pair (the same bits, without moving `i` by zero).
    /// `TILTED`: the box is (a constant, so that the orthorhombic loop
    /// stays as tight as it is without tilts).
    #[inline(always)]
    pub(super) fn lane_products<const AT_NOW: bool, const TILTED: bool>(
        &self,
        i: usize,
        others: &[usize; LANES],
        sigma_of: impl Fn(usize) -> f64,
    ) -> LaneProducts {
        let bi = &self.bodies[i];
        // Structure of arrays, one lane per partner, so that the compiler
        // computes the lanes in vector registers.
        let mut d = [[0.0; LANES]; 3];
        let mut dv = [[0.0; LANES]; 3];
        let mut t0 = [self.now; LANES];
        let mut sigma = [0.0; LANES];
        for (k, &j) in others.iter().enumerate() {
            let bj = &self.bodies[j];
            sigma[k] = sigma_of(j);
            // Both bodies brought to the later of their times (the one
            // already there moves by zero: the same bits as moving only the
            // other, as `closed_form_contact` does).
            let ri = if AT_NOW {
                bi.position
            } else {
                t0[k] = later(bi.time, bj.time);
                position_after(&bi.position, &bi.velocity, t0[k] - bi.time)
            };
            let rj = position_after(&bj.position, &bj.velocity, t0[k] - bj.time);
            for a in 0..3 {
                d[a][k] = rj[a] - ri[a];
                dv[a][k] = bj.velocity[a] - bi.velocity[a];
            }
        }
        // The products of each lane: the image nearest now (as
        // `closed_form_contact`), in the order of nalgebra's (x, y, z).
        // nalgebra sums from zero; d·Δv here from −0, its first term:
        // they differ only in the sign of a zero d·Δv, a pair that never
        // meets either way.
        let mut b = [-0.0; LANES];
        let mut dd = [0.0; LANES];
        let mut v2 = [0.0; LANES];
        for k in 0..LANES {
            let now = |a: usize| {
                if AT_NOW {
                    d[a][k]
                } else {
                    d[a][k] + dv[a][k] * (self.now - t0[k])
                }
            };
            // In a tilted box the shifts are whole lattice vectors chosen
            // in unsheared coordinates, not axis by axis.
            let tilted_shift = if TILTED {
                self.box_.image_shift(&V3::from_fn(|a, _| now(a)))
            } else {
                V3::zeros()
            };
            for a in 0..3 {
                let shift = if TILTED {
                    tilted_shift[a]
                } else {
                    self.box_.image_shift_along(a, now(a))
                };
                let x = d[a][k] + shift;
                b[k] += x * dv[a][k];
                dd[k] += x * x;
                v2[k] += dv[a][k] * dv[a][k];
            }
        }
        LaneProducts {
            t0,
            b,
            dd,
            v2,
            sigma,
        }
    }

    /// The contact times of [`Dynamics::closed_form_contacts`] from the
    /// pairs' products.
    #[inline(always)]
    pub(super) fn lane_times(&self, products: &LaneProducts) -> [f64; LANES] {
        let LaneProducts {
            t0,
            b,
            dd,
            v2,
            sigma,
        } = *products;
        let mut times = [0.0; LANES];
        // Growth is decided once for the lanes, outside their loop, which
        // the compiler then keeps in vector registers.
        match self.growth {
            None => {
                let t = crate::geometry::pair::sphere_contact_times_from_products(b, dd, v2, sigma);
                for k in 0..LANES {
                    times[k] = (t0[k] + t[k]).max(self.now); // t0 + ∞ stays ∞
                }
            }
            Some(g) => {
                for k in 0..LANES {
                    let t = crate::geometry::pair::grown_sphere_contact_time(
                        b[k],
                        dd[k],
                        v2[k],
                        sigma[k] * g.at(t0[k]),
                        sigma[k] * g.rate,
                    );
                    times[k] = (t0[k] + t).max(self.now);
                }
            }
        }
        times
    }
}

/// Partners whose closed-form contact times are computed side by side:
/// two, one vector register of SSE2. Against four, simulated over 4000
/// spheres at φ = 0.5 with lists, 5 % fewer instructions and 18 % fewer
/// mispredicted branches (more batches skipped whole).
pub(super) const LANES: usize = 2;

/// Per lane of a batch of sphere pairs: the later of the two stored times
/// and, there, d·Δv, |d|², |Δv|² and the contact distance σ.
#[derive(Clone, Copy)]
pub(super) struct LaneProducts {
    t0: [f64; LANES],
    b: [f64; LANES],
    dd: [f64; LANES],
    v2: [f64; LANES],
    sigma: [f64; LANES],
}

impl LaneProducts {
    /// Whether any lane's pair may touch (without growth) before the
    /// lane's time in `before`: false only if every pair recedes or meets
    /// at or after it. A closing pair apart (c = |d|² − σ² > 0, b = d·Δv <
    /// 0) touches at c / (−b + √(b² − |Δv|² c)) ≥ c / (−2b) after t₀,
    /// also as computed (the denominator rounds to at most 2|b|(1 + 3ε)),
    /// so c ≥ −2b (before − t₀)(1 + 10⁻⁶) rules it out before `before`
    /// with room for every rounding.
    #[inline(always)]
    pub(super) fn may_meet_before(&self, before: &[f64; LANES]) -> bool {
        let mut any = false;
        for (k, &before) in before.iter().enumerate() {
            let c = self.dd[k] - self.sigma[k] * self.sigma[k];
            // The constants folded into one factor.
            let ruled_out = c >= self.b[k] * (before - self.t0[k]) * (-2.0 * (1.0 + 1e-6));
            any |= (self.b[k] < 0.0) & !ruled_out;
        }
        any
    }
}

/// Which lane of a batch holds the earliest contact, `LANES` if none:
/// among the `times` that `kept` lets through and that come before the
/// lane's `before` (the horizon or the partner's own, if earlier), the
/// earliest, the first of equal ones, as taking the lanes one after the
/// other would; `horizon` is lowered to it. Without a branch on the
/// times: one of floats, in vector registers, which the compiler would
/// otherwise turn into jumps mispredicted about one time in three.
#[inline(always)]
fn earliest_lane(
    times: [f64; LANES],
    before: [f64; LANES],
    kept: [bool; LANES],
    horizon: &mut f64,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_and_pd, _mm_andnot_pd, _mm_castsi128_pd, _mm_cmplt_pd, _mm_cvtsd_f64, _mm_loadu_pd,
            _mm_min_sd, _mm_movemask_pd, _mm_or_pd, _mm_set_epi64x, _mm_set1_pd, _mm_shuffle_pd,
        };
        // SAFETY: SSE2 is part of the x86_64 baseline; the loads read
        // two-element arrays.
        let (taken, second_earlier, least) = unsafe {
            let t = _mm_loadu_pd(times.as_ptr());
            let kept = _mm_castsi128_pd(_mm_set_epi64x(-i64::from(kept[1]), -i64::from(kept[0])));
            let taken = _mm_and_pd(kept, _mm_cmplt_pd(t, _mm_loadu_pd(before.as_ptr())));
            // +∞ in the lanes not taken.
            let candidate = _mm_or_pd(
                _mm_and_pd(taken, t),
                _mm_andnot_pd(taken, _mm_set1_pd(f64::INFINITY)),
            );
            let swapped = _mm_shuffle_pd::<0b01>(candidate, candidate);
            (
                _mm_movemask_pd(taken),
                _mm_movemask_pd(_mm_cmplt_pd(candidate, swapped)) >> 1,
                _mm_cvtsd_f64(_mm_min_sd(candidate, swapped)),
            )
        };
        // A lane taken comes before the horizon: the least of them is the
        // new one (+∞, and no change, if none).
        *horizon = earlier(*horizon, least);
        let second = (taken >> 1) & second_earlier != 0;
        let first = taken & 1 != 0;
        if second {
            1
        } else if first {
            0
        } else {
            LANES
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut lane = LANES;
        for k in 0..LANES {
            if kept[k] && times[k] < earlier(*horizon, before[k]) {
                lane = k;
                *horizon = times[k];
            }
        }
        lane
    }
}

/// The earlier of two times, neither NaN (one compare, where `f64::min`
/// also sorts out NaN).
#[inline(always)]
fn earlier(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

/// The later of two times, neither NaN.
#[inline(always)]
fn later(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch's earliest lane is the one taking the lanes one after the
    /// other finds, with the same new horizon: over times drawn from a few
    /// values (ties between lanes, with the horizon and with the
    /// partners'), +∞, and lanes left out.
    #[test]
    fn earliest_lane_is_the_lanes_taken_in_turn() {
        let mut u = crate::test_support::uniform(4);
        let values = [0.0, 0.5, 1.0, 1.5, 2.0, f64::INFINITY];
        let mut pick = || values[(u() * values.len() as f64) as usize % values.len()];
        let mut lanes_found = [0; LANES + 1];
        for _ in 0..20_000 {
            let times: [f64; LANES] = std::array::from_fn(|_| pick());
            let partners: [f64; LANES] = std::array::from_fn(|_| pick());
            let kept: [bool; LANES] = std::array::from_fn(|_| pick() < 1.9);
            let start = pick();
            let (mut expected_horizon, mut expected) = (start, LANES);
            for k in 0..LANES {
                if kept[k] && times[k] < expected_horizon.min(partners[k]) {
                    (expected_horizon, expected) = (times[k], k);
                }
            }
            let before = partners.map(|h| earlier(start, h));
            let mut horizon = start;
            let lane = earliest_lane(times, before, kept, &mut horizon);
            assert_eq!(
                (lane, horizon),
                (expected, expected_horizon),
                "{times:?} {partners:?} {kept:?} from {start}"
            );
            lanes_found[lane] += 1;
        }
        assert!(lanes_found.iter().all(|&n| n > 1000), "{lanes_found:?}");
    }
}
