//! Cell crossings, box escapes and hard walls: the events a single body
//! has with the space around it.

use nalgebra::{Matrix3, Vector3};

use crate::edmd::calendar::EventKind;
use crate::edmd::collision::{Kinetics, collide};
use crate::edmd::motion::position_after;
use crate::geometry::roots::{brent_minimize, narrow_sign_change};

type V3 = Vector3<f64>;

use super::*;

impl Dynamics {
    pub(super) fn cross(&mut self, i: usize, axis: usize, up: bool) -> Result<(), EdmdError> {
        // The stored pose stays (see `closed_form`): a periodic crossing
        // moves `cell_shifts`, not the pose.
        let dims = self.cells.dims();
        let mut c = self.cells.coords_of(self.cells.cell_of(i));
        // Across the box's face: the image one lattice vector back.
        if up {
            c[axis] += 1;
            if c[axis] == dims[axis] {
                c[axis] = 0;
                self.cell_shifts[i] -= self.box_.lattice_vector(axis);
            }
        } else if c[axis] == 0 {
            c[axis] = dims[axis] - 1;
            self.cell_shifts[i] += self.box_.lattice_vector(axis);
        } else {
            c[axis] -= 1;
        }
        let cell = self.cells.index_of(c);
        self.cells.move_to(i, cell);
        if self.closed_form {
            // The trajectory is unchanged and its events stand; only the
            // bodies in the layer of cells ahead are new neighbours.
            self.schedule_crossing(i);
            let mut layer = c;
            layer[axis] = if up {
                (c[axis] + 1) % dims[axis]
            } else {
                (c[axis] + dims[axis] - 1) % dims[axis]
            };
            return self.schedule_collisions_in_layer(i, layer, axis);
        }
        self.calendar.invalidate(i);
        self.schedule_crossing(i);
        self.schedule_collisions(i, None, false)
    }

    /// Body `i` has moved the shell from its neighbour sphere's centre: the
    /// sphere is rebuilt around it, and `i` searches its new list.
    pub(super) fn escape(&mut self, i: usize) -> Result<(), EdmdError> {
        // The stored pose stays (see `closed_form`). Boxes turn with their
        // bodies; a sphere region needs its centre alone.
        let boxes =
            (self.neighbours.as_ref()).is_some_and(|s| matches!(s.regions, Regions::Boxes { .. }));
        let (centre, orientation) = if boxes {
            let (centre, orientation) = self.pose_at(i, self.now);
            (centre, Some(orientation))
        } else {
            let b = &self.bodies[i];
            (
                position_after(&b.position, &b.velocity, self.now - b.time),
                None,
            )
        };
        let wrapped = self.box_.wrap(&centre);
        self.cells.update(i, &wrapped);
        // Only bodies with neighbour lists schedule escapes; without lists
        // the refresh is of the cells alone.
        if let Some(spheres) = self.neighbours.as_mut() {
            spheres.centres[i] = wrapped;
            if let (Regions::Boxes { axes, .. }, Some(q)) = (&mut spheres.regions, orientation) {
                axes[i] = q.to_rotation_matrix().into_inner();
            }
            link_overlapping(i, false, &self.box_, &self.cells, &self.bodies, spheres);
        }
        // A sphere's trajectory and its events stand (its search stopped
        // at this escape, and runs again over the new list); a body's
        // events are dropped.
        if !self.closed_form {
            self.calendar.invalidate(i);
        }
        self.schedule_crossing(i);
        self.schedule_collisions(i, None, false)
    }

