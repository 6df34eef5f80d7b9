//! Collision prediction for pairs that are not two spheres (De Michele
//! Sec. 2.4.2): the bounding spheres give a first interval; inside it the
//! distance is followed in steps that cannot jump over a contact, because
//! the distance changes no faster than ḋ_max (eq. 32), with steps d/ḋ_max
//! and ε_d/ḋ_max close to contact (eq. 39); a pair that stays within ε_d
//! is searched for a grazing contact by a parabola through three distances
//! and, if that is inconclusive, by Brent's minimisation. A sign change
//! found is narrowed by a safeguarded root finder on the exact signed
//! distance of the geometry layer (Newton for smooth pairs, OCSI, SAT,
//! GJK/EPA otherwise), so every pair type, cuboids included, is exact.
//!
//! The contact time returned is the last time found at which the bodies are
//! still apart (distance in [0, tol]): the dynamics never steps into an
//! overlap.
//!
//! One search is a `ContactSearch`: named steps over the state they
//! share (the bodies' turned orientations at the last τ asked, the
//! distance solutions at the last two τ with their warm starts, the hint
//! of the normal, and the first failure seen):
//!
//! - `interval`: the bounding spheres' interval;
//! - `start`: the first step's distance, or that the pair is apart or
//!   touching already;
//! - `advance`: steps that cannot jump over a contact (eq. 39), each
//!   checked for a sign change (`stepped_into_overlap`) and, close to
//!   contact, for a grazing one (`graze`);
//! - `narrow`: a sign change narrowed to the contact by Newton's method in
//!   τ and a safeguarded regula falsi.

use nalgebra::{UnitQuaternion, Vector3};

use super::bounds::{TurnBound, first_zero, time_to_zero};
use super::motion::FreeTop;
use super::predict::{Predictor, is_fallback};
use crate::geometry::pair::{distance_lower_bound_near, support_points_start};
use crate::geometry::roots::{brent_minimize, narrow_sign_change};
use crate::geometry::{Contact, Relative, Shape, Status, WarmStart, distance};

type V3 = Vector3<f64>;

pub use super::outcome::{Found, Growth, Progress, Rotor, Search, SearchError};

impl Predictor {
    /// Whether the bounding spheres of `a` and `b`, at separation `d` (B − A)
    /// closing at `dv`, meet before `horizon`: where they do not, a search
    /// ends at once, and the caller need not build the bodies' rotations.
    pub fn bounding_spheres_meet(a: &Shape, b: &Shape, d: &V3, dv: &V3, horizon: f64) -> bool {
        ContactSearch::interval(a, b, d, dv, horizon).is_some()
    }

    /// [`Predictor::search`] that leaves the progress of a search out of
    /// budget in `stopped` and returns only how it ended: a search's
    /// progress is a few hundred bytes, which the dynamics' many searches
    /// that end at once should not copy through every return. The bodies'
    /// orientations are given `since` (A, B) before the search's origin
    /// (each turns on from there); `growth`, if any, scales both bodies.
    #[allow(clippy::too_many_arguments)]
    pub fn search_into(
        &self,
        a: Rotor,
        b: Rotor,
        since: (f64, f64),
        growth: Option<Growth>,
        d: &V3,
        dv: &V3,
        resume: Option<&Progress>,
        horizon: f64,
        budget: u32,
        stopped: &mut Option<Progress>,
    ) -> Result<Found, SearchError> {
        if horizon <= resume.map_or(0.0, |p| p.t) {
            return Ok(Found::Apart);
        }
        let Some((t1, t2, t_exit)) = ContactSearch::interval(a.0, b.0, d, dv, horizon) else {
            return Ok(Found::Apart);
        };
        let mut search = ContactSearch::new(self, a, b, since, d, dv);
        if let Some(g) = growth {
            search.grow(g);
        }
        if search.rate_bound == 0.0 {
            // Nothing moves.
            return Ok(Found::Apart);
        }
        match search.start(resume, t1, t2)? {
            Start::Ended(found) => Ok(found),
            Start::At(t, d_t, normal_t) => {
                search.advance((t, d_t, normal_t), t2, t_exit, budget, stopped)
            }
        }
    }
}

