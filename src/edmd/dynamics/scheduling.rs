//! Scheduling: the earliest predicted collision of a body with its
//! neighbours, spheres in closed form (side by side in `lanes.rs`),
//! bodies through the predictor, in every image where they can touch.

use nalgebra::{UnitQuaternion, Vector3};

use crate::edmd::calendar::{Calendar, EventKind};
use crate::edmd::motion::position_after;
use crate::edmd::search::{Found, Growth, Progress};
use crate::geometry::WarmStart;

type V3 = Vector3<f64>;

use super::*;

impl Dynamics {
    /// Closed-form pairs only: schedules body `i`'s collisions with the
    /// bodies in the 3×3 cells around `layer` across `axis` (its new
    /// neighbours after a crossing), if earlier than its earliest one.
    pub(super) fn schedule_collisions_in_layer(
        &mut self,
        i: usize,
        layer: [usize; 3],
        axis: usize,
    ) -> Result<(), EdmdError> {
        let dims = self.cells.dims();
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let layer_cells: [u32; 9] = std::array::from_fn(|k| {
            let mut c = layer;
            c[a] = (c[a] + [dims[a] - 1, 0, 1][k / 3]) % dims[a];
            c[b] = (c[b] + [dims[b] - 1, 0, 1][k % 3]) % dims[b];
            self.cells.index_of(c) as u32
        });
        let horizon = self.bodies[i].horizon;
        let earliest = self.earliest_closed_form_in_cells(i, &layer_cells, |j| j != i, horizon);
        self.schedule_earliest(i, earliest);
        Ok(())
    }

    /// Body `i`'s centre and orientation at time `t`, by free motion from
    /// its stored pose.
    pub(super) fn pose_at(&self, i: usize, t: f64) -> (V3, UnitQuaternion<f64>) {
        body_pose(&self.kinds, &self.bodies[i], t)
    }

    /// [`Self::pose_at`] with the body's free rotation `top` already built
    /// (for searches that ask for many times).
    #[inline]
    pub(super) fn pose_by(&self, i: usize, top: &FreeTop, t: f64) -> (V3, UnitQuaternion<f64>) {
        let b = &self.bodies[i];
        let dt = t - b.time;
        (
            position_after(&b.position, &b.velocity, dt),
            top.orientation_after(dt),
        )
    }