    /// Schedules body `i`'s next cell crossing, or with neighbour lists its
    /// escape from its neighbour sphere (`i` at its own time), or its wall
    /// contact if that comes first.
    pub(super) fn schedule_crossing(&mut self, i: usize) {
        let b = &self.bodies[i];
        if let Some(spheres) = &self.neighbours {
            if let Regions::Boxes { half, axes } = &spheres.regions {
                let t = self.box_escape_time(i, spheres, half, axes);
                self.schedule_neighbourhood_event(i, t, EventKind::Escape);
                return;
            }
            // Against a sphere shrunk by a relative 1e-9: rounding never
            // takes a body out of its sphere unseen.
            let now = position_after(&b.position, &b.velocity, self.now - b.time);
            let dt = escape_time(
                &self.box_.minimum_image(&(now - spheres.centres[i])),
                &b.velocity,
                spheres.shell * (1.0 - 1e-9),
            );
            self.schedule_neighbourhood_event(i, self.now + dt, EventKind::Escape);
            return;
        }
        let c = self.cells.coords_of(self.cells.cell_of(i));
        let half = self.box_.lengths() * 0.5;
        // Cells are faces of constant unsheared coordinate: the stored
        // position in the image of its cell (they differ when the pose is
        // kept through a periodic crossing) and the velocity, unsheared.
        let x = self.box_.unshear(&(b.position + self.cell_shifts[i]));
        let velocity = self.box_.unshear(&b.velocity);
        // Without a branch on the signs of the velocity or on which face
        // comes first (coin tosses to the branch predictor): the face by
        // arithmetic, the earliest by selection.
        let mut best = (f64::INFINITY, 0u8, false);
        for k in 0..3 {
            let v = velocity[k];
            if v == 0.0 {
                continue;
            }
            let up = v > 0.0;
            let lower = -half[k] + c[k] as f64 * self.cell_lengths[k];
            // 1 upwards, 0 downwards, from the sign bit (a selection of
            // 1 or 0 the compiler would turn back into a jump).
            let upwards = 0.5 + 0.5 * 1.0f64.copysign(v);
            let face = lower + self.cell_lengths[k] * upwards;
            let t = ((face - x[k]) / v).max(0.0);
            let first = t < best.0;
            best.0 = if first { t } else { best.0 };
            best.1 = std::hint::select_unpredictable(first, k as u8, best.1);
            best.2 = std::hint::select_unpredictable(first, up, best.2);
        }
        let time = b.time + best.0;
        self.schedule_neighbourhood_event(
            i,
            time,
            EventKind::CellCrossing {
                axis: best.1,
                up: best.2,
            },
        );
    }

    /// Schedules `kind` (a crossing or an escape) for body `i` at `time`,
    /// or its wall contact if that comes first.
    pub(super) fn schedule_neighbourhood_event(&mut self, i: usize, time: f64, kind: EventKind) {
        if self.box_.has_walls() {
            match self.wall_contact(i, time) {
                WallContact::At { time: t, axis, up } => {
                    self.crossing_times[i] = t;
                    self.calendar.schedule(
                        t,
                        EventKind::Wall {
                            axis: axis as u8,
                            up,
                        },
                        i,
                        i,
                    );
                    return;
                }
                WallContact::SearchedTo(t) if t < time => {
                    self.crossing_times[i] = t;
                    self.calendar.schedule(t, EventKind::WallSearch, i, i);
                    return;
                }
                _ => {}
            }
        }
        self.crossing_times[i] = time;
        if time.is_finite() {
            self.calendar.schedule(time, kind, i, i);
        }
    }

    /// The gap between body `i` at time `t` and the faces of its neighbour
    /// box: min over the box axes uₖ of Hₖ − |(r − c)·uₖ| − hₖ, with H the
    /// box's half-extents, c its centre and hₖ the body's extent along uₖ.
    pub(super) fn box_gap_at(
        &self,
        (i, top): (usize, &FreeTop),
        t: f64,
        spheres: &NeighbourSpheres,
        half: &[V3],
        axes: &[Matrix3<f64>],
    ) -> f64 {
        let b = &self.bodies[i];
        let kind = &self.kinds[b.kind as usize];
        let (r, q) = self.pose_by(i, top, t);
        let axes = &axes[i];
        let h = kind
            .shape
            .lab_half_extents(&axes.tr_mul(&q.to_rotation_matrix().into_inner()));
        let offset = axes.tr_mul(&self.box_.minimum_image(&(r - spheres.centres[i])));
        let half = &half[b.species as usize];
        (0..3)
            .map(|k| half[k] - offset[k].abs() - h[k])
            .fold(f64::INFINITY, f64::min)
    }