/// A search in progress: the pair, its motion, the step bounds fixed over
/// the search, and what the distance solutions so far leave for the next.
struct ContactSearch<'a> {
    predictor: &'a Predictor,
    shape_a: &'a Shape,
    shape_b: &'a Shape,
    w_a: &'a FreeTop,
    w_b: &'a FreeTop,
    /// How long before the search's origin the orientations were given.
    since: (f64, f64),
    /// The bodies' growth, if they grow.
    growth: Option<Growth>,
    d: &'a V3,
    dv: &'a V3,
    turn_a: TurnBound,
    turn_b: TurnBound,
    /// ḋ_max of eq. (32).
    rate_bound: f64,
    /// ε_d of eq. (39).
    eps: f64,
    /// The distance below which the bodies touch.
    tol: f64,
    /// Below this the step uses the distance, above it the cheap bound.
    exact_below: f64,
    /// Both orientations at τ, kept for the last τ asked (the pose, the
    /// bounds and the closing speed at one τ share them).
    turned: (f64, UnitQuaternion<f64>, UnitQuaternion<f64>),
    warm: Option<WarmStart>,
    failure: Option<SearchError>,
    last: Option<(f64, Contact)>,
    /// The last normal seen (A's frame): where the next bound's ascent
    /// and a cold distance start (pairs with a superellipsoid).
    hint: Option<V3>,
    /// The solution before `last`: a grazing check asks again for the
    /// distance at the step it starts from, solved by the check before.
    earlier: Option<(f64, Contact)>,
}

/// Where the stepping starts, or how the search ended before it.
enum Start {
    /// Step on from τ with this distance (or bound) and normal.
    At(f64, f64, V3),
    /// Ended already.
    Ended(Found),
}

impl<'a> ContactSearch<'a> {
    /// The bounding spheres' interval [t1, t2] within the horizon, and
    /// where they part (`t_exit`); None where they never meet by then.
    #[inline]
    fn interval(
        shape_a: &Shape,
        shape_b: &Shape,
        d: &V3,
        dv: &V3,
        horizon: f64,
    ) -> Option<(f64, f64, f64)> {
        let (la, lb) = (shape_a.bounding_radius(), shape_b.bounding_radius());
        let reach = la + lb;
        let b = d.dot(dv);
        let c = d.norm_squared() - reach * reach;
        let v2 = dv.norm_squared();
        let (t1, t2) = if c > 0.0 {
            let disc = b * b - v2 * c;
            if b >= 0.0 || disc < 0.0 {
                return None;
            }
            let root = disc.sqrt();
            (c / (-b + root), (-b + root) / v2)
        } else if v2 > 0.0 {
            (0.0, (-b + (b * b - v2 * c).sqrt()) / v2)
        } else {
            (0.0, f64::INFINITY)
        };
        // Steps are cut where the bounding spheres part, never at the
        // horizon, which only says where to stop: the steps, and so the
        // contact found, do not depend on the horizon (a search is
        // canonical, see `Dynamics::predict_pair`).
        let t_exit = t2;
        let t2 = t2.min(horizon);
        (t1 <= t2).then_some((t1, t2, t_exit))
    }

    /// The search of a pair (see [`Predictor::search_into`]) whose
    /// bounding spheres meet ([`ContactSearch::interval`]).
    #[inline]
    fn new(
        predictor: &'a Predictor,
        (shape_a, w_a): Rotor<'a>,
        (shape_b, w_b): Rotor<'a>,
        since: (f64, f64),
        d: &'a V3,
        dv: &'a V3,
    ) -> Self {
        let (turn_a, turn_b) = (TurnBound::new(w_a), TurnBound::new(w_b));
        // Eq. (32), with the moment arm in place of the bounding radius: the
        // distance changes at the normal velocity of the contact points, and
        // a rotation moves a surface point along its normal by ω·(x × n).
        let rate_bound =
            dv.norm() + turn_a.speed * shape_a.moment_arm() + turn_b.speed * shape_b.moment_arm();
        let options = predictor.options();
        let scale = shape_a.min_half_extent().min(shape_b.min_half_extent());
        Self {
            predictor,
            shape_a,
            shape_b,
            w_a,
            w_b,
            since,
            growth: None,
            d,
            dv,
            turn_a,
            turn_b,
            rate_bound,
            eps: options.grazing_threshold * scale,
            tol: options.contact_tolerance * scale,
            // Far from contact the cheap lower bound is enough to step
            // with (a step d/ḋ_max is safe for any d below the distance).
            exact_below: options.exact_below * scale,
            turned: (f64::NAN, w_a.start(), w_b.start()),
            warm: None,
            failure: None,
            last: None,
            hint: None,
            earlier: None,
        }
    }

