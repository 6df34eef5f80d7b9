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

use std::cell::Cell;

use nalgebra::{UnitQuaternion, Vector3};

use super::motion::Spin;
use crate::geometry::pair::{distance_lower_bound_near, support_points_start};
use crate::geometry::roots::{brent_minimize, narrow_sign_change};
use crate::geometry::{
    Contact, DistanceOptions, Method, Relative, Shape, Status, WarmStart, distance,
};

type V3 = Vector3<f64>;

/// Knobs of the prediction, lengths relative to the smaller body's
/// smallest half-extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictorOptions {
    /// ε_d of eq. (39): below this distance steps are ε_d/ḋ_max and
    /// grazing contacts are searched for.
    pub grazing_threshold: f64,
    /// A contact is accepted when the distance is in [0, tol].
    pub contact_tolerance: f64,
    /// Above this, the stepping uses a cheap lower bound on the distance
    /// (bounding spheres, support planes, oriented boxes) instead of the
    /// exact distance.
    pub exact_below: f64,
    /// The distance kernels' options.
    pub distance: DistanceOptions,
}

impl Default for PredictorOptions {
    fn default() -> Self {
        Self {
            grazing_threshold: 1e-4,
            contact_tolerance: 1e-10,
            exact_below: 0.0,
            distance: DistanceOptions::default(),
        }
    }
}

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
/// [`Predictor::search_into`]).
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
    t: f64,
    distance: f64,
    normal: V3,
    warm: Option<WarmStart>,
    hint: Option<V3>,
    last: Option<(f64, Contact)>,
    earlier: Option<(f64, Contact)>,
}

impl Progress {
    /// The time (from the search's origin) it got to.
    pub fn time(&self) -> f64 {
        self.t
    }
}

/// A body's shape and rotation, for prediction: (shape, orientation at the
/// search's origin, or a given time before it for
/// [`Predictor::search_into`], free rotation; |ω| is constant in it).
pub type Rotor<'a> = (&'a Shape, &'a UnitQuaternion<f64>, &'a Spin);

/// The work the searches have done: exact distances evaluated and the
/// solver iterations they took (Newton steps, or GJK/EPA and feature
/// iterations for pairs with a cuboid), and the evaluations that did not
/// go the first way, cumulative. A run reports the last four: none is an
/// error (each answer is certified or the run fails), but a count that
/// grows says where the numerics are strained.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SolverWork {
    /// Exact distance evaluations.
    pub distances: u64,
    /// Iterations over all of them.
    pub iterations: u64,
    /// Distances taken from a fallback method: GJK (or EPA) where Newton
    /// is the first method (pairs of smooth bodies), closest features by
    /// enumeration where GJK stalled (two cuboids).
    #[serde(default)]
    pub fallbacks: u64,
    /// Distances that stopped at the iteration cap (the last iterate used).
    #[serde(default)]
    pub iteration_caps: u64,
    /// Grazing approaches refined by a minimisation of the distance in
    /// time, the parabola through three distances being inconclusive.
    #[serde(default)]
    pub grazing_refinements: u64,
    /// Pairs found overlapping to round-off at the start of a step and
    /// taken as touching there.
    #[serde(default)]
    pub roundoff_contacts: u64,
}

impl SolverWork {
    /// The strains in words ("3 solver fallbacks, 1 iteration caps"), if
    /// any.
    pub fn strains_in_words(&self) -> Option<String> {
        let strains = self.strains();
        (!strains.is_empty()).then(|| {
            strains
                .iter()
                .map(|(name, n)| format!("{n} {name}"))
                .collect::<Vec<_>>()
                .join(", ")
        })
    }

    /// The counts of what did not go the first way, named, where not zero.
    pub fn strains(&self) -> Vec<(&'static str, u64)> {
        [
            ("solver fallbacks", self.fallbacks),
            ("iteration caps", self.iteration_caps),
            ("grazing refinements", self.grazing_refinements),
            ("round-off contacts", self.roundoff_contacts),
        ]
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .collect()
    }
}

/// Whether `method` is a fallback for the pair (`a`, `b`): GJK or EPA
/// where Newton comes first (two smooth bodies, not both spheres), closest
/// features where GJK stalled (two cuboids).
fn is_fallback(a: &Shape, b: &Shape, method: Method) -> bool {
    match method {
        Method::Gjk | Method::Epa => {
            !matches!(a, Shape::Cuboid(_)) && !matches!(b, Shape::Cuboid(_))
        }
        Method::Features => true,
        _ => false,
    }
}

/// Predicts contacts of general pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct Predictor {
    options: PredictorOptions,
    /// The distance solver's state at the last contact found (Newton's
    /// points and multiplier), so that the collision is computed on the
    /// same solution the prediction stopped at.
    found: Cell<Option<WarmStart>>,
    /// What the searches have cost so far.
    work: Cell<SolverWork>,
}

impl Predictor {
    /// A predictor with these options.
    pub fn new(options: PredictorOptions) -> Self {
        Self {
            options,
            found: Cell::new(None),
            work: Cell::new(SolverWork::default()),
        }
    }

