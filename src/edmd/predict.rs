//! The predictor of contacts between bodies that are not two spheres: its
//! accuracy knobs, the solver work it counts, the signed distance at one
//! pose, and the first contact in time of a pair; the steps of that
//! search are in [`super::search`].

use std::cell::Cell;

use super::outcome::{Found, Progress, Rotor, Search, SearchError};
use crate::geometry::{Contact, DistanceOptions, Method, Relative, Shape, WarmStart, distance};

type V3 = nalgebra::Vector3<f64>;

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
pub(super) fn is_fallback(a: &Shape, b: &Shape, method: Method) -> bool {
    match method {
        Method::Gjk | Method::Epa => [a, b].iter().all(|s| {
            matches!(
                s,
                Shape::Sphere(_) | Shape::Ellipsoid(_) | Shape::Superellipsoid(_)
            )
        }),
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
    pub(super) fn count(&self, add: impl FnOnce(&mut SolverWork)) {
        let mut work = self.work.get();
        add(&mut work);
        self.work.set(work);
    }

    /// The work of every search so far.
    pub fn work(&self) -> SolverWork {
        self.work.get()
    }

    /// Keeps the solver state at the contact a search found.
    pub(super) fn set_found(&self, warm: Option<WarmStart>) {
        self.found.set(warm);
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
    ) -> Result<Option<f64>, SearchError> {
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
    ) -> Result<Search, SearchError> {
        let mut stopped = None;
        Ok(
            match self.search_into(
                a,
                b,
                (0.0, 0.0),
                None,
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edmd::motion::FreeTop;
    use crate::edmd::search::{Found, Search};
    use nalgebra::{UnitQuaternion, Vector3};
    type V3 = Vector3<f64>;
    use crate::geometry::Shape;

    fn ellipsoid(a: f64, b: f64, c: f64) -> Shape {
        Shape::Ellipsoid(crate::geometry::Ellipsoid::new(a, b, c).unwrap())
    }

    /// Two spheres given as ellipsoids: the general search finds the
    /// closed-form contact time.
    #[test]
    fn spheres_as_ellipsoids_match_the_closed_form() {
        let p = Predictor::new(PredictorOptions::default());
        let s = ellipsoid(0.5, 0.5, 0.5);
        let q = UnitQuaternion::identity();
        let w = FreeTop::spherical(q, V3::zeros());
        let mut u = crate::test_support::uniform(4);
        for _ in 0..200 {
            let d = V3::new(3.0, u() - 0.5, u() - 0.5);
            let dv = V3::new(-1.0 - u(), 0.3 * (u() - 0.5), 0.3 * (u() - 0.5));
            let expected = crate::geometry::pair::sphere_contact_time(&d, &dv, 1.0);
            let got = p.contact_time((&s, &w), (&s, &w), &d, &dv, 100.0).unwrap();
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
            let (wa, wb) = (
                FreeTop::spherical(qa, unit() * 0.5),
                FreeTop::spherical(qb, unit() * 0.5),
            );
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
                .search((a, &wa), (b, &wb), &d, &dv, None, 2.0, u32::MAX)
                .unwrap();
            let stepwise = Predictor::new(PredictorOptions::default());
            let mut progress = None;
            let got = loop {
                match stepwise
                    .search((a, &wa), (b, &wb), &d, &dv, progress.as_ref(), 2.0, 1)
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
            // Tops of every kind: spherical, symmetric and asymmetric.
            let moments = |k: usize| match k % 3 {
                0 => V3::repeat(0.4),
                1 => V3::new(0.5, 0.5, 0.2),
                _ => V3::new(0.5, 0.3, 0.2),
            };
            let (wa, wb) = (
                FreeTop::new(moments(case), qa, unit() * 2.0),
                FreeTop::new(moments(case / 3), qb, unit() * 2.0),
            );
            let since = (0.3 * (case % 4) as f64, 0.2 * (case % 5) as f64);
            let dir = unit();
            let d = dir * 3.0;
            let dv = -dir + unit() * 0.3;
            let p = Predictor::new(PredictorOptions::default());
            let mut stopped = None;
            let given_earlier = p
                .search_into(
                    (a, &wa),
                    (b, &wb),
                    since,
                    None,
                    &d,
                    &dv,
                    None,
                    10.0,
                    u32::MAX,
                    &mut stopped,
                )
                .unwrap();
            let (qa_now, qb_now) = (wa.orientation_after(since.0), wb.orientation_after(since.1));
            let (wa_now, wb_now) = (
                FreeTop::new(moments(case), qa_now, wa.angular_velocity(&qa_now)),
                FreeTop::new(moments(case / 3), qb_now, wb.angular_velocity(&qb_now)),
            );
            let turned_first = p
                .search((a, &wa_now), (b, &wb_now), &d, &dv, None, 10.0, u32::MAX)
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

    /// A rotating rod sweeping past a sphere at rest: the predicted time is
    /// when the distance first reaches zero, checked by stepping finely.
    #[test]
    fn rotating_rod_hits_where_fine_stepping_says() {
        let p = Predictor::new(PredictorOptions::default());
        let rod = ellipsoid(2.0, 0.2, 0.2);
        let ball = ellipsoid(0.3, 0.3, 0.3);
        let qa = UnitQuaternion::identity();
        let wa = FreeTop::spherical(qa, V3::new(0.0, 0.0, 1.0));
        let qb = UnitQuaternion::identity();
        let wb = FreeTop::spherical(qb, V3::zeros());
        let d = V3::new(0.0, 1.5, 0.0);
        let dv = V3::zeros();
        let tc = p
            .contact_time((&rod, &wa), (&ball, &wb), &d, &dv, 10.0)
            .unwrap()
            .expect("the rod sweeps through the ball");
        let dist = |t: f64| {
            let rel = Relative::new(&d, &wa.orientation_after(t), &qb);
            distance(&rod, &ball, &rel, &DistanceOptions::default(), None).distance
        };
        assert!(dist(tc) >= 0.0 && dist(tc) < 1e-9, "{}", dist(tc));
        let first_negative = (1..100_000)
            .map(|k| k as f64 * 1e-5 * 3.0)
            .find(|&t| dist(t) < 0.0)
            .unwrap();
        assert!(first_negative >= tc && first_negative - tc < 3e-5);
    }

    /// Growing bodies of every kind, turning and moving: the contact found
    /// is where the grown bodies' distance, s(τ) times the unscaled
    /// shapes' distance at the separation over s(τ), first reaches zero,
    /// checked by stepping finely; pairs that stay apart stay apart.
    #[test]
    fn growing_bodies_touch_where_fine_stepping_says() {
        use crate::edmd::search::Growth;
        let shapes = [
            ellipsoid(1.0, 0.5, 0.4),
            Shape::Cuboid(crate::geometry::Cuboid::new(0.6, 0.4, 0.3).unwrap()),
            Shape::Superellipsoid(
                crate::geometry::Superellipsoid::new(0.5, 0.5, 0.7, (4.0, 4.0, 4.0)).unwrap(),
            ),
            ellipsoid(0.5, 0.5, 0.5),
        ];
        let mut u = crate::test_support::uniform(23);
        let mut vector = || V3::new(u() - 0.5, u() - 0.5, u() - 0.5);
        let p = Predictor::new(PredictorOptions::default());
        let (mut met, mut missed) = (0, 0);
        for case in 0..48 {
            let (a, b) = (&shapes[case % 4], &shapes[(case / 4) % 4]);
            let qa = UnitQuaternion::from_scaled_axis(vector() * 6.0);
            let qb = UnitQuaternion::from_scaled_axis(vector() * 6.0);
            let (wa, wb) = (
                FreeTop::spherical(qa, vector() * 2.0),
                FreeTop::spherical(qb, vector() * 2.0),
            );
            let d = vector().normalize() * 1.9;
            let dv = -d * 0.3 + vector() * 0.8;
            // From 0.8 to 1 over the horizon.
            let growth = Growth {
                scale: 0.8,
                rate: 0.1,
            };
            let horizon = 2.0;
            let grown = |t: f64| {
                let s = growth.scale + growth.rate * t;
                let rel = Relative::new(
                    &((d + dv * t) / s),
                    &wa.orientation_after(t),
                    &wb.orientation_after(t),
                );
                s * distance(a, b, &rel, &DistanceOptions::default(), None).distance
            };
            if grown(0.0) <= 0.0 {
                continue;
            }
            let mut stopped = None;
            let found = p
                .search_into(
                    (a, &wa),
                    (b, &wb),
                    (0.0, 0.0),
                    Some(growth),
                    &d,
                    &dv,
                    None,
                    horizon,
                    u32::MAX,
                    &mut stopped,
                )
                .unwrap();
            let step = 2e-5;
            let first_negative = (1..=(horizon / step) as usize)
                .map(|k| k as f64 * step)
                .find(|&t| grown(t) < 0.0);
            match found {
                Found::Contact(tc) => {
                    met += 1;
                    assert!(
                        grown(tc) >= -1e-12 && grown(tc) < 1e-8,
                        "{case}: {}",
                        grown(tc)
                    );
                    let first = first_negative.expect("they overlap past the contact");
                    assert!(
                        first >= tc && first - tc < 2.0 * step,
                        "{case}: {tc} {first}"
                    );
                }
                Found::Apart => {
                    missed += 1;
                    assert_eq!(first_negative, None, "case {case}");
                }
                Found::Stopped(_) => unreachable!("no budget"),
            }
        }
        assert!(met > 10 && missed > 5, "{met} met, {missed} apart");
    }
}