    /// The bodies grow: the distance changes faster by the rate times the
    /// bounding radii (no surface point is farther from its centre).
    fn grow(&mut self, growth: Growth) {
        self.rate_bound +=
            growth.rate * (self.shape_a.bounding_radius() + self.shape_b.bounding_radius());
        self.growth = Some(growth);
    }

    /// The bodies' scale at τ = t (1 if they do not grow).
    #[inline]
    fn scale(&self, t: f64) -> f64 {
        self.growth.map_or(1.0, |g| g.at(t))
    }

    /// Both orientations at τ = t.
    #[inline]
    fn orientations(&mut self, t: f64) -> (UnitQuaternion<f64>, UnitQuaternion<f64>) {
        let (at, qa, qb) = self.turned;
        if at == t {
            return (qa, qb);
        }
        let (qa, qb) = (
            self.w_a.orientation_after(self.since.0 + t),
            self.w_b.orientation_after(self.since.1 + t),
        );
        self.turned = (t, qa, qb);
        (qa, qb)
    }

    /// B's placement in A's frame at τ = t; for growing bodies, the
    /// placement of the unscaled shapes whose distance, times the scale,
    /// is the distance (the separation divided by the scale).
    #[inline]
    fn pose(&mut self, t: f64) -> Relative {
        let (qa_t, qb_t) = self.orientations(t);
        let separation = self.d + self.dv * t;
        match self.growth {
            None => Relative::new(&separation, &qa_t, &qb_t),
            Some(_) => Relative::new(&(separation / self.scale(t)), &qa_t, &qb_t),
        }
    }

    /// The signed distance at τ = t (NaN where the solver failed, the
    /// failure kept), reusing the last two solutions where τ is theirs.
    fn distance_at(&mut self, t: f64) -> f64 {
        if let Some((at, c)) = self.last
            && at == t
        {
            if c.warm_start.is_some() {
                self.warm = c.warm_start;
            }
            return c.distance;
        }
        if let Some((at, c)) = self.earlier
            && at == t
        {
            if c.warm_start.is_some() {
                self.warm = c.warm_start;
            }
            self.earlier = self.last;
            self.last = Some((at, c));
            return c.distance;
        }
        let rel = self.pose(t);
        let (shape_a, shape_b) = (self.shape_a, self.shape_b);
        let start = self.warm.or_else(|| {
            self.hint
                .and_then(|n| support_points_start(shape_a, shape_b, &rel, &n))
        });
        let mut contact = distance(
            shape_a,
            shape_b,
            &rel,
            &self.predictor.options().distance,
            start.as_ref(),
        );
        if self.growth.is_some() {
            // Lengths of the grown bodies; the solver state stays the
            // unscaled problem's.
            let scale = self.scale(t);
            contact.distance *= scale;
            contact.point_a *= scale;
            contact.point_b *= scale;
        }
        if contact.warm_start.is_some() {
            self.warm = contact.warm_start;
        }
        self.predictor.count(|work| {
            work.distances += 1;
            work.iterations += match contact.status {
                Status::Converged { iterations }
                | Status::IterationCap { iterations }
                | Status::Failed { iterations, .. } => u64::from(iterations),
                Status::DeepOverlap => 0,
            };
            work.iteration_caps += u64::from(matches!(contact.status, Status::IterationCap { .. }));
            work.fallbacks += u64::from(is_fallback(shape_a, shape_b, contact.method));
        });
        self.earlier = self.last;
        self.last = Some((t, contact));
        if !contact.distance.is_finite() {
            self.failure = Some(SearchError::Solver {
                status: contact.status,
                at: t,
            });
            return f64::NAN;
        }
        contact.distance
    }