    /// Counts on from `work` (a dynamics rebuilt at a frame, or resumed
    /// from one, continues its stage's counts).
    pub fn continue_work(&self, work: SolverWork) {
        self.work.set(work);
    }

    /// Adds to the work counted.
    fn count(&self, add: impl FnOnce(&mut SolverWork)) {
        let mut work = self.work.get();
        add(&mut work);
        self.work.set(work);
    }

    /// The work of every search so far.
    pub fn work(&self) -> SolverWork {
        self.work.get()
    }

    /// The solver state at the contact the last search found (taken).
    pub fn take_found(&self) -> Option<WarmStart> {
        self.found.take()
    }

    /// The signed distance and contact of a pair at one pose, starting from
    /// a previous solution of the same pair.
    pub fn contact_from(
        &self,
        a: &Shape,
        b: &Shape,
        rel: &Relative,
        warm: Option<&WarmStart>,
    ) -> Contact {
        distance(a, b, rel, &self.options.distance, warm)
    }

    /// The options it predicts with.
    pub fn options(&self) -> &PredictorOptions {
        &self.options
    }

    /// Relative tolerance on the distance at a contact.
    pub fn contact_tolerance(&self) -> f64 {
        // A collision found at the end of a search may sit anywhere in
        // [0, tol]; allow for the re-evaluation at processing.
        10.0 * self.options.contact_tolerance
    }

    /// The signed distance and contact of a pair at one pose.
    pub fn contact(&self, a: &Shape, b: &Shape, rel: &Relative) -> Contact {
        self.contact_from(a, b, rel, None)
    }

    /// The first time τ in [0, `horizon`] at which the bodies touch, their
    /// centres separated by `d + dv τ` (B − A) and each turning at its
    /// angular velocity; `Ok(None)` if they do not touch by then. An error
    /// says why the distance could not be followed (solver failure, or the
    /// pair already overlapping).
    pub fn contact_time(
        &self,
        a: Rotor,
        b: Rotor,
        d: &V3,
        dv: &V3,
        horizon: f64,
    ) -> Result<Option<f64>, String> {
        match self.search(a, b, d, dv, None, horizon, u32::MAX)? {
            Search::Contact(t) => Ok(Some(t)),
            Search::Apart => Ok(None),
            Search::Unfinished(_) => unreachable!("an unlimited search finishes"),
        }
    }

    /// [`Predictor::contact_time`] with at most about `budget` steps: a
    /// search that runs out says how far it got, so that it can be resumed
    /// (`resume`, with the same pair and motion), perhaps with a shorter
    /// horizon, once cheaper pairs have been searched.
    #[allow(clippy::too_many_arguments)]
    pub fn search(
        &self,
        a: Rotor,
        b: Rotor,
        d: &V3,
        dv: &V3,
        resume: Option<&Progress>,
        horizon: f64,
        budget: u32,
    ) -> Result<Search, String> {
        let mut stopped = None;
        Ok(
            match self.search_into(
                a,
                b,
                (0.0, 0.0),
                d,
                dv,
                resume,
                horizon,
                budget,
                &mut stopped,
            )? {
                Found::Contact(t) => Search::Contact(t),
                Found::Apart => Search::Apart,
                Found::Stopped(_) => {
                    Search::Unfinished(stopped.expect("a stopped search's progress"))
                }
            },
        )
    }