    /// Predicts and schedules the collisions of body `i` (at the current
    /// time) with the bodies in the cells around it, except `skip`; with
    /// `once`, only with bodies of larger index (the initial sweep over all
    /// pairs). Each search stops at the earliest event found so far for `i`
    /// (its horizon): a later collision of `i` would be invalidated by it.
    pub(super) fn schedule_collisions(
        &mut self,
        i: usize,
        skip: Option<usize>,
        once: bool,
    ) -> Result<(), EdmdError> {
        // Without short cuts: one branch less per partner.
        let skip = skip.unwrap_or(usize::MAX);
        let keep = |j: usize| (j != i) & (j != skip) & !(once & (j < i));
        if self.closed_form {
            // Every search is one closed-form solve, exact whenever it is
            // done: none deferred. With lists, no further than the body's
            // escape, where its search is renewed over its new list.
            let (horizon, earliest) = match &self.neighbours {
                Some(spheres) => {
                    let list = spheres.lists.of(i);
                    prefetch_bodies(&self.bodies, list);
                    let escape = self.crossing_times[i];
                    (
                        escape,
                        self.earliest_closed_form_listed(i, list, keep, escape),
                    )
                }
                None => {
                    let around = self.cells.neighbour_cells(self.cells.cell_of(i));
                    let earliest =
                        self.earliest_closed_form_in_cells(i, &around, keep, f64::INFINITY);
                    (f64::INFINITY, earliest)
                }
            };
            self.bodies[i].horizon = horizon;
            self.schedule_earliest(i, earliest);
            return Ok(());
        }
        let mut horizon_i = self.crossing_times[i];
        // Searches that need many steps (pairs lingering close together)
        // wait until the cheap ones have shortened the horizon.
        let mut deferred = std::mem::take(&mut self.deferred);
        deferred.clear();
        // Only the earliest contact found is scheduled: a later one would be
        // invalidated by it, or, if its partner changes first, found again
        // when the search is renewed from there (see `process_next`).
        let mut earliest = None;
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.clear();
        match &self.neighbours {
            Some(spheres) => candidates.extend_from_slice(spheres.lists.of(i)),
            None => {
                for nc in self.cells.neighbour_cells(self.cells.cell_of(i)) {
                    candidates.extend_from_slice(self.cells.members(nc as usize));
                }
            }
        }
        // Where a search out of budget leaves its progress.
        let mut stopped = None;
        for &j in &candidates {
            let j = j as usize;
            if !keep(j) {
                continue;
            }
            // Past j's own horizon, j's first event will have changed it
            // or renewed its search (which covers this pair).
            let horizon = horizon_i.min(self.bodies[j].horizon);
            match self.predict_pair(i, j, horizon, CHEAP_SEARCH, None, &mut stopped)? {
                PairSearch::Contact(t, warm) => {
                    earliest = Some((t, j, warm));
                    horizon_i = t;
                }
                PairSearch::Apart => {}
                PairSearch::Unfinished(t) => {
                    deferred.push((j as u32, t, stopped.take().expect("stopped")))
                }
            }
        }
        self.candidates = candidates;
        // The put-off searches race: the least advanced one takes the next
        // few steps, so that the first contact among them is found before
        // any of them searches past it (it becomes everyone's horizon). A
        // search resumes with its solver state: the same steps as if it
        // had not stopped (see `predict_pair`).
        while !deferred.is_empty() {
            let (k, &(j, _, progress)) = deferred
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.1.total_cmp(&b.1.1))
                .expect("not empty");
            let j = j as usize;
            let horizon = horizon_i.min(self.bodies[j].horizon);
            match self.predict_pair(i, j, horizon, CHEAP_SEARCH, Some(&progress), &mut stopped)? {
                PairSearch::Contact(t, warm) => {
                    earliest = Some((t, j, warm));
                    horizon_i = t;
                    deferred.swap_remove(k);
                }
                PairSearch::Apart => {
                    deferred.swap_remove(k);
                }
                PairSearch::Unfinished(t) => {
                    deferred[k] = (j as u32, t, stopped.take().expect("stopped"))
                }
            }
        }
        self.deferred = deferred;
        self.bodies[i].horizon = horizon_i;
        if let Some((t, j, warm)) = earliest {
            schedule_collision(&mut self.calendar, &mut self.found, t, i, j, warm);
        }
        Ok(())
    }

    /// Closed-form pairs: the earliest contact of body `i` (at the current
    /// time) with one of `others` before `horizon` and before the other's
    /// own horizon (past it, the other's first event changes it or renews
    /// its search, which covers the pair).
    pub(super) fn earliest_closed_form(
        &self,
        i: usize,
        others: impl Iterator<Item = usize>,
        mut horizon: f64,
    ) -> Option<(f64, usize)> {
        let mut earliest = None;
        for j in others {
            // +∞ for pairs that never meet: no branch on whether they do.
            let t = self.closed_form_contact(i, j);
            if t < horizon.min(self.bodies[j].horizon) {
                earliest = Some((t, j));
                horizon = t;
            }
        }
        earliest
    }

    /// The contact distance of bodies `i` and `j` if closed-form, else NaN
    /// (which meets nothing).
    #[inline(always)]
    pub(super) fn sigma(&self, i: usize, j: usize) -> f64 {
        self.contact_sum(i, j).unwrap_or(f64::NAN)
    }

    /// The contact distance of bodies `i` and `j` at full size if both are
    /// spheres: their species' table, or with sizes their own radii.
    #[inline(always)]
    pub(super) fn contact_sum(&self, i: usize, j: usize) -> Option<f64> {
        let sum = self.contact_sums[self.pair_index(i, j)];
        if self.body_radii.is_empty() {
            sum
        } else {
            sum.map(|_| self.body_radii[i] + self.body_radii[j])
        }
    }

    /// [`Dynamics::earliest_closed_form_listed`] over the members of
    /// `cells` that `keep` lets through, gathered room by room first (and
    /// prefetched); more than fit are searched one at a time.
    #[inline(always)]
    pub(super) fn earliest_closed_form_in_cells(
        &mut self,
        i: usize,
        cells: &[u32],
        keep: impl Fn(usize) -> bool,
        horizon: f64,
    ) -> Option<(f64, usize)> {
        let cells = cells.iter().map(|&c| c as usize);
        match self.cells.gather(cells.clone(), &mut self.around[..]) {
            Some(count) => {
                let near = &self.around[..count];
                prefetch_bodies(&self.bodies, near);
                self.earliest_closed_form_listed(i, near, keep, horizon)
            }
            None => {
                let near = cells
                    .flat_map(|c| self.cells.members(c))
                    .map(|&j| j as usize);
                self.earliest_closed_form(i, near.filter(|&j| keep(j)), horizon)
            }
        }
    }

    /// Schedules the contact found by [`Dynamics::earliest_closed_form`],
    /// which becomes body `i`'s horizon.
    pub(super) fn schedule_earliest(&mut self, i: usize, earliest: Option<(f64, usize)>) {
        if let Some((t, j)) = earliest {
            self.bodies[i].horizon = t;
            self.calendar.schedule(t, EventKind::Collision, i, j);
        }
    }

    /// Where the species pair of bodies `i` and `j` sits in
    /// `contact_sums`.
    #[inline]
    pub(super) fn pair_index(&self, i: usize, j: usize) -> usize {
        self.species_of(i) * self.species.len() + self.species_of(j)
    }

    /// Body `k`'s species; with one species, without reading the body's
    /// second cache line, which spheres need for nothing else.
    #[inline]
    pub(super) fn species_of(&self, k: usize) -> usize {
        if self.species.len() == 1 {
            0
        } else {
            self.bodies[k].species as usize
        }
    }

    /// The contact time of two spheres, `i` at the current time (absolute,
    /// +∞ if they never touch).
    #[inline(always)]
    pub(super) fn closed_form_contact(&self, i: usize, j: usize) -> f64 {
        let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
        let Some(sigma) = self.contact_sum(i, j) else {
            return f64::INFINITY;
        };
        // From the later of the two stored poses, whenever the search runs:
        // the same bits for the same poses (see `closed_form`).
        // The image is the one nearest now (bodies that have flown far
        // since t0 may have been nearer in another then); neighbours are
        // far closer than half a box, so every search picks the same one.
        let dv = bj.velocity - bi.velocity;
        let (t0, raw) = if bi.time >= bj.time {
            let rj = position_after(&bj.position, &bj.velocity, bi.time - bj.time);
            (bi.time, rj - bi.position)
        } else {
            let ri = position_after(&bi.position, &bi.velocity, bj.time - bi.time);
            (bj.time, bj.position - ri)
        };
        let d = raw + self.box_.image_shift(&(raw + dv * (self.now - t0)));
        let t = match self.growth {
            None => crate::geometry::pair::sphere_contact_time_or_never(&d, &dv, sigma),
            Some(g) => grown_sphere_contact(&d, &dv, sigma, g, t0),
        };
        (t0 + t).max(self.now)
    }

    /// The contact time of bodies `i` and `j` if it comes before
    /// `horizon`, with about `budget` steps (else how far the search got,
    /// to resume it from there with `resume`). Canonical (see
    /// `closed_form`): searched from the later of the two stored poses, the
    /// body of lower index as A, on a step grid the horizon does not cut,
    /// and resumed with its solver state; so the time found is a function
    /// of the two stored poses alone, whenever and from whichever body the
    /// search runs.
    pub(super) fn predict_pair(
        &self,
        i: usize,
        j: usize,
        horizon: f64,
        budget: u32,
        resume: Option<&Progress>,
        stopped: &mut Option<Progress>,
    ) -> Result<PairSearch, EdmdError> {
        let (a, b) = (i.min(j), i.max(j));
        // Growing bodies are bounded by their species' shapes only up to
        // the end of the growth.
        let horizon = match self.growth {
            None => horizon,
            Some(g) => horizon.min(g.ends()),
        };
        let (ba, bb) = (&self.bodies[a], &self.bodies[b]);
        let t0 = ba.time.max(bb.time);
        let ra = position_after(&ba.position, &ba.velocity, t0 - ba.time);
        let rb = position_after(&bb.position, &bb.velocity, t0 - bb.time);
        let dv = bb.velocity - ba.velocity;
        // The image nearest now (as for closed-form pairs).
        let raw = rb - ra;
        let nearest = raw + self.box_.image_shift(&(raw + dv * (self.now - t0)));
        // In a box narrow enough, the images ahead first, each searched to
        // the end (they only lower the horizon); then the nearest, whose
        // search may be put off and resumed with its own state.
        let (steps, axes) = self.image_steps(&dv);
        let mut horizon = horizon;
        let mut further = None;
        for k in 1..3usize.pow(axes as u32) {
            // Image k: digit m of k (base 3) steps along narrow axis m.
            let mut image = nearest;
            let mut digits = k;
            for step in &steps[..axes] {
                image += step * (digits % 3) as f64;
                digits /= 3;
            }
            let mut unused = None;
            let found = self.search_pair_image(
                a,
                b,
                t0,
                &image,
                &dv,
                horizon,
                u32::MAX,
                None,
                &mut unused,
            )?;
            let warm = self.predictor.take_found();
            if let Found::Contact(t) = found
                && t0 + t < horizon
            {
                horizon = t0 + t;
                further = Some(warm);
            }
        }
        let found =
            self.search_pair_image(a, b, t0, &nearest, &dv, horizon, budget, resume, stopped)?;
        let warm = self.predictor.take_found();
        Ok(match (found, further) {
            // Not before now (rounding at a contact found right now).
            (Found::Contact(t), _) if t0 + t < horizon => {
                PairSearch::Contact((t0 + t).max(self.now), warm)
            }
            (Found::Stopped(t), _) => PairSearch::Unfinished(t0 + t),
            (_, Some(warm)) => PairSearch::Contact(horizon.max(self.now), warm),
            (Found::Contact(_) | Found::Apart, None) => PairSearch::Apart,
        })
    }

    /// Where else than in the image nearest now a pair moving apart at
    /// `dv` can next touch: none, unless an axis is narrower than four
    /// cells. There a pair in neighbouring cells may be more than half a
    /// box apart, and it can pass into the next image, or (in one or two
    /// cells) the one after, before either body leaves its cell or
    /// neighbour region. Returns the step to the next image ahead (in the
    /// direction the separation moves) along each such axis, and how many
    /// axes; the images are the nearest plus 0, 1 or 2 steps along each.
    fn image_steps(&self, dv: &V3) -> ([V3; 3], usize) {
        let mut steps = [V3::zeros(); 3];
        let mut axes = 0;
        if !self.narrow.contains(&true) {
            return (steps, axes);
        }
        let moving = self.box_.unshear(dv);
        for k in (0..3).filter(|&k| self.narrow[k] && moving[k] != 0.0) {
            steps[axes] = self.box_.lattice_vector(k) * -moving[k].signum();
            axes += 1;
        }
        (steps, axes)
    }

    /// The contact of bodies `a` < `b`, at separation `d` at `t0`, within
    /// `horizon` (see [`Dynamics::predict_pair`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn search_pair_image(
        &self,
        a: usize,
        b: usize,
        t0: f64,
        d: &V3,
        dv: &V3,
        horizon: f64,
        budget: u32,
        resume: Option<&Progress>,
        stopped: &mut Option<Progress>,
    ) -> Result<Found, EdmdError> {
        let (ba, bb) = (&self.bodies[a], &self.bodies[b]);
        if let Some(sigma) = self.contact_sum(a, b) {
            let t = match self.growth {
                None => crate::geometry::pair::sphere_contact_time_or_never(d, dv, sigma),
                Some(g) => grown_sphere_contact(d, dv, sigma, g, t0),
            };
            return Ok(if t < f64::INFINITY {
                Found::Contact(t)
            } else {
                Found::Apart
            });
        }
        let (ka, kb) = (&self.kinds[ba.kind as usize], &self.kinds[bb.kind as usize]);
        if !Predictor::bounding_spheres_meet(&ka.shape, &kb.shape, d, dv, horizon - t0) {
            return Ok(Found::Apart);
        }
        let (spin_a, spin_b) = (&self.tops[a], &self.tops[b]);
        // The stored orientations, each turned on from its own time
        // inside the search (one rotation per step, none to bring it to
        // t0 first).
        self.predictor
            .search_into(
                (&ka.shape, spin_a),
                (&kb.shape, spin_b),
                (t0 - ba.time, t0 - bb.time),
                self.growth.map(|g| g.since(t0)),
                d,
                dv,
                resume,
                horizon - t0,
                budget,
                stopped,
            )
            .map_err(|why| EdmdError::Solver {
                i: a,
                j: b,
                time: self.time(),
                why,
            })
    }
}