    /// When body `i`'s neighbour box stops being trusted: the gap to its
    /// faces cannot close faster than |v·uₖ| + |ω|max × moment arm, so steps
    /// of gap / rate never pass a face (conservative advancement); the
    /// search stops within [`BOX_ESCAPE_MARGIN`] of the shell, or after 64
    /// steps (an early rebuild costs a search, never a collision).
    pub(super) fn box_escape_time(
        &self,
        i: usize,
        spheres: &NeighbourSpheres,
        half: &[V3],
        axes: &[Matrix3<f64>],
    ) -> f64 {
        let b = &self.bodies[i];
        let kind = &self.kinds[b.kind as usize];
        let along = axes[i].tr_mul(&b.velocity).abs().max();
        let top = &self.tops[i];
        let rate = along + top.max_angular_speed() * kind.shape.moment_arm();
        if rate == 0.0 {
            return f64::INFINITY;
        }
        let margin = BOX_ESCAPE_MARGIN * spheres.shell;
        let mut t = self.now;
        for _ in 0..64 {
            let gap = self.box_gap_at((i, top), t, spheres, half, axes);
            if gap <= margin {
                break;
            }
            t += gap / rate;
        }
        t
    }

    /// Body `i`'s size relative to its kind's shape: 1, or with sizes its
    /// own over its species' largest.
    #[inline]
    pub(super) fn relative_size(&self, i: usize) -> f64 {
        match self.body_radii.get(i) {
            Some(r) => {
                r / self.kinds[self.bodies[i].kind as usize]
                    .shape
                    .bounding_radius()
            }
            None => 1.0,
        }
    }

    /// The gap between body `i` at absolute time `t` (relative to the
    /// origin) and the nearest wall: min over walled axes and sides of
    /// L/2 − rₖ − hₖ(+eₖ) and L/2 + rₖ − hₖ(−eₖ) (h the support values of
    /// the turned body), with the axis and side.
    pub(super) fn wall_gap_at(&self, (i, top): (usize, &FreeTop), t: f64) -> (f64, usize, bool) {
        let b = &self.bodies[i];
        let kind = &self.kinds[b.kind as usize];
        let (r, q) = self.pose_by(i, top, t);
        let (up, down) = kind.shape.lab_extents(&q.to_rotation_matrix().into_inner());
        let scale = self.relative_size(i) * self.growth.map_or(1.0, |g| g.at(t));
        let half = self.box_.lengths() * 0.5;
        let walls = self.box_.walls();
        (0..3)
            .filter(|&k| walls[k])
            .flat_map(|k| {
                [
                    (half[k] - r[k] - up[k] * scale, k, true),
                    (half[k] + r[k] - down[k] * scale, k, false),
                ]
            })
            .fold(
                (f64::INFINITY, 0, true),
                |m, x| if x.0 < m.0 { x } else { m },
            )
    }