    /// [`Predictor::search`] that leaves the progress of a search out of
    /// budget in `stopped` and returns only how it ended: a search's
    /// progress is a few hundred bytes, which the dynamics' many searches
    /// that end at once should not copy through every return. The bodies'
    /// orientations are given `since` (A, B) before the search's origin
    /// (each turns on from there).
    #[allow(clippy::too_many_arguments)]
    pub fn search_into(
        &self,
        (shape_a, q_a, w_a): Rotor,
        (shape_b, q_b, w_b): Rotor,
        (since_a, since_b): (f64, f64),
        d: &V3,
        dv: &V3,
        resume: Option<&Progress>,
        horizon: f64,
        budget: u32,
        stopped: &mut Option<Progress>,
    ) -> Result<Found, String> {
        if horizon <= resume.map_or(0.0, |p| p.t) {
            return Ok(Found::Apart);
        }
        let (la, lb) = (shape_a.bounding_radius(), shape_b.bounding_radius());
        // The bounding spheres' interval [t1, t2].
        let reach = la + lb;
        let b = d.dot(dv);
        let c = d.norm_squared() - reach * reach;
        let v2 = dv.norm_squared();
        let (t1, t2) = if c > 0.0 {
            let disc = b * b - v2 * c;
            if b >= 0.0 || disc < 0.0 {
                return Ok(Found::Apart);
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
        if t1 > t2 {
            return Ok(Found::Apart);
        }
        // Eq. (32), with the moment arm in place of the bounding radius: the
        // distance changes at the normal velocity of the contact points, and
        // a rotation moves a surface point along its normal by ω·(x × n).
        let (turn_a, turn_b) = (TurnBound::new(w_a, q_a), TurnBound::new(w_b, q_b));
        let rate_bound =
            dv.norm() + turn_a.speed * shape_a.moment_arm() + turn_b.speed * shape_b.moment_arm();
        if rate_bound == 0.0 {
            return Ok(Found::Apart);
        }
        let scale = shape_a.min_half_extent().min(shape_b.min_half_extent());
        let eps = self.options.grazing_threshold * scale;
        let tol = self.options.contact_tolerance * scale;
        // Both orientations at τ, kept for the last τ asked (the pose, the
        // bounds and the closing speed at one τ share them).
        let turned: Cell<(f64, UnitQuaternion<f64>, UnitQuaternion<f64>)> =
            Cell::new((f64::NAN, *q_a, *q_b));
        let orientations = |t: f64| {
            let (at, qa, qb) = turned.get();
            if at == t {
                return (qa, qb);
            }
            let (qa, qb) = (
                turn_a.orientation_after(w_a, q_a, since_a + t),
                turn_b.orientation_after(w_b, q_b, since_b + t),
            );
            turned.set((t, qa, qb));
            (qa, qb)
        };
        let pose = |t: f64| {
            let (qa_t, qb_t) = orientations(t);
            Relative::new(&(d + dv * t), &qa_t, &qb_t)
        };
        let warm: Cell<Option<WarmStart>> = Cell::new(None);
        let failure: Cell<Option<String>> = Cell::new(None);
        let last: Cell<Option<(f64, Contact)>> = Cell::new(None);
        // The last normal seen (A's frame): where the next bound's ascent
        // and a cold distance start (pairs with a superellipsoid).
        let hint: Cell<Option<V3>> = Cell::new(None);
        // The solution before `last`: a grazing check asks again for the
        // distance at the step it starts from, solved by the check before.
        let earlier: Cell<Option<(f64, Contact)>> = Cell::new(None);
        let dist = |t: f64| -> f64 {
            if let Some((at, c)) = last.get()
                && at == t
            {
                if c.warm_start.is_some() {
                    warm.set(c.warm_start);
                }
                return c.distance;
            }
            if let Some((at, c)) = earlier.get()
                && at == t
            {
                if c.warm_start.is_some() {
                    warm.set(c.warm_start);
                }
                earlier.set(last.get());
                last.set(Some((at, c)));
                return c.distance;
            }
            let rel = pose(t);
            let start = warm.get().or_else(|| {
                hint.get()
                    .and_then(|n| support_points_start(shape_a, shape_b, &rel, &n))
            });
            let contact = distance(
                shape_a,
                shape_b,
                &rel,
                &self.options.distance,
                start.as_ref(),
            );
            if contact.warm_start.is_some() {
                warm.set(contact.warm_start);
            }
            self.count(|work| {
                work.distances += 1;
                work.iterations += match contact.status {
                    Status::Converged { iterations }
                    | Status::IterationCap { iterations }
                    | Status::Failed { iterations, .. } => u64::from(iterations),
                    Status::DeepOverlap => 0,
                };
                work.iteration_caps +=
                    u64::from(matches!(contact.status, Status::IterationCap { .. }));
                work.fallbacks += u64::from(is_fallback(shape_a, shape_b, contact.method));
            });
            earlier.set(last.get());
            last.set(Some((t, contact)));
            if !contact.distance.is_finite() {
                failure.set(Some(format!("{:?} at τ = {t}", contact.status)));
                return f64::NAN;
            }
            contact.distance
        };
        let failed = |v: f64| -> Result<(), String> {
            if v.is_nan() {
                Err(failure.take().unwrap_or_else(|| "distance is NaN".into()))
            } else {
                Ok(())
            }
        };
        // Far from contact the cheap lower bound is enough to step with
        // (a step d/ḋ_max is safe for any d below the distance).
        let exact_below = self.options.exact_below * scale;
        // With the distance (or its bound), a direction along which the
        // bodies are well apart: the contact normal, or the bound's.
        let step_distance = |t: f64| -> (f64, V3) {
            let rel = pose(t);
            let (bound, normal) =
                distance_lower_bound_near(shape_a, shape_b, &rel, hint.get().as_ref());
            // (Also where a cold distance below starts.)
            hint.set(Some(normal));
            if bound > exact_below {
                (bound, normal)
            } else {
                let exact = dist(t);
                let normal = last.get().map_or(normal, |(_, c)| c.normal);
                hint.set(Some(normal));
                (exact, normal)
            }
        };
        // How long the bodies surely stay apart from τ = t: along a fixed
        // lab direction n the separation φ(τ) = n·r − h_A(n) − h_B(−n) of
        // the support planes is a lower bound on the distance, n·r changes
        // at n·Δv exactly, and each support value grows as
        // Shape::support_growth bounds it; φ(0) is the distance when n is
        // the contact normal, and then φ′(0) = ḋ (so a receding pair is
        // cleared at once, and an approaching one is followed to its
        // contact in steps that shrink quadratically, not geometrically).
        let apart_for = |t: f64, normal: &V3| -> f64 {
            let (qa_t, qb_t) = orientations(t);
            let n = qa_t * normal;
            // n in A's frame is `normal`; in B's, −n turned back.
            let u_b = -qb_t.inverse_transform_vector(&n);
            let ga = turn_a.support_growth(shape_a, w_a, &qa_t, normal);
            let gb = turn_b.support_growth(shape_b, w_b, &qb_t, &u_b);
            let phi = n.dot(&(d + dv * t)) - ga.value - gb.value;
            // (NaN included: no time is sure then.)
            if phi.is_nan() || phi <= 0.0 {
                return 0.0;
            }
            // Until the bound falls to a level short of zero (half of φ, at
            // most ε_d/2): a step never lands on a contact the bound sees
            // exactly (a face meeting a face along n), where the distance
            // may round to zero.
            let phi = phi - (0.5 * phi).min(0.5 * eps);
            let approach = n.dot(dv);
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
            quadratic.max(linear)
        };
        // The speed at which the contact points close along the normal
        // (ḋ = −closing), from the contact found at τ = t.
        let closing_speed = |t: f64| -> f64 {
            let contact = match last.get() {
                Some((at, c)) if at == t => c,
                _ => {
                    dist(t);
                    last.get().expect("just computed").1
                }
            };
            let (qa_t, qb_t) = orientations(t);
            let normal = qa_t * contact.normal;
            let arm_a = qa_t * (0.5 * (contact.point_a + contact.point_b));
            let arm_b = arm_a - (d + dv * t);
            let (omega_a, omega_b) = (w_a.angular_velocity(&qa_t), w_b.angular_velocity(&qb_t));
            -normal.dot(&(dv + omega_b.cross(&arm_b) - omega_a.cross(&arm_a)))
        };
        let narrow = |lo: (f64, f64), hi: (f64, f64)| -> Result<Found, String> {
            // The lower end's value may be a lower bound on the distance
            // (all the stepping needed); the root finder needs the distance
            // (and Newton below the solution there).
            let mut lo = match last.get() {
                Some((at, c)) if at == lo.0 => (lo.0, c.distance),
                _ => (lo.0, dist(lo.0)),
            };
            failed(lo.1)?;
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
                    let d_mid = dist(mid);
                    failed(d_mid)?;
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
                    failed(dist(touching))?;
                    self.found.set(warm.get());
                    return Ok(Found::Contact(touching));
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
                let slope = -closing_speed(lo.0);
                let next = lo.0 - lo.1 / slope;
                if !(slope < 0.0 && next > lo.0 && next < hi.0) {
                    break;
                }
                let d_next = dist(next);
                failed(d_next)?;
                if d_next >= 0.0 {
                    lo = (next, d_next);
                } else {
                    hi = (next, d_next);
                    break;
                }
            }
            let (lo, f_lo, _, f_hi, _) = if lo.1 > tol {
                narrow_sign_change(&dist, lo, hi, tol, 200)
            } else {
                (lo.0, lo.1, hi.0, hi.1, 0)
            };
            failed(f_lo)?;
            failed(f_hi)?;
            // The solution at lo (unless the last evaluation was there).
            if last.get().map(|(t, _)| t) != Some(lo) {
                failed(dist(lo))?;
            }
            self.found.set(warm.get());
            Ok(Found::Contact(lo))
        };
        // Where the stepping starts: from the bounding spheres' first
        // touch, or where an unfinished search stopped, with its solver
        // state (the same steps as if it had not stopped).
        let (mut t, mut d_t, mut normal_t) = match resume {
            Some(p) => {
                warm.set(p.warm);
                hint.set(p.hint);
                last.set(p.last);
                earlier.set(p.earlier);
                (p.t, p.distance, p.normal)
            }
            None => {
                let t = t1;
                // Most pairs of a list are cleared by the support planes across the
                // line of centres alone, before any contact function is built.
                let across = orientations(t).0.inverse_transform_vector(&(d + dv * t));
                if let Some(across) = across.try_normalize(0.0)
                    && t + apart_for(t, &across) >= t2
                {
                    return Ok(Found::Apart);
                }
                let (mut d_t, mut normal_t) = step_distance(t);
                failed(d_t)?;
                if d_t <= tol && d_t > 0.0 {
                    // A lower bound this small says nothing: look at the distance.
                    d_t = dist(t);
                    if let Some((_, c)) = last.get() {
                        normal_t = c.normal;
                    }
                    failed(d_t)?;
                }
                if d_t <= tol {
                    if d_t < -tol.max(eps * 1e-3) {
                        return Err(format!("the pair overlaps by {:e} at τ = {t}", -d_t));
                    }
                    // In contact to round-off: a collision now if the contact points
                    // approach (after a collision they recede, so a pair is never
                    // made to collide twice at one time), else follow the pair.
                    if closing_speed(t) > 0.0 {
                        self.found.set(warm.get());
                        return Ok(Found::Contact(t));
                    }
                }
                (t, d_t, normal_t)
            }
        };
        let mut steps = 0u32;
        while t < t2 {
            if steps >= budget {
                *stopped = Some(Progress {
                    t,
                    distance: d_t,
                    normal: normal_t,
                    warm: warm.get(),
                    hint: hint.get(),
                    last: last.get(),
                    earlier: earlier.get(),
                });
                return Ok(Found::Stopped(t));
            }
            steps += 1;
            // A step that cannot jump over a contact: d/ḋ_max (eq. 39), or
            // longer where the support planes keep the bodies apart; close
            // to contact with neither long enough, ε_d/ḋ_max and a look for
            // a grazing contact within it.
            let safe = (d_t.max(0.0) / rate_bound).max(apart_for(t, &normal_t));
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
            let (d_next, normal_next) = step_distance(t_next);
            failed(d_next)?;
            if d_next < 0.0 {
                if d_t > 0.0 {
                    // (From a contact the pair receded from too: see
                    // `narrow`.)
                    return narrow((t, d_t), (t_next, d_next));
                }
                // From a receding round-off contact into overlap within one
                // step: bisect for a time the pair is apart, then narrow.
                let (mut lo, mut hi, mut d_hi) = (t, t_next, d_next);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    let d_mid = dist(mid);
                    failed(d_mid)?;
                    if d_mid > 0.0 {
                        return narrow((mid, d_mid), (hi, d_hi));
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
                self.count(|work| work.roundoff_contacts += 1);
                self.found.set(None);
                return Ok(Found::Contact(hi));
            }
            if !sure && d_next < eps {
                // A grazing contact may hide between t and t_next (step 6).
                // The stepping may have used lower bounds: the parabola
                // needs the distances themselves (a lower bound far below
                // the distance bent it wrongly and let a vertex graze of two
                // cuboids through).
                // Each closing speed right after its distance, from the
                // same solution.
                let d_t = dist(t);
                failed(d_t)?;
                let closing_at_t = closing_speed(t);
                let d_next = dist(t_next);
                failed(d_next)?;
                let closing_at_next = closing_speed(t_next);
                let t_mid = 0.5 * (t + t_next);
                let d_mid = dist(t_mid);
                failed(d_mid)?;
                if d_mid < 0.0 && d_t > 0.0 {
                    return narrow((t, d_t), (t_mid, d_mid));
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
                if parabola_dips || turns {
                    let s_min = if parabola_dips { s_min } else { 0.0 };
                    {
                        let t_min = t_mid + s_min * h;
                        let d_min = dist(t_min);
                        failed(d_min)?;
                        if d_min < 0.0 && d_t > 0.0 {
                            return narrow((t, d_t), (t_min, d_min));
                        }
                        // Inconclusive: the true minimum, as well as can be.
                        self.count(|work| work.grazing_refinements += 1);
                        let (tb, db, _) =
                            brent_minimize(dist, t, t_next, 1e-14 * (1.0 + t_next.abs()), 60);
                        failed(db)?;
                        if db < 0.0 && d_t > 0.0 {
                            return narrow((t, d_t), (tb, db));
                        }
                    }
                }
            }
            t = t_next;
            d_t = d_next;
            normal_t = normal_next;
        }
        Ok(Found::Apart)
    }
}

/// What the support-growth bound needs of a body's free rotation, fixed
/// over a search: |ω| (a constant of the free rotation), the bound on |ü|
/// for a fixed lab direction's body-frame image u (|ü| ≤ |ω|² + |ω̇_body|,
/// and |ω̇_body| ≤ |ω| |ω_lab part| for a symmetric top, 0 for a spherical
/// one), and a spherical top's ω in its own frame (constant as well: the
/// body turns about ω).
#[derive(Debug, Clone, Copy)]
struct TurnBound {
    speed: f64,
    accel: f64,
    body_omega: Option<V3>,
    /// A spherical top's ω/|ω| (lab frame).
    axis: Option<V3>,
}

impl TurnBound {
    fn new(spin: &Spin, q: &UnitQuaternion<f64>) -> Self {
        let omega = spin.angular_velocity(q);
        let speed = omega.norm();
        let spherical = spin.body == V3::zeros();
        let precession = if spherical { 0.0 } else { spin.lab.norm() };
        Self {
            speed,
            accel: speed * (speed + precession),
            body_omega: spherical.then(|| q.inverse_transform_vector(&omega)),
            axis: (spherical && speed > 0.0).then(|| omega / speed),
        }
    }

    /// The orientation a time `t` after `q` (the same rotation as
    /// `Spin::orientation_after`, to rounding): a spherical top turns by
    /// |ω| t about its fixed axis, without finding the axis again at each
    /// τ; not renormalised (one product of unit quaternions from the
    /// stored orientation, nothing accumulates).
    #[inline]
    fn orientation_after(
        &self,
        spin: &Spin,
        q: &UnitQuaternion<f64>,
        t: f64,
    ) -> UnitQuaternion<f64> {
        match self.axis {
            Some(axis) if t != 0.0 => {
                let (sin, cos) = (0.5 * self.speed * t).sin_cos();
                let turn = nalgebra::Quaternion::from_parts(cos, axis * sin);
                UnitQuaternion::new_unchecked(turn * q.quaternion())
            }
            Some(_) => *q,
            None if self.speed == 0.0 => *q,
            None => spin.orientation_after(q, t),
        }
    }

    /// `Shape::support_growth` along the body-frame direction `u` of the
    /// body at orientation `q` (u̇ = u × ω_body).
    #[inline]
    fn support_growth(
        &self,
        shape: &Shape,
        spin: &Spin,
        q: &UnitQuaternion<f64>,
        u: &V3,
    ) -> crate::geometry::shape::SupportGrowth {
        let body_omega = self
            .body_omega
            .unwrap_or_else(|| q.inverse_transform_vector(&spin.lab) + spin.body);
        shape.support_growth(u, &u.cross(&body_omega), self.speed, self.accel)
    }
}

/// The first τ > 0 at which the concave bound
/// φ + slope τ − Σ w (|c + rτ| − |c|) − ½ curvature τ² reaches 0 (φ > 0;
/// the kinks are a cuboid's support value, see `Shape::support_growth`):
/// between consecutive kinks it is a parabola, solved exactly.
fn first_zero(phi: f64, slope: f64, kinks: &[(f64, f64, f64); 6], curvature: f64) -> f64 {
    // The bound's slope from the kinks just after τ = 0, Σ w r sign(c + rτ)
    // (sign(r) where c = 0), and where the kinks ahead bend it down (c and
    // r of opposite signs: at τ = −c/r the term's slope rises by 2 w |r|).
    let mut bend = 0.0;
    let mut breaks = [(f64::INFINITY, 0.0); 6];
    let mut ahead = 0;
    for &(w, c, r) in kinks {
        let sign = if c != 0.0 { c.signum() } else { r.signum() };
        bend += w * r * sign;
        if w > 0.0 && c * r < 0.0 {
            breaks[ahead] = (-c / r, 2.0 * w * r.abs());
            ahead += 1;
        }
    }
    if !bend.is_finite() {
        return 0.0;
    }
    // In order (insertion sort: at most six).
    for k in 1..ahead {
        let mut m = k;
        while m > 0 && breaks[m - 1].0 > breaks[m].0 {
            breaks.swap(m - 1, m);
            m -= 1;
        }
    }
    let (mut lo, mut f_lo) = (0.0, phi);
    for &(hi, rise) in &breaks[..ahead] {
        let x = time_to_zero(f_lo, slope - bend - curvature * lo, curvature);
        if lo + x <= hi {
            return lo + x;
        }
        f_lo = kinked_bound(phi, slope, kinks, curvature, hi);
        lo = hi;
        if f_lo <= 0.0 {
            // Rounding at the kink: the bound is down to zero there.
            return lo;
        }
        bend += rise;
    }
    lo + time_to_zero(f_lo, slope - bend - curvature * lo, curvature)
}

/// φ + slope τ − Σ w (|c + rτ| − |c|) − ½ curvature τ² at τ.
#[inline]
fn kinked_bound(
    phi: f64,
    slope: f64,
    kinks: &[(f64, f64, f64); 6],
    curvature: f64,
    tau: f64,
) -> f64 {
    let bent: f64 = kinks
        .iter()
        .map(|&(w, c, r)| w * ((c + r * tau).abs() - c.abs()))
        .sum();
    phi + slope * tau - bent - 0.5 * curvature * tau * tau
}

/// The first τ > 0 at which φ + slope τ − ½ curvature τ² reaches 0 (φ > 0,
/// curvature ≥ 0), infinite if never; written without cancellation.
fn time_to_zero(phi: f64, slope: f64, curvature: f64) -> f64 {
    if curvature > 0.0 {
        let root = (slope * slope + 2.0 * curvature * phi).sqrt();
        if slope < 0.0 {
            2.0 * phi / (root - slope)
        } else {
            (slope + root) / curvature
        }
    } else if slope < 0.0 {
        phi / -slope
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    fn ellipsoid(a: f64, b: f64, c: f64) -> Shape {
        Shape::Ellipsoid(crate::geometry::Ellipsoid::new(a, b, c).unwrap())
    }

    /// Two spheres given as ellipsoids: the general search finds the
    /// closed-form contact time.
    /// The first zero of the kinked bound against a fine scan of it: the
    /// bound is positive before the time returned and zero there.
    #[test]
    fn first_zero_of_the_kinked_bound_matches_a_scan() {
        let mut u = crate::test_support::uniform(31);
        for case in 0..3000 {
            let phi = 1e-3 + u();
            let slope = 4.0 * (u() - 0.5);
            let curvature = if case % 3 == 0 { 0.0 } else { 3.0 * u() };
            let mut kinks = [(0.0, 0.0, 0.0); 6];
            for kink in kinks.iter_mut().take(1 + case % 6) {
                *kink = (u(), 2.0 * (u() - 0.5), 4.0 * (u() - 0.5));
            }
            let bound = |tau: f64| kinked_bound(phi, slope, &kinks, curvature, tau);
            let tau = first_zero(phi, slope, &kinks, curvature);
            let horizon = if tau.is_finite() { tau } else { 50.0 };
            for k in 0..2000 {
                let s = horizon * k as f64 / 2000.0;
                assert!(
                    bound(s) > -1e-12,
                    "case {case}: bound {} at {s} before {tau}",
                    bound(s)
                );
            }
            if tau.is_finite() {
                assert!(
                    bound(tau).abs() < 1e-9,
                    "case {case}: bound {} at {tau}",
                    bound(tau)
                );
            } else {
                // Never zero: the bound does not turn down at all.
                assert!(curvature == 0.0 && bound(1e3) > 0.0, "case {case}");
            }
        }
    }

    #[test]
    fn spheres_as_ellipsoids_match_the_closed_form() {
        let p = Predictor::new(PredictorOptions::default());
        let s = ellipsoid(0.5, 0.5, 0.5);
        let q = UnitQuaternion::identity();
        let w = Spin::constant(V3::zeros());
        let mut u = crate::test_support::uniform(4);
        for _ in 0..200 {
            let d = V3::new(3.0, u() - 0.5, u() - 0.5);
            let dv = V3::new(-1.0 - u(), 0.3 * (u() - 0.5), 0.3 * (u() - 0.5));
            let expected = crate::geometry::pair::sphere_contact_time(&d, &dv, 1.0);
            let got = p
                .contact_time((&s, &q, &w), (&s, &q, &w), &d, &dv, 100.0)
                .unwrap();
            match (expected, got) {
                (Some(e), Some(g)) => assert!((e - g).abs() < 1e-9, "{e} vs {g}"),
                (None, None) => {}
                other => panic!("{other:?} for d = {d}, dv = {dv}"),
            }
        }
    }

    /// A search stopped after every step and resumed from its progress
    /// takes the same steps as one that never stopped: the same contact
    /// time to the bit and the same distances evaluated (the dynamics'
    /// searches stop where their neighbours' budgets run out, which depends
    /// on the neighbour structure). Pairs placed a grazing distance apart,
    /// turning and drifting, so that the steps within ε_d are taken.
    #[test]
    fn a_search_resumed_after_every_step_is_the_search_in_one_go() {
        let shapes: [Shape; 4] = [
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)".parse().unwrap(),
            ellipsoid(1.0, 0.5, 0.5),
            "Superellipsoid(a: 1.0, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))"
                .parse()
                .unwrap(),
            "Cuboid(a: 0.6, b: 0.5, c: 0.3)".parse().unwrap(),
        ];
        let mut u = crate::test_support::uniform(77);
        let mut unit = || V3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
        let (mut contacts, mut resumed) = (0, 0);
        for case in 0..400 {
            let (a, b) = (&shapes[case % 4], &shapes[(case / 4) % 4]);
            let qa = UnitQuaternion::from_scaled_axis(unit() * 3.0);
            let qb = UnitQuaternion::from_scaled_axis(unit() * 3.0);
            let (wa, wb) = (Spin::constant(unit() * 0.5), Spin::constant(unit() * 0.5));
            // B along a random direction, a gap of 1e-6 to 1e-4 away.
            let dir = unit();
            let gap = 10f64.powf(-6.0 + 2.0 * (case % 7) as f64 / 6.0);
            let at = |s: f64| {
                let rel = Relative::new(&(dir * s), &qa, &qb);
                distance(a, b, &rel, &DistanceOptions::default(), None).distance
            };
            let (mut lo, mut hi) = (0.0, 4.0);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if at(mid) < gap { lo = mid } else { hi = mid }
            }
            let d = dir * hi;
            let dv = unit() * 0.02 - dir * 0.01 * (case % 3) as f64;
            let one_go = Predictor::new(PredictorOptions::default());
            let expected = one_go
                .search((a, &qa, &wa), (b, &qb, &wb), &d, &dv, None, 2.0, u32::MAX)
                .unwrap();
            let stepwise = Predictor::new(PredictorOptions::default());
            let mut progress = None;
            let got = loop {
                match stepwise
                    .search(
                        (a, &qa, &wa),
                        (b, &qb, &wb),
                        &d,
                        &dv,
                        progress.as_ref(),
                        2.0,
                        1,
                    )
                    .unwrap()
                {
                    Search::Unfinished(p) => {
                        resumed += 1;
                        progress = Some(p)
                    }
                    done => break done,
                }
            };
            assert_eq!(got, expected, "case {case}");
            assert_eq!(stepwise.work(), one_go.work(), "case {case}");
            contacts += matches!(got, Search::Contact(_)) as usize;
        }
        // Both kinds of ending, and many stops on the way.
        assert!(
            contacts > 40 && contacts < 360 && resumed > 4000,
            "{contacts} {resumed}"
        );
    }

    /// Orientations given some time before the search's origin (turned on
    /// inside it) give the contact found from the orientations turned to
    /// the origin first: the same time to rounding.
    #[test]
    fn orientations_given_earlier_are_turned_on_to_the_origin() {
        let shapes: [Shape; 3] = [
            "Cuboid(a: 0.5, b: 0.4, c: 0.3)".parse().unwrap(),
            ellipsoid(1.0, 0.5, 0.5),
            "Superellipsoid(a: 1.0, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))"
                .parse()
                .unwrap(),
        ];
        let mut u = crate::test_support::uniform(78);
        let mut unit = || V3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
        let mut contacts = 0;
        for case in 0..150 {
            let (a, b) = (&shapes[case % 3], &shapes[(case / 3) % 3]);
            let (qa, qb) = (
                UnitQuaternion::from_scaled_axis(unit() * 3.0),
                UnitQuaternion::from_scaled_axis(unit() * 3.0),
            );
            let (wa, wb) = (Spin::constant(unit() * 2.0), Spin::constant(unit() * 2.0));
            let since = (0.3 * (case % 4) as f64, 0.2 * (case % 5) as f64);
            let dir = unit();
            let d = dir * 3.0;
            let dv = -dir + unit() * 0.3;
            let p = Predictor::new(PredictorOptions::default());
            let mut stopped = None;
            let given_earlier = p
                .search_into(
                    (a, &qa, &wa),
                    (b, &qb, &wb),
                    since,
                    &d,
                    &dv,
                    None,
                    10.0,
                    u32::MAX,
                    &mut stopped,
                )
                .unwrap();
            let (qa_now, qb_now) = (
                wa.orientation_after(&qa, since.0),
                wb.orientation_after(&qb, since.1),
            );
            let turned_first = p
                .search(
                    (a, &qa_now, &wa),
                    (b, &qb_now, &wb),
                    &d,
                    &dv,
                    None,
                    10.0,
                    u32::MAX,
                )
                .unwrap();
            match (given_earlier, turned_first) {
                (Found::Contact(s), Search::Contact(t)) => {
                    contacts += 1;
                    assert!((s - t).abs() < 1e-9, "case {case}: {s} vs {t}")
                }
                (Found::Apart, Search::Apart) => {}
                other => panic!("case {case}: {other:?}"),
            }
        }
        assert!(contacts > 100, "{contacts}");
    }

    /// The search's orientations are the free rotation's to rounding, for
    /// spherical tops (the shortcut), symmetric tops and bodies at rest.
    #[test]
    fn the_search_turns_bodies_as_the_free_rotation_does() {
        let mut u = crate::test_support::uniform(5);
        let mut vector = || V3::new(u() - 0.5, u() - 0.5, u() - 0.5);
        for case in 0..300 {
            let q = UnitQuaternion::from_scaled_axis(vector() * 4.0);
            let spin = match case % 3 {
                0 => Spin::constant(vector() * 5.0),
                1 => Spin {
                    lab: vector() * 3.0,
                    body: V3::z() * vector().x,
                },
                _ => Spin::constant(V3::zeros()),
            };
            let turn = TurnBound::new(&spin, &q);
            for t in [0.0, 1e-9, 1e-3, 0.3, 2.0, 40.0] {
                let (got, expected) = (
                    turn.orientation_after(&spin, &q, t),
                    spin.orientation_after(&q, t),
                );
                assert!(
                    (got.coords - expected.coords).norm() < 1e-14 * (1.0 + t),
                    "case {case}, t {t}: {got:?} vs {expected:?}"
                );
            }
        }
    }

    /// A rotating rod sweeping past a sphere at rest: the predicted time is
    /// when the distance first reaches zero, checked by stepping finely.
    #[test]
    fn rotating_rod_hits_where_fine_stepping_says() {
        let p = Predictor::new(PredictorOptions::default());
        let rod = ellipsoid(2.0, 0.2, 0.2);
        let ball = ellipsoid(0.3, 0.3, 0.3);
        let qa = UnitQuaternion::identity();
        let wa = Spin::constant(V3::new(0.0, 0.0, 1.0));
        let qb = UnitQuaternion::identity();
        let wb = Spin::constant(V3::zeros());
        let d = V3::new(0.0, 1.5, 0.0);
        let dv = V3::zeros();
        let tc = p
            .contact_time((&rod, &qa, &wa), (&ball, &qb, &wb), &d, &dv, 10.0)
            .unwrap()
            .expect("the rod sweeps through the ball");
        let dist = |t: f64| {
            let rel = Relative::new(&d, &wa.orientation_after(&qa, t), &qb);
            distance(&rod, &ball, &rel, &DistanceOptions::default(), None).distance
        };
        assert!(dist(tc) >= 0.0 && dist(tc) < 1e-9, "{}", dist(tc));
        let first_negative = (1..100_000)
            .map(|k| k as f64 * 1e-5 * 3.0)
            .find(|&t| dist(t) < 0.0)
            .unwrap();
        assert!(first_negative >= tc && first_negative - tc < 3e-5);
    }
}
