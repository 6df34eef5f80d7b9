//! Collisions: the contact point and normal of a touching pair and the
//! elastic impulse there (De Michele Sec. 2.6).

use nalgebra::Vector3;

use crate::edmd::collision::{Kinetics, collide, collide_patch, collide_spheres};
use crate::edmd::motion::position_after;
use crate::edmd::prefetch::prefetch_lines;
use crate::geometry::Relative;

type V3 = Vector3<f64>;

use super::*;

impl Dynamics {
    pub(super) fn collide(&mut self, i: usize, j: usize) -> Result<(), EdmdError> {
        // The body of lower index first, whichever body's search found the
        // pair: the same bits for the same collision (see `closed_form`).
        let (i, j) = (i.min(j), i.max(j));
        // What the two bodies' new events touch is on its way from memory
        // while the impulse is found.
        for k in [i, j] {
            if let Some(spheres) = &self.neighbours {
                prefetch_lines(spheres.lists.room_of(k));
                prefetch_lines(&spheres.centres[k..=k]);
            }
            prefetch_lines(&self.images[k..=k]);
            prefetch_lines(&self.crossing_times[k..=k]);
            self.calendar.prefetch(k);
        }
        // A collision that fails leaves both bodies as they were, so that a
        // dump taken then replays it (see `DynamicsDump`). Two spheres are
        // checked before anything changes; bodies are kept aside.
        let spheres = self.contact_sum(i, j).is_some();
        let kept = (!spheres)
            .then(|| [i, j].map(|k| (self.bodies[k], self.cell_shifts[k], self.images[k])));
        let impulse = match self.impulse_at_contact(i, j) {
            Ok(impulse) => impulse,
            Err(e) => {
                for (k, (body, shift, image)) in [i, j].into_iter().zip(kept.into_iter().flatten())
                {
                    (self.bodies[k], self.cell_shifts[k], self.images[k]) = (body, shift, image);
                }
                return Err(e);
            }
        };
        if let Some(kept) = &kept {
            let unchanged = [i, j].iter().zip(kept).all(|(&k, (before, _, _))| {
                self.bodies[k].velocity == before.velocity
                    && self.bodies[k].angular_velocity == before.angular_velocity
            });
            self.count_futile(i, j, unchanged)?;
        }
        self.add_virial(&impulse.0, &impulse.1);
        self.interval.collisions += 1;
        self.collisions += 1;
        if let Some(trace) = self.trace.as_mut() {
            trace.push((self.origin + self.now, i.min(j) as u32, i.max(j) as u32));
        }
        self.calendar.invalidate(i);
        self.calendar.invalidate(j);
        // The second body's neighbours are on their way from memory while
        // the first's are searched.
        if let Some(spheres) = &self.neighbours {
            prefetch_bodies(&self.bodies, spheres.lists.of(j));
        }
        self.schedule_crossing(i);
        self.schedule_crossing(j);
        self.schedule_collisions(i, Some(j), false)?;
        self.schedule_collisions(j, Some(i), false)?;
        // The pair itself last, within both horizons: a pair that has just
        // touched stays within ε_d for a while, where the search is slow.
        // Found, it is `i`'s earliest collision, in place of the one its
        // search found: `i`'s horizon, so that if `j` changes first, `i`'s
        // search is renewed there (see `process_next`).
        // Two spheres that have just collided recede for ever on their
        // straight lines (|d + Δv t|² grows once d·Δv > 0): nothing to search.
        // In a box narrow enough, they may meet again in another image.
        if spheres && !self.narrow.contains(&true) {
            return Ok(());
        }
        let horizon = self.bodies[i].horizon.min(self.bodies[j].horizon);
        if let PairSearch::Contact(t, warm) =
            self.predict_pair(i, j, horizon, u32::MAX, None, &mut None)?
        {
            self.bodies[i].horizon = t;
            schedule_collision(&mut self.calendar, &mut self.found, t, i, j, warm);
        }
        Ok(())
    }