    /// The failure behind a NaN distance.
    #[inline]
    fn failed(&mut self, v: f64) -> Result<(), SearchError> {
        if v.is_nan() {
            Err(self.failure.take().unwrap_or(SearchError::NotANumber))
        } else {
            Ok(())
        }
    }

    /// With the distance (or its bound), a direction along which the
    /// bodies are well apart: the contact normal, or the bound's.
    fn step_distance(&mut self, t: f64) -> (f64, V3) {
        let rel = self.pose(t);
        let (bound, normal) =
            distance_lower_bound_near(self.shape_a, self.shape_b, &rel, self.hint.as_ref());
        let bound = bound * self.scale(t);
        // (Also where a cold distance below starts.)
        self.hint = Some(normal);
        if bound > self.exact_below {
            (bound, normal)
        } else {
            let exact = self.distance_at(t);
            let normal = self.last.map_or(normal, |(_, c)| c.normal);
            self.hint = Some(normal);
            (exact, normal)
        }
    }

    /// How long the bodies surely stay apart from τ = t: along a fixed
    /// lab direction n the separation φ(τ) = n·r − h_A(n) − h_B(−n) of
    /// the support planes is a lower bound on the distance, n·r changes
    /// at n·Δv exactly, and each support value grows as
    /// Shape::support_growth bounds it; φ(0) is the distance when n is
    /// the contact normal, and then φ′(0) = ḋ (so a receding pair is
    /// cleared at once, and an approaching one is followed to its
    /// contact in steps that shrink quadratically, not geometrically).
    ///
    /// Returns that time and the level the separation stays above until
    /// then.
    fn apart_for(&mut self, t: f64, normal: &V3) -> (f64, f64) {
        let (qa_t, qb_t) = self.orientations(t);
        let n = qa_t * normal;
        // n in A's frame is `normal`; in B's, −n turned back.
        let u_b = -qb_t.inverse_transform_vector(&n);
        let ga = self
            .turn_a
            .support_growth(self.shape_a, self.w_a, &qa_t, normal);
        let gb = self
            .turn_b
            .support_growth(self.shape_b, self.w_b, &qb_t, &u_b);
        let (ga, gb) = match self.growth {
            None => (ga, gb),
            Some(g) => {
                let scale = self.scale(t);
                (
                    ga.grown(scale, g.rate, self.shape_a.bounding_radius()),
                    gb.grown(scale, g.rate, self.shape_b.bounding_radius()),
                )
            }
        };
        let phi = n.dot(&(self.d + self.dv * t)) - ga.value - gb.value;
        // (NaN included: no time is sure then.)
        if phi.is_nan() || phi <= 0.0 {
            return (0.0, 0.0);
        }
        // Until the bound falls to a level short of zero (half of φ, at
        // most ε_d/2): a step never lands on a contact the bound sees
        // exactly (a face meeting a face along n), where the distance
        // may round to zero.
        let level = (0.5 * phi).min(0.5 * self.eps);
        let phi = phi - level;
        let approach = n.dot(self.dv);
        let mut kinks = [(0.0, 0.0, 0.0); 6];
        kinks[..3].copy_from_slice(&ga.kinks);
        kinks[3..].copy_from_slice(&gb.kinks);
        let quadratic = first_zero(
            phi,
            approach - ga.slope - gb.slope,
            &kinks,
            ga.curvature + gb.curvature,
        );
        let linear = time_to_zero(phi, approach - ga.lipschitz - gb.lipschitz, 0.0);
        (quadratic.max(linear), level)
    }

