//! Property tests (proptest) over random shapes, poses and velocities
//! (issue 7): the signed distance agrees in sign with the overlap test, and
//! a predicted contact time is never later than the first overlap seen by
//! stepping the trajectory finely (translation and free rotation), nor
//! missing when stepping sees one, and the bodies touch there to 1e-9.

mod common;

use common::{KINDS, Kind, random_rotation, random_shape, random_unit, rng};
use hardbody::edmd::motion::FreeTop;
use hardbody::edmd::{Predictor, PredictorOptions};
use hardbody::geometry::{DistanceOptions, Relative, Shape, distance, overlap};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;
use rand::Rng;

type V3 = Vector3<f64>;

fn kind(k: usize) -> Kind {
    KINDS[k % KINDS.len()]
}

/// A random pair, pose and motion from a seed: B at 1–1.6 bounding-radius
/// sums from A, moving roughly towards it, both turning (for odd seeds as
/// spherical tops, for even ones with their own inertia tensors, mostly
/// asymmetric tops).
struct Case {
    a: Shape,
    b: Shape,
    qa: UnitQuaternion<f64>,
    qb: UnitQuaternion<f64>,
    d: V3,
    dv: V3,
    wa: V3,
    wb: V3,
    /// Principal moments (body axes).
    ia: V3,
    ib: V3,
}