    /// Advances bodies `i` < `j` to now, where they touch, and applies the
    /// impulse; returns r_B − r_A and the impulse on B, for the virial.
    /// Changes nothing but the two bodies, and their velocities only if it
    /// succeeds.
    pub(super) fn impulse_at_contact(&mut self, i: usize, j: usize) -> Result<(V3, V3), EdmdError> {
        let (si, sj) = (self.species_of(i), self.species_of(j));
        let sphere_contact = self.contact_sum(i, j);
        // The separation now, from the positions `advance` will store (to
        // the bit), before either body is touched.
        let now = |k: usize| {
            let b = &self.bodies[k];
            position_after(&b.position, &b.velocity, self.now - b.time)
        };
        let d = self.box_.minimum_image(&(now(j) - now(i)));
        let scale = self.scale_now();
        if let Some(sigma) = sphere_contact.map(|s| s * scale) {
            // Two spheres touch now.
            let gap = d.norm() - sigma;
            if gap.abs() > 1e-9 * sigma {
                return Err(EdmdError::ContactMismatch {
                    i,
                    j,
                    time: self.time(),
                    distance: gap,
                });
            }
        }
        self.advance(i);
        self.advance(j);
        // New stored poses: wrapped into the box here, and only here;
        // with cells, in the image of the body's cell.
        for k in [i, j] {
            let p = self.bodies[k].position;
            let wrapped = match self.neighbours {
                Some(_) => self.box_.wrap(&p),
                None => {
                    let l = self.box_.lengths();
                    let c = self.cells.coords_of(self.cells.cell_of(k));
                    let centre = self.box_.shear(&V3::from_fn(|a, _| {
                        -0.5 * l[a] + (c[a] as f64 + 0.5) * self.cell_lengths[a]
                    }));
                    // The pose is now in its cell's image (only cells
                    // read the shift).
                    self.cell_shifts[k] = V3::zeros();
                    p + self.box_.image_shift(&(p - centre))
                }
            };
            self.images[k] += p - wrapped;
            self.bodies[k].position = wrapped;
        }
        let impulse = if sphere_contact.is_some() {
            let len = d.norm();
            let normal = d / len;
            let (mi, mj) = (self.kinds[si].inverse_mass, self.kinds[sj].inverse_mass);
            let (a, b) = pair_mut(&mut self.bodies, i, j);
            let gap = b.velocity - a.velocity;
            // The radii's sum grows at σ ṡ/s.
            let growth = self.growth.map_or(0.0, |g| g.rate / scale * len);
            let jn = collide_spheres(&mut a.velocity, &mut b.velocity, mi, mj, &normal, growth);
            let impulse = normal * jn;
            self.kinetic_impulse(&gap, &impulse, mi + mj);
            (d, impulse)
        } else {
            self.collide_bodies(i, j, &d)?
        };
        Ok(impulse)
    }