    /// Body `i`'s next wall contact before `t_end`: in closed form for a
    /// body that does not turn; otherwise by bracketing the gap with steps
    /// it cannot close faster than (|v| + |ω|max × moment arm), a search for
    /// grazing minima below ε_d, and the safeguarded root finder. Gives up
    /// after a fixed number of steps (to be renewed from there).
    pub(super) fn wall_contact(&self, i: usize, t_end: f64) -> WallContact {
        // Growing bodies are bounded by their species' shapes only up to
        // the end of the growth.
        let t_end = match self.growth {
            None => t_end,
            Some(g) => t_end.min(g.ends()),
        };
        let b = &self.bodies[i];
        let kind = &self.kinds[b.kind as usize];
        let half = self.box_.lengths() * 0.5;
        let walls = self.box_.walls();
        if !kind.rotates || b.angular_velocity == V3::zeros() {
            let (up, down) = kind
                .shape
                .lab_extents(&b.orientation.to_rotation_matrix().into_inner());
            let (up, down) = (up * self.relative_size(i), down * self.relative_size(i));
            let mut best = WallContact::None;
            let mut best_t = t_end;
            for k in (0..3).filter(|&k| walls[k]) {
                let v = b.velocity[k];
                // The gap to the wall ahead closes at |v|; growing, the
                // extents h grow at ṡ h and both walls may come.
                let sides: [(bool, f64, f64); 2] = match self.growth {
                    None if v > 0.0 => [(true, up[k], v), (false, 0.0, 0.0)],
                    None => [(false, down[k], -v), (true, 0.0, 0.0)],
                    Some(g) => [
                        (true, up[k] * g.at(b.time), v + up[k] * g.rate),
                        (false, down[k] * g.at(b.time), -v + down[k] * g.rate),
                    ],
                };
                for (up, extent, closing) in sides {
                    if closing <= 0.0 {
                        continue;
                    }
                    let gap = half[k] - extent - if up { b.position[k] } else { -b.position[k] };
                    let t = b.time + (gap / closing).max(0.0);
                    if t < best_t {
                        best_t = t;
                        best = WallContact::At {
                            time: t,
                            axis: k,
                            up,
                        };
                    }
                }
            }
            return best;
        }
        let opts = self.predictor.options();
        let scale = kind.shape.min_half_extent();
        let tol = opts.contact_tolerance * scale;
        let eps = opts.grazing_threshold * scale;
        let speed = (0..3)
            .filter(|&k| walls[k])
            .map(|k| b.velocity[k].abs())
            .fold(0.0, f64::max);
        let top = &self.tops[i];
        let rate = speed
            + top.max_angular_speed() * kind.shape.moment_arm()
            + self
                .growth
                .map_or(0.0, |g| g.rate * kind.shape.bounding_radius());
        let gap = |t: f64| self.wall_gap_at((i, top), t).0;
        let contact = |lo: f64| {
            let (_, axis, up) = self.wall_gap_at((i, top), lo);
            WallContact::At { time: lo, axis, up }
        };
        // From now: the pose is kept through the events that renew this
        // search (see `closed_form`), and the body is clear of the walls
        // up to now (a search that stopped renews itself from there).
        let start = self.now.max(b.time);
        let (mut t, mut g) = (start, gap(start));
        for _ in 0..64 {
            let t1 = (t + g.max(eps) / rate).min(t_end);
            let g1 = gap(t1);
            if g1 < 0.0 {
                if g <= 0.0 {
                    return contact(t);
                }
                let (lo, ..) = narrow_sign_change(gap, (t, g), (t1, g1), tol, 200);
                return contact(lo);
            }
            if g.min(g1) < eps {
                // A grazing approach: is there a dip below zero in between?
                let (x, gx, _) = brent_minimize(gap, t, t1, 1e-12 * (t1 - t).max(1e-300), 60);
                if gx < 0.0 && g > 0.0 {
                    let (lo, ..) = narrow_sign_change(gap, (t, g), (x, gx), tol, 200);
                    return contact(lo);
                }
            }
            if t1 >= t_end {
                return WallContact::None;
            }
            (t, g) = (t1, g1);
        }
        WallContact::SearchedTo(t)
    }

    /// Body `i` meets the wall normal to `axis` (at +L/2 if `up`): an
    /// elastic impulse against an immovable wall at the body's extreme
    /// point (collision::collide with an infinite-mass partner).
    pub(super) fn hit_wall(&mut self, i: usize, axis: usize, up: bool) -> Result<(), EdmdError> {
        self.advance(i);
        let b = self.bodies[i];
        let kind = &self.kinds[b.kind as usize];
        let normal = V3::ith(axis, if up { 1.0 } else { -1.0 });
        let scale = self.scale_now();
        let arm = b.orientation
            * kind
                .shape
                .support(&b.orientation.inverse_transform_vector(&normal))
            * (scale * self.relative_size(i));
        let gap = 0.5 * self.box_.lengths()[axis] - (b.position[axis] + arm[axis]) * normal[axis];
        let size = kind.shape.min_half_extent();
        if gap.abs() > 1e3 * self.predictor.contact_tolerance() * size {
            return Err(EdmdError::ContactMismatch {
                i,
                j: i,
                time: self.time(),
                distance: gap,
            });
        }
        let mut body = Kinetics {
            velocity: b.velocity,
            angular_velocity: b.angular_velocity,
            inverse_mass: kind.inverse_mass,
            inverse_inertia: kind.inverse_inertia(&b.orientation),
        };
        let mut wall = Kinetics {
            velocity: V3::zeros(),
            angular_velocity: V3::zeros(),
            inverse_mass: 0.0,
            inverse_inertia: Matrix3::zeros(),
        };
        // The growth moves the touching point outward at (ṡ/s) n·arm.
        let growth = self
            .growth
            .map_or(0.0, |g| g.rate / scale * normal.dot(&arm));
        let j = collide(&mut body, &mut wall, &arm, &V3::zeros(), &normal, growth);
        self.interval.wall_impulse[axis] += j;
        // The impulse on the body is −j n̂ (the wall is B).
        let before = self.bodies[i].velocity;
        self.kinetic_impulse(&before, &(-normal * j), kind.inverse_mass);
        self.bodies[i].velocity = body.velocity;
        self.bodies[i].angular_velocity = body.angular_velocity;
        self.refresh_top(i);
        self.calendar.invalidate(i);
        self.schedule_crossing(i);
        self.schedule_collisions(i, None, false)
    }
}