/// The contact time (from `t0`) of two growing spheres `d` apart at `t0`
/// whose contact distance is `sigma` at full size.
#[inline]
fn grown_sphere_contact(d: &V3, dv: &V3, sigma: f64, growth: Growth, t0: f64) -> f64 {
    crate::geometry::pair::grown_sphere_contact_time(
        d.dot(dv),
        d.norm_squared(),
        dv.norm_squared(),
        sigma * growth.at(t0),
        sigma * growth.rate,
    )
}

/// Schedules the collision of `i` and `j` at `t`, keeping the solver state
/// at the predicted contact for it.
pub(super) fn schedule_collision(
    calendar: &mut Calendar,
    found: &mut std::collections::HashMap<(u32, u32), WarmStart>,
    t: f64,
    i: usize,
    j: usize,
    warm: Option<WarmStart>,
) {
    calendar.schedule(t, EventKind::Collision, i, j);
    if let Some(w) = warm {
        // Found with the body of lower index as A (see `predict_pair`).
        found.insert((i.min(j) as u32, i.max(j) as u32), w);
    }
}

/// Asks for the first cache line of each listed body (all a sphere search
/// reads of it) at once, before the search reads them one after another.
#[inline]
pub(super) fn prefetch_bodies(bodies: &[Body], list: &[u32]) {
    for &j in list {
        prefetch_body(bodies, j as usize);
    }
}

/// Asks for body `j`'s first cache line (see [`prefetch_bodies`]).
#[inline(always)]
pub(super) fn prefetch_body(bodies: &[Body], j: usize) {
    // No bounds check: a prefetch never faults, whatever the address.
    crate::edmd::prefetch::prefetch_address(bodies.as_ptr().wrapping_add(j).cast());
}

/// Slots of the cells around a sphere gathered at once: 27 rooms of 16
/// (more are searched one at a time).
pub(super) const AROUND: usize = 27 * 16;