    /// The collision of two bodies with at least one non-sphere: contact
    /// point and normal from the distance kernel, impulse from
    /// [`collide`]. Returns r_B − r_A and the impulse on B, for the virial.
    pub(super) fn collide_bodies(
        &mut self,
        i: usize,
        j: usize,
        d: &V3,
    ) -> Result<(V3, V3), EdmdError> {
        let (bi, bj) = (self.bodies[i], self.bodies[j]);
        let (ki, kj) = (&self.kinds[bi.kind as usize], &self.kinds[bj.kind as usize]);
        // Growing bodies: the unscaled shapes at the separation over the
        // scale, as the prediction solved them; lengths scaled back.
        let scale = self.scale_now();
        let rel = Relative::new(&(d / scale), &bi.orientation, &bj.orientation);
        let warm = self.found.remove(&(i as u32, j as u32));
        let contact = scaled_contact(
            self.predictor
                .contact_from(&ki.shape, &kj.shape, &rel, warm.as_ref()),
            scale,
        );
        // What the growth adds to the approach of the contact points.
        let growth_along =
            |normal: &V3| self.growth.map_or(0.0, |g| g.rate / scale * normal.dot(d));
        if !contact.distance.is_finite() {
            return Err(EdmdError::Solver {
                i,
                j,
                time: self.time(),
                why: SearchError::Solver {
                    status: contact.status,
                    at: 0.0,
                },
            });
        }
        let size = ki.shape.min_half_extent().min(kj.shape.min_half_extent());
        if contact.distance.abs() > self.predictor.contact_tolerance() * size {
            return Err(EdmdError::ContactMismatch {
                i,
                j,
                time: self.time(),
                distance: contact.distance,
            });
        }
        let lab = |c: &crate::geometry::Contact| {
            let normal = bi.orientation * c.normal;
            let arm_a = bi.orientation * (0.5 * (c.point_a + c.point_b));
            let closing = normal.dot(
                &(bi.velocity + bi.angular_velocity.cross(&arm_a)
                    - bj.velocity
                    - bj.angular_velocity.cross(&(arm_a - d))),
            ) + growth_along(&normal);
            (normal, arm_a, closing)
        };
        let kinetics = |b: &Body, k: &Kind| Kinetics {
            velocity: b.velocity,
            angular_velocity: b.angular_velocity,
            inverse_mass: k.inverse_mass,
            inverse_inertia: k.inverse_inertia(&b.orientation),
        };
        // A face or an edge lying on a face: the impact acts on all the
        // corners of the shared region at once (see `collide_patch`).
        let patch = crate::geometry::pair::contact_patch(
            &ki.shape,
            &kj.shape,
            &rel,
            &contact.normal,
            self.predictor.contact_tolerance() * size / scale,
        );
        if patch.points().len() >= 2 {
            let normal = bi.orientation * contact.normal;
            let mut arms = [(V3::zeros(), V3::zeros()); crate::geometry::pair::MAX_PATCH];
            for (arm, p) in arms.iter_mut().zip(patch.points()) {
                let arm_a = bi.orientation * (p * scale);
                *arm = (arm_a, arm_a - d);
            }
            let mut ka = kinetics(&bi, ki);
            let mut kb = kinetics(&bj, kj);
            let jn = collide_patch(
                &mut ka,
                &mut kb,
                &arms[..patch.points().len()],
                &normal,
                growth_along(&normal),
            );
            // No corner of the patch approaches: the pair closes in at a
            // second contact a round-off away (a cube's edge leaving a
            // face while another edge comes down 1e-13 off it), found
            // below as for a single contact point.
            if jn != 0.0 {
                return Ok(self.apply_impulse(i, j, ka, kb, (*d, normal * jn)));
            }
        }
        let (mut normal, mut arm_a, closing) = lab(&contact);
        if closing <= 0.0 {
            // Touching, but not where the bodies close in: at a contact
            // within round-off of a second one (a box face about to meet a
            // vertex beside the one touching), the pair overlaps an instant
            // later at the other. Take the contact from there.
            let (spin_i, spin_j) = (
                ki.spin(&bi.orientation, &bi.angular_velocity),
                kj.spin(&bj.orientation, &bj.angular_velocity),
            );
            let rate = (bj.velocity - bi.velocity).norm()
                + spin_i.max_angular_speed() * ki.shape.moment_arm()
                + spin_j.max_angular_speed() * kj.shape.moment_arm();
            let tolerance = self.predictor.contact_tolerance() * size;
            let mut delta = tolerance / rate.max(f64::MIN_POSITIVE);
            for _ in 0..40 {
                // The bodies a moment later, grown as the search has them
                // (a second contact may close in by the growth alone).
                let scale_later = self.growth.map_or(1.0, |g| g.at(self.now + delta));
                let later = Relative::new(
                    &((d + (bj.velocity - bi.velocity) * delta) / scale_later),
                    &spin_i.orientation_after(delta),
                    &spin_j.orientation_after(delta),
                );
                let ahead = scaled_contact(
                    self.predictor.contact(&ki.shape, &kj.shape, &later),
                    scale_later,
                );
                // Overlapping beyond the tolerance: a pair already
                // overlapping by round-off (an edge across a face, one
                // end receding) stays so for a while before the
                // approaching end takes over.
                if ahead.distance < -tolerance {
                    let (n, a, c) = lab(&ahead);
                    if c > 0.0 {
                        // Both points at once: struck at the second
                        // alone, the first would close in again (two
                        // tetrahedra, an edge on a face to just past the
                        // patch's tolerance, struck at each end in turn
                        // for ever).
                        let arms = [(arm_a, arm_a - d), (a, a - d)];
                        let mut ka = kinetics(&bi, ki);
                        let mut kb = kinetics(&bj, kj);
                        let jn = collide_patch(&mut ka, &mut kb, &arms, &n, growth_along(&n));
                        if jn != 0.0 {
                            return Ok(self.apply_impulse(i, j, ka, kb, (*d, n * jn)));
                        }
                        (normal, arm_a) = (n, a);
                    }
                    break;
                }
                delta *= 2.0;
            }
        }
        let arm_b = arm_a - d;
        let mut ka = kinetics(&bi, ki);
        let mut kb = kinetics(&bj, kj);
        let jn = collide(
            &mut ka,
            &mut kb,
            &arm_a,
            &arm_b,
            &normal,
            growth_along(&normal),
        );
        Ok(self.apply_impulse(i, j, ka, kb, (*d, normal * jn)))
    }

