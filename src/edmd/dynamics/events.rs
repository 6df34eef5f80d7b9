//! The event loop (De Michele Sec. 2.7): the calendar yields the next
//! event, only the bodies involved are advanced, and the clock is
//! rebased before time loses precision.

use nalgebra::Vector3;

use crate::edmd::calendar::{Event, EventKind};
use crate::edmd::motion::position_after;

type V3 = Vector3<f64>;

use super::*;

impl Dynamics {
    /// Runs until the simulated time reaches `t_end` (bodies are then
    /// advanced to it).
    pub fn run_until(&mut self, t_end: f64) -> Result<(), EdmdError> {
        self.run_collisions_until(u64::MAX, t_end)
    }

    /// Runs `count` more collisions.
    pub fn run_collisions(&mut self, count: u64) -> Result<(), EdmdError> {
        let target = self.collisions + count;
        while self.collisions < target {
            if !self.process_next()? {
                break;
            }
        }
        Ok(())
    }

    /// Runs `count` more collisions, or until `t_end` if that comes first
    /// (bodies are then advanced to it).
    pub fn run_collisions_until(&mut self, count: u64, t_end: f64) -> Result<(), EdmdError> {
        let target = self.collisions.saturating_add(count);
        while self.collisions < target {
            // Relative to the origin, which a rebase moves.
            let end = t_end - self.origin;
            match self.calendar.pop_if(|e| e.time <= end) {
                Some(e) => self.process(e)?,
                None => {
                    self.advance_clock(end);
                    break;
                }
            }
        }
        Ok(())
    }

    /// Moves the clock to `now` (no event in between).
    pub(super) fn advance_clock(&mut self, now: f64) {
        if now > self.now {
            self.now = now;
        }
    }

    /// Processes the next event; false if the calendar is empty (nothing
    /// moves).
    pub(super) fn process_next(&mut self) -> Result<bool, EdmdError> {
        let Some(e) = self.calendar.pop() else {
            return Ok(false);
        };
        self.process(e)?;
        Ok(true)
    }

    /// Processes `e`, just taken from the calendar.
    fn process(&mut self, e: Event) -> Result<(), EdmdError> {
        if e.time > self.now {
            self.now = e.time;
            self.events_at_now = 0;
        } else {
            self.events_at_now += 1;
            // Every body may meet every neighbour at one instant in a
            // lattice; far more than that is a loop.
            if self.events_at_now > 100 * self.bodies.len() as u64 + 1000 {
                return Err(EdmdError::Stalled {
                    time: self.time(),
                    events: self.events_at_now,
                    i: e.i as usize,
                    j: e.j as usize,
                });
            }
        }
        match e.kind {
            EventKind::Collision if !self.calendar.partner_current(&e) => {
                // The partner changed: no collision; but if this was where
                // the first body's search stopped, it goes on from here.
                let i = e.i as usize;
                if e.time == self.bodies[i].horizon {
                    self.schedule_collisions(i, None, false)?;
                }
            }
            EventKind::Collision => self.collide(e.i as usize, e.j as usize)?,
            EventKind::CellCrossing { axis, up } => self.cross(e.i as usize, axis as usize, up)?,
            EventKind::Escape => self.escape(e.i as usize)?,
            EventKind::Wall { axis, up } => self.hit_wall(e.i as usize, axis as usize, up)?,
            EventKind::WallSearch => {
                let i = e.i as usize;
                self.calendar.invalidate(i);
                self.schedule_crossing(i);
                self.schedule_collisions(i, None, false)?;
            }
        }
        // At a collision (an instant both neighbour structures share; see
        // `closed_form`).
        let due = self.collisions - self.collisions_at_rebase > 32 * self.bodies.len() as u64
            && matches!(e.kind, EventKind::Collision);
        if due {
            self.rebase()?;
        }
        Ok(())
    }

    /// Advances body `i` to the current time.
    #[inline]
    pub(super) fn advance(&mut self, i: usize) {
        let now = self.now;
        let dt = now - self.bodies[i].time;
        if dt != 0.0 {
            // The stored pose moves on; its top is rebuilt by the caller
            // once the spin is settled.
            let turned =
                (self.rotating && self.bodies[i].angular_velocity != V3::zeros()).then(|| {
                    let top = self.top(i);
                    let q = top.orientation_after(dt);
                    (q, top.angular_velocity(&q))
                });
            let b = &mut self.bodies[i];
            b.position = position_after(&b.position, &b.velocity, dt);
            if let Some((q, w)) = turned {
                (b.orientation, b.angular_velocity) = (q, w);
            }
            b.time = now;
        }
    }

    /// Moves the time origin to now, so that event times stay small and
    /// keep their precision over long runs.
    pub(super) fn rebase(&mut self) -> Result<(), EdmdError> {
        for i in 0..self.bodies.len() {
            self.advance(i);
        }
        self.accumulate_kinetic();
        let shift = self.now;
        for b in &mut self.bodies {
            b.time = 0.0;
            b.horizon -= shift;
        }
        for t in &mut self.crossing_times {
            *t -= shift;
        }
        self.calendar.shift_times(shift);
        self.interval.start -= shift;
        self.interval.ke_since -= shift;
        self.origin += shift;
        self.now = 0.0;
        if let Some(g) = self.growth.as_mut() {
            *g = g.since(shift);
        }
        self.collisions_at_rebase = self.collisions;
        // Every prediction again from the new poses: an event predicted
        // before and shifted can differ in its last bit from the same event
        // predicted after (see `closed_form`).
        self.schedule_everything()?;
        Ok(())
    }
}