    /// The speed at which the contact points close along the normal
    /// (ḋ = −closing), from the contact found at τ = t.
    fn closing_speed(&mut self, t: f64) -> f64 {
        let contact = match self.last {
            Some((at, c)) if at == t => c,
            _ => {
                self.distance_at(t);
                self.last.expect("just computed").1
            }
        };
        let (qa_t, qb_t) = self.orientations(t);
        let normal = qa_t * contact.normal;
        let arm_a = qa_t * (0.5 * (contact.point_a + contact.point_b));
        let arm_b = arm_a - (self.d + self.dv * t);
        let (omega_a, omega_b) = (
            self.w_a.angular_velocity(&qa_t),
            self.w_b.angular_velocity(&qb_t),
        );
        let rigid = -normal.dot(&(self.dv + omega_b.cross(&arm_b) - omega_a.cross(&arm_a)));
        match self.growth {
            None => rigid,
            // A grown body's surface point x (from its centre) moves
            // outward at (ṡ/s) x: the contact points close faster by
            // (ṡ/s) n·(arm_A − arm_B) = (ṡ/s) n·(r_B − r_A).
            Some(g) => rigid + g.rate / self.scale(t) * normal.dot(&(arm_a - arm_b)),
        }
    }

    /// A contact at τ = t, the solver state there kept for the collision.
    #[inline]
    fn contact_at(&mut self, t: f64) -> Found {
        self.predictor.set_found(self.warm);
        Found::Contact(t)
    }

    /// The contact between `lo`, where the pair is apart (or its value is
    /// a lower bound), and `hi`, where it overlaps.
    fn narrow(&mut self, lo: (f64, f64), hi: (f64, f64)) -> Result<Found, SearchError> {
        let tol = self.tol;
        // The lower end's value may be a lower bound on the distance
        // (all the stepping needed); the root finder needs the distance
        // (and Newton below the solution there).
        let mut lo = match self.last {
            Some((at, c)) if at == lo.0 => (lo.0, c.distance),
            _ => (lo.0, self.distance_at(lo.0)),
        };
        self.failed(lo.1)?;
        let mut hi = hi;
        if lo.1 > 0.0 && lo.1 <= tol {
            let touching = lo.0;
            // Touching to the tolerance at the lower end (a contact the
            // pair recedes from) and overlapping at the upper: it came
            // back within the step. The root finder would stop at the
            // lower end at once, the collision would be processed
            // again at the same instant, and again (the stall of
            // ε_d = 1e-1, aspect 2, φ = 0.5): find a time the pair is
            // clearly apart, and narrow from there.
            let mut apart = false;
            for _ in 0..60 {
                let mid = 0.5 * (lo.0 + hi.0);
                if mid <= lo.0 || mid >= hi.0 {
                    break;
                }
                let d_mid = self.distance_at(mid);
                self.failed(d_mid)?;
                if d_mid > tol {
                    lo = (mid, d_mid);
                    apart = true;
                    break;
                }
                if d_mid < 0.0 {
                    hi = (mid, d_mid);
                } else {
                    lo = (mid, d_mid);
                }
            }
            if !apart {
                // Within the tolerance until it overlaps: the contact is
                // where the narrowing started (as the root finder
                // would have said).
                let d_touching = self.distance_at(touching);
                self.failed(d_touching)?;
                return Ok(self.contact_at(touching));
            }
        }
        // Newton's method in τ from the end where the pair is apart:
        // the reduced form of the paper's Newton–Raphson on eqs.
        // (30)–(31). Each distance solves the contact equations at
        // fixed τ (eq. 9), and its derivative is exact without
        // differentiating them: d′(τ) = −(closing speed of the contact
        // points along the normal), the envelope theorem. Near a
        // contact the distance bends up (it is convex for bodies that
        // only translate), so the steps stay on the apart side and
        // converge quadratically; a step that overshoots into overlap,
        // or a pair that is not closing, hands the bracket to the
        // regula falsi below.
        let mut newton_steps = 0;
        while lo.1 > tol && newton_steps < 8 {
            newton_steps += 1;
            let slope = -self.closing_speed(lo.0);
            let next = lo.0 - lo.1 / slope;
            if !(slope < 0.0 && next > lo.0 && next < hi.0) {
                break;
            }
            let d_next = self.distance_at(next);
            self.failed(d_next)?;
            if d_next >= 0.0 {
                lo = (next, d_next);
            } else {
                hi = (next, d_next);
                break;
            }
        }
        let (lo, f_lo, _, f_hi, _) = if lo.1 > tol {
            narrow_sign_change(|t| self.distance_at(t), lo, hi, tol, 200)
        } else {
            (lo.0, lo.1, hi.0, hi.1, 0)
        };
        self.failed(f_lo)?;
        self.failed(f_hi)?;
        // The solution at lo (unless the last evaluation was there).
        if self.last.map(|(t, _)| t) != Some(lo) {
            let d_lo = self.distance_at(lo);
            self.failed(d_lo)?;
        }
        Ok(self.contact_at(lo))
    }