    /// Counts collisions of one pair in a row that changed no velocity: a
    /// contact the collision rule cannot resolve comes back an instant
    /// later, again and again, the clock barely moving (so `Stalled` does
    /// not see it). Past [`FUTILE_COLLISIONS`] it is reported.
    pub(super) fn count_futile(
        &mut self,
        i: usize,
        j: usize,
        unchanged: bool,
    ) -> Result<(), EdmdError> {
        let (a, b, count) = &mut self.futile;
        if !unchanged {
            *count = 0;
            return Ok(());
        }
        if (*a, *b) == (i as u32, j as u32) {
            *count += 1;
        } else {
            (*a, *b, *count) = (i as u32, j as u32, 1);
        }
        let collisions = *count;
        if collisions > FUTILE_COLLISIONS {
            return Err(EdmdError::Futile {
                i,
                j,
                time: self.time(),
                collisions,
            });
        }
        Ok(())
    }

    /// Stores bodies `i` and `j`'s velocities after a collision (`ka`,
    /// `kb`); passes the virial terms through.
    pub(super) fn apply_impulse(
        &mut self,
        i: usize,
        j: usize,
        ka: Kinetics,
        kb: Kinetics,
        virial: (V3, V3),
    ) -> (V3, V3) {
        let gap = self.bodies[j].velocity - self.bodies[i].velocity;
        self.kinetic_impulse(&gap, &virial.1, ka.inverse_mass + kb.inverse_mass);
        for (idx, k) in [(i, ka), (j, kb)] {
            self.bodies[idx].velocity = k.velocity;
            self.bodies[idx].angular_velocity = k.angular_velocity;
            self.refresh_top(idx);
        }
        virial
    }
}

/// Collisions of one pair in a row that change no velocity before the
/// dynamics reports them (a real grazing pair may give a few).
pub(super) const FUTILE_COLLISIONS: u64 = 1000;

/// A contact of unscaled shapes at the separation over `scale`, in the
/// lengths of the bodies scaled by it (the solver state left unscaled).
fn scaled_contact(mut contact: crate::geometry::Contact, scale: f64) -> crate::geometry::Contact {
    if scale != 1.0 {
        contact.distance *= scale;
        contact.point_a *= scale;
        contact.point_b *= scale;
    }
    contact
}

/// Two distinct elements of a slice, mutably.
#[inline]
pub(super) fn pair_mut<T>(s: &mut [T], i: usize, j: usize) -> (&mut T, &mut T) {
    debug_assert_ne!(i, j);
    if i < j {
        let (lo, hi) = s.split_at_mut(j);
        (&mut lo[i], &mut hi[0])
    } else {
        let (lo, hi) = s.split_at_mut(i);
        (&mut hi[0], &mut lo[j])
    }
}