/// When a centre `d` from its neighbour sphere's centre (inside: |d| <
/// `shell`), moving at `v`, is `shell` from it.
pub(super) fn escape_time(d: &V3, v: &V3, shell: f64) -> f64 {
    let a = v.norm_squared();
    let c = d.norm_squared() - shell * shell;
    if a == 0.0 {
        return f64::INFINITY;
    }
    if c >= 0.0 {
        return 0.0;
    }
    let b = d.dot(v);
    let root = (b * b - a * c).sqrt();
    positive_root(a, b, c, root)
}

/// The positive root of a t² + 2b t + c (a > 0 > c) from `root` =
/// √(b² − ac), in the form without cancellation for the sign of b: both
/// forms divided at once and one selected by a mask on x86-64 (the sign
/// of b is a coin toss to the branch predictor).
#[inline(always)]
fn positive_root(a: f64, b: f64, c: f64, root: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_and_pd, _mm_andnot_pd, _mm_cmpgt_sd, _mm_cvtsd_f64, _mm_div_pd, _mm_or_pd,
            _mm_set_pd, _mm_set_sd, _mm_setzero_pd, _mm_unpackhi_pd,
        };
        // SAFETY: SSE2 is part of the x86_64 baseline, and these
        // intrinsics touch no memory.
        unsafe {
            // −c / (b + √·) for b > 0, else (√· − b) / a.
            let both = _mm_div_pd(_mm_set_pd(root - b, -c), _mm_set_pd(a, b + root));
            let positive = _mm_cmpgt_sd(_mm_set_sd(b), _mm_setzero_pd());
            let otherwise = _mm_unpackhi_pd(both, both);
            _mm_cvtsd_f64(_mm_or_pd(
                _mm_and_pd(positive, both),
                _mm_andnot_pd(positive, otherwise),
            ))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    if b > 0.0 {
        -c / (b + root)
    } else {
        (root - b) / a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The positive root is each form as chosen by the sign of b, to the
    /// bit, zeros of both signs included, and it solves the quadratic.
    #[test]
    fn positive_root_is_the_form_for_the_sign() {
        let mut u = crate::test_support::uniform(12);
        let mut signs = [0; 2];
        for k in 0..100_000 {
            let a = 0.01 + u();
            let b = match k % 5 {
                0 => 0.0,
                1 => -0.0,
                _ => 2.0 * (u() - 0.5),
            };
            let c = -0.01 - u();
            let root = (b * b - a * c).sqrt();
            let expected = if b > 0.0 {
                -c / (b + root)
            } else {
                (root - b) / a
            };
            let t = positive_root(a, b, c, root);
            assert_eq!(t.to_bits(), expected.to_bits(), "{a} {b} {c}");
            assert!(
                (a * t * t + 2.0 * b * t + c).abs() < 1e-9 * (1.0 + a * t * t),
                "{a} {b} {c}"
            );
            signs[usize::from(b > 0.0)] += 1;
        }
        assert!(signs.iter().all(|&n| n > 30_000), "{signs:?}");
    }
}