    /// Where the stepping starts: from the bounding spheres' first touch
    /// `t1`, or where an unfinished search stopped, with its solver state
    /// (the same steps as if it had not stopped).
    fn start(&mut self, resume: Option<&Progress>, t1: f64, t2: f64) -> Result<Start, SearchError> {
        if let Some(p) = resume {
            self.warm = p.warm;
            self.hint = p.hint;
            self.last = p.last;
            self.earlier = p.earlier;
            return Ok(Start::At(p.t, p.distance, p.normal));
        }
        let t = t1;
        // Most pairs of a list are cleared by the support planes across the
        // line of centres alone, before any contact function is built.
        let across = self
            .orientations(t)
            .0
            .inverse_transform_vector(&(self.d + self.dv * t));
        if let Some(across) = across.try_normalize(0.0)
            && t + self.apart_for(t, &across).0 >= t2
        {
            return Ok(Start::Ended(Found::Apart));
        }
        let (mut d_t, mut normal_t) = self.step_distance(t);
        self.failed(d_t)?;
        let tol = self.tol;
        if d_t <= tol && d_t > 0.0 {
            // A lower bound this small says nothing: look at the distance.
            d_t = self.distance_at(t);
            if let Some((_, c)) = self.last {
                normal_t = c.normal;
            }
            self.failed(d_t)?;
        }
        if d_t <= tol {
            if d_t < -tol.max(self.eps * 1e-3) {
                return Err(SearchError::Overlap { depth: -d_t, at: t });
            }
            // In contact to round-off: a collision now if the contact points
            // approach (after a collision they recede, so a pair is never
            // made to collide twice at one time), else follow the pair.
            if self.closing_speed(t) > 0.0 {
                return Ok(Start::Ended(self.contact_at(t)));
            }
        }
        Ok(Start::At(t, d_t, normal_t))
    }

    /// Steps from (t, d_t, normal_t) to `t2` (cut where the bounding
    /// spheres part, `t_exit`) in at most `budget` steps; an unfinished
    /// search leaves its progress in `stopped`.
    #[allow(clippy::too_many_arguments)]
    fn advance(
        &mut self,
        (mut t, mut d_t, mut normal_t): (f64, f64, V3),
        t2: f64,
        t_exit: f64,
        budget: u32,
        stopped: &mut Option<Progress>,
    ) -> Result<Found, SearchError> {
        let (eps, rate_bound) = (self.eps, self.rate_bound);
        let mut steps = 0u32;
        while t < t2 {
            if steps >= budget {
                *stopped = Some(Progress {
                    t,
                    distance: d_t,
                    normal: normal_t,
                    warm: self.warm,
                    hint: self.hint,
                    last: self.last,
                    earlier: self.earlier,
                });
                return Ok(Found::Stopped(t));
            }
            steps += 1;
            // A step that cannot jump over a contact: d/ḋ_max (eq. 39), or
            // longer where the support planes keep the bodies apart; close
            // to contact with neither long enough, ε_d/ḋ_max and a look for
            // a grazing contact within it.
            let (apart, level) = self.apart_for(t, &normal_t);
            let safe = (d_t.max(0.0) / rate_bound).max(apart);
            // Apart until t2 by more than the contact tolerance (so no
            // contact this search could report comes before t2): nothing
            // to step through. The grid of the steps is unchanged, so is
            // the contact found within any horizon.
            let margin = 2.0 * self.tol;
            let clear = ((d_t - margin).max(0.0) / rate_bound).max(if level > margin {
                apart
            } else {
                0.0
            });
            if t + clear >= t2 {
                break;
            }
            let sure = d_t > eps || safe >= eps / rate_bound;
            let step = if sure { safe } else { eps / rate_bound };
            if sure && t + step >= t2 {
                // Apart until t2: the distance cannot close within the step.
                break;
            }
            let t_next = (t + step).min(t_exit);
            if t_next <= t {
                break;
            }
            let (d_next, normal_next) = self.step_distance(t_next);
            self.failed(d_next)?;
            if d_next < 0.0 {
                return self.stepped_into_overlap((t, d_t), (t_next, d_next));
            }
            if !sure
                && d_next < eps
                && let Some(found) = self.graze((t, t_next))?
            {
                return Ok(found);
            }
            t = t_next;
            d_t = d_next;
            normal_t = normal_next;
        }
        Ok(Found::Apart)
    }