fn case(ka: usize, kb: usize, seed: u64, turning: bool) -> Case {
    let mut g = rng(5000 + seed, (ka * 4 + kb) as u64);
    let a = random_shape(kind(ka), &mut g);
    let b = random_shape(kind(kb), &mut g);
    let reach = a.bounding_radius() + b.bounding_radius();
    let dir = random_unit(&mut g);
    let d = dir * reach * (1.0 + 0.6 * g.r#gen::<f64>());
    let dv = -(dir + random_unit(&mut g) * 0.5) * (0.5 + g.r#gen::<f64>());
    let spin = |g: &mut rand_pcg::Pcg64| {
        if turning {
            random_unit(g) * (2.0 * g.r#gen::<f64>())
        } else {
            V3::zeros()
        }
    };
    let moments = |s: &Shape| {
        if seed.is_multiple_of(2) {
            s.inertia_tensor(1.0).diagonal()
        } else {
            V3::repeat(1.0)
        }
    };
    Case {
        ia: moments(&a),
        ib: moments(&b),
        qa: random_rotation(&mut g),
        qb: random_rotation(&mut g),
        wa: spin(&mut g),
        wb: spin(&mut g),
        a,
        b,
        d,
        dv,
    }
}

fn tops(c: &Case) -> (FreeTop, FreeTop) {
    (
        FreeTop::new(c.ia, c.qa, c.wa),
        FreeTop::new(c.ib, c.qb, c.wb),
    )
}

fn pose(c: &Case, t: f64) -> Relative {
    let (sa, sb) = tops(c);
    let (qa, qb) = (sa.orientation_after(t), sb.orientation_after(t));
    Relative::new(&(c.d + c.dv * t), &qa, &qb)
}

/// 400 cases from a fixed seed, so that a run of the suite is repeatable
/// (a random one failed CI on a case no run before had drawn). Explore
/// further with `PROPTEST_RNG_SEED=<n>` and `PROPTEST_CASES=<n>`; a failure
/// found that way becomes a named regression test below.
fn config() -> ProptestConfig {
    let mut config = ProptestConfig::default();
    if std::env::var_os("PROPTEST_RNG_SEED").is_none() {
        config.rng_seed = proptest::test_runner::RngSeed::Fixed(20_261_124);
    }
    if std::env::var_os("PROPTEST_CASES").is_none() {
        config.cases = 400;
    }
    config
}

proptest! {
    #![proptest_config(config())]

    /// sign(distance) = overlap, away from round-off.
    #[test]
    fn distance_and_overlap_agree(ka in 0usize..4, kb in 0usize..4, seed in 0u64..1_000_000, s in 0.3f64..1.2) {
        let c = case(ka, kb, seed, false);
        // Somewhere between deep overlap and well apart.
        let rel = Relative::new(&(c.d * s), &c.qa, &c.qb);
        let k = distance(&c.a, &c.b, &rel, &DistanceOptions::default(), None);
        let o = overlap(&c.a, &c.b, &rel);
        let len = c.a.min_half_extent().min(c.b.min_half_extent());
        prop_assume!(k.distance.abs() > 1e-9 * len);
        prop_assert_eq!(o, k.distance < 0.0, "{} / {}: distance {:e}, overlap {}", c.a, c.b, k.distance, o);
    }

    /// A predicted contact is never after the first overlap seen by fine
    /// stepping, and stepping never sees an overlap the prediction missed.
    #[test]
    fn contact_time_is_never_late(ka in 0usize..4, kb in 0usize..4, seed in 0u64..1_000_000, turning in any::<bool>()) {
        contact_time_check(&case(ka, kb, seed, turning))?;
    }
}

/// The case the property test found (issue 7): an ellipsoid against a
/// cuboid's edge, where GJK stalls within ~1e-7 of the contact (both the
/// distance and the boolean variant) and the distance jumped between +2.5e-8
/// and -1.1e-7, so the contact came out 2e-8 apart. Fixed by the exact
/// cuboid–smooth distance near contact (largest support-plane gap over the
/// cuboid's features).
#[test]
fn ellipsoid_against_cuboid_edge_contact_is_exact() {
    for turning in [false, true] {
        contact_time_check(&case(1, 3, 104646, turning)).unwrap();
    }
}

/// The case CI's random property run found (issue 7): a superellipsoid
/// against a flat ellipsoid, whose contact came out 3.2e-9 short of touching
/// against a tolerance of 1e-9 of the smaller half extent.
#[test]
fn superellipsoid_against_flat_ellipsoid_contact_is_exact() {
    for turning in [false, true] {
        contact_time_check(&case(2, 1, 713104, turning)).unwrap();
    }
}

/// Found by a longer random run (issue 7): a cuboid against a flat turning
/// superellipsoid, where GJK stalled near contact and its normal started the
/// support-gap search beside a stationary point of the gap facing away from
/// B (−2.75 for a pair 6.3e-6 apart): the contact came out 7e-6 early.
#[test]
fn cuboid_against_flat_superellipsoid_contact_is_exact() {
    for turning in [false, true] {
        contact_time_check(&case(3, 2, 824550, turning)).unwrap();
    }
}

fn contact_time_check(c: &Case) -> Result<(), TestCaseError> {
    let predictor = Predictor::new(PredictorOptions::default());
    let (sa, sb) = tops(c);
    let horizon = 4.0;
    let predicted = predictor
        .contact_time((&c.a, &sa), (&c.b, &sb), &c.d, &c.dv, horizon)
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    // Fine stepping with the MC overlap test.
    let steps = 4000;
    let h = horizon / steps as f64;
    let first = (0..=steps)
        .map(|k| k as f64 * h)
        .find(|&t| overlap(&c.a, &c.b, &pose(c, t)));
    match (predicted, first) {
        (Some(t), Some(f)) => prop_assert!(
            t <= f + 1e-9,
            "{} / {}: predicted {} after the overlap seen at {}",
            c.a,
            c.b,
            t,
            f
        ),
        (None, Some(f)) => {
            prop_assert!(false, "{} / {}: missed the overlap seen at {}", c.a, c.b, f)
        }
        _ => {}
    }
    if let Some(t) = predicted {
        // Apart (or touching) at the contact returned.
        let d = distance(&c.a, &c.b, &pose(c, t), &DistanceOptions::default(), None).distance;
        let len = c.a.min_half_extent().min(c.b.min_half_extent());
        prop_assert!(
            d >= -1e-9 * len && d <= 1e-9 * len,
            "{} / {}: distance {:e} at the contact",
            c.a,
            c.b,
            d
        );
    }
    Ok(())
}