    /// A step from τ = t (distance d_t) into overlap at t_next.
    fn stepped_into_overlap(
        &mut self,
        (t, d_t): (f64, f64),
        (t_next, d_next): (f64, f64),
    ) -> Result<Found, SearchError> {
        if d_t > 0.0 {
            // (From a contact the pair receded from too: see `narrow`.)
            return self.narrow((t, d_t), (t_next, d_next));
        }
        // From a receding round-off contact into overlap within one
        // step: bisect for a time the pair is apart, then narrow.
        let (mut lo, mut hi, mut d_hi) = (t, t_next, d_next);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            let d_mid = self.distance_at(mid);
            self.failed(d_mid)?;
            if d_mid > 0.0 {
                return self.narrow((mid, d_mid), (hi, d_hi));
            }
            if mid <= lo || mid >= hi {
                break;
            }
            if d_mid < 0.0 {
                hi = mid;
                d_hi = d_mid;
            } else {
                lo = mid;
            }
        }
        // Overlapping from the start to round-off: touching now.
        self.predictor.count(|work| work.roundoff_contacts += 1);
        self.predictor.set_found(None);
        Ok(Found::Contact(hi))
    }

    /// A grazing contact hidden between t and t_next (step 6), if any.
    fn graze(&mut self, (t, t_next): (f64, f64)) -> Result<Option<Found>, SearchError> {
        // The stepping may have used lower bounds: the parabola
        // needs the distances themselves (a lower bound far below
        // the distance bent it wrongly and let a vertex graze of two
        // cuboids through).
        // Each closing speed right after its distance, from the
        // same solution.
        let d_t = self.distance_at(t);
        self.failed(d_t)?;
        let closing_at_t = self.closing_speed(t);
        let d_next = self.distance_at(t_next);
        self.failed(d_next)?;
        let closing_at_next = self.closing_speed(t_next);
        let t_mid = 0.5 * (t + t_next);
        let d_mid = self.distance_at(t_mid);
        self.failed(d_mid)?;
        if d_mid < 0.0 && d_t > 0.0 {
            return self.narrow((t, d_t), (t_mid, d_mid)).map(Some);
        }
        let h = 0.5 * (t_next - t);
        // Parabola through the three points, in s = (τ − t_mid)/h.
        let curvature = d_next - 2.0 * d_mid + d_t;
        let s_min = -(d_next - d_t) / (2.0 * curvature);
        let parabola_dips = curvature > 0.0 && s_min > -1.0 && s_min < 1.0;
        // The contact points close at t and recede at t_next: a
        // minimum lies between, whatever the parabola says (a
        // vertex graze is a V, no parabola).
        let turns = closing_at_t > 0.0 && closing_at_next <= 0.0;
        if !(parabola_dips || turns) {
            return Ok(None);
        }
        let s_min = if parabola_dips { s_min } else { 0.0 };
        let t_min = t_mid + s_min * h;
        let d_min = self.distance_at(t_min);
        self.failed(d_min)?;
        if d_min < 0.0 && d_t > 0.0 {
            return self.narrow((t, d_t), (t_min, d_min)).map(Some);
        }
        // Inconclusive: the true minimum, as well as can be.
        self.predictor.count(|work| work.grazing_refinements += 1);
        let (tb, db, _) = brent_minimize(
            |s| self.distance_at(s),
            t,
            t_next,
            1e-14 * (1.0 + t_next.abs()),
            60,
        );
        self.failed(db)?;
        if db < 0.0 && d_t > 0.0 {
            return self.narrow((t, d_t), (tb, db)).map(Some);
        }
        Ok(None)
    }
}
