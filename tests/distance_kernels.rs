//! Every distance kernel against exact distances: bodies placed touching at
//! their support points along a random common normal, then moved apart by a
//! known δ (1e-10 to 1 of the size), so the distance is exactly δ and the
//! normal is the construction's. Slight overlaps (δ < 0) give negative
//! distances: exactly δ where the method defines the distance along the
//! common normal (Newton's β < 0 solution, OCSI), and an overlap (d < 0) for
//! the minimum-translation methods (SAT depth, EPA). Oriented bounding boxes
//! hold their bodies.

mod common;

use common::*;
use hardbody::geometry::pair::distance_lower_bound;
use hardbody::geometry::{DistanceOptions, Method, Obb, Shape, distance, overlap};
use nalgebra::Vector3;
use rand::Rng;
use rayon::prelude::*;

fn check(ka: Kind, kb: Kind, tag: u64) {
    let opts = DistanceOptions::default();
    let bad: Vec<String> = (0..4000u64)
        .into_par_iter()
        .filter_map(|i| {
            let mut r = rng(tag, i);
            let a = random_shape(ka, &mut r);
            let b = random_shape(kb, &mut r);
            let q = random_rotation(&mut r);
            let n = random_unit(&mut r);
            let len = a.min_half_extent().min(b.min_half_extent());
            let apart = i % 4 != 0;
            let delta = if apart {
                len * 10f64.powf(-10.0 + 10.0 * r.r#gen::<f64>())
            } else {
                -len * 10f64.powf(-8.0 + 5.0 * r.r#gen::<f64>())
            };
            let rel = touching(&a, &b, &q, &n, delta);
            let c = distance(&a, &b, &rel, &opts, None);
            let mut why = Vec::new();
            // The cheap lower bound the dynamics steps with never exceeds the
            // exact distance.
            // Overlapping, it must not be positive (its negative values are
            // not a depth).
            let (bound, _) = distance_lower_bound(&a, &b, &rel);
            if bound > delta.max(0.0) + 1e-12 * len {
                why.push(format!(
                    "lower bound {bound:e} above the distance {delta:e}"
                ));
            }
            if apart {
                if !c.is_converged() || (c.distance - delta).abs() > 1e-9 * len.max(delta) {
                    why.push(format!(
                        "distance {:e} ({:?}, {:?}) for exact {delta:e}",
                        c.distance, c.status, c.method
                    ));
                }
                let gap = c.point_b - c.point_a;
                if ((gap.norm() - c.distance).abs() > 1e-9 * len.max(delta))
                    || (c.normal.dot(&gap) - c.distance).abs() > 1e-9 * len.max(delta)
                {
                    why.push(format!(
                        "points {:?} / {:?} and normal {:?} do not span the distance",
                        c.point_a, c.point_b, c.normal
                    ));
                }
                // The normal is the construction's wherever it is unique
                // (the support point along n is a single point for smooth
                // bodies; cuboid contacts may touch along an edge or face).
                if delta > 1e-6 * len
                    && !matches!(c.method, Method::Gjk)
                    && (c.normal - n).norm() > 1e-6
                {
                    why.push(format!("normal {:?}, construction {:?}", c.normal, n));
                }
            } else {
                let exact = matches!(c.method, Method::Newton | Method::Ocsi | Method::Analytic);
                if c.distance >= 0.0 || (exact && (c.distance - delta).abs() > 1e-9 * len) {
                    why.push(format!(
                        "overlap by {delta:e}: distance {:e} ({:?}, {:?})",
                        c.distance, c.status, c.method
                    ));
                }
                if !overlap(&a, &b, &rel) {
                    why.push("overlap kernel says apart".into());
                }
            }
            (!why.is_empty()).then(|| format!("case {i}: {a} / {b}: {}", why.join("; ")))
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{ka:?}-{kb:?}: {} failures, first: {:#?}",
        bad.len(),
        &bad[..bad.len().min(6)]
    );
}

#[test]
fn every_pair_distance_is_exact() {
    for (ia, &ka) in KINDS.iter().enumerate() {
        for (ib, &kb) in KINDS[ia..].iter().enumerate() {
            check(ka, kb, 1000 + 10 * ia as u64 + ib as u64);
            check(kb, ka, 2000 + 10 * ia as u64 + ib as u64);
        }
    }
}

/// The tight OBB holds the body: every support point lies inside it, and a
/// pair that overlaps has overlapping OBBs (what neighbour lists rely on).
#[test]
fn oriented_bounding_boxes_hold_their_bodies() {
    for (ia, &ka) in KINDS.iter().enumerate() {
        for &kb in &KINDS[ia..] {
            for i in 0..3000u64 {
                let mut r = rng(3000, i);
                let a = random_shape(ka, &mut r);
                let b = random_shape(kb, &mut r);
                let (qa, qb) = (random_rotation(&mut r), random_rotation(&mut r));
                let ra = Vector3::new(r.r#gen(), r.r#gen(), r.r#gen());
                let rb = ra
                    + random_unit(&mut r)
                        * (a.bounding_radius() + b.bounding_radius())
                        * r.r#gen::<f64>();
                let oa = Obb::of_shape(&a, ra, qa.to_rotation_matrix().into_inner(), 0.0);
                let ob = Obb::of_shape(&b, rb, qb.to_rotation_matrix().into_inner(), 0.0);
                let rel = hardbody::geometry::Relative::new(&(rb - ra), &qa, &qb);
                if overlap(&a, &b, &rel) {
                    assert!(
                        oa.overlaps(&ob) && ob.overlaps(&oa),
                        "{a} / {b}: bodies overlap, OBBs do not"
                    );
                }
                let d = random_unit(&mut r);
                let p = a.support(&d);
                let h = a.obb_half_extents();
                assert!(
                    (0..3).all(|k| p[k].abs() <= h[k] * (1.0 + 1e-12)),
                    "{a}: support point outside its OBB"
                );
                assert!(
                    p.norm() <= a.bounding_radius() * (1.0 + 1e-12),
                    "{a}: support point outside its bounding sphere"
                );
            }
        }
    }
}

#[test]
fn shapes_parse_and_report_bad_input_by_name() {
    let bad = [
        ("Ellipsoid(a: 1.0, b: 0.0, c: 1.0)", "b"),
        (
            "Superellipsoid(a: 1.0, b: 1.0, c: 1.0, exponents: (2.0, 1.0, 2.0))",
            "exponent m",
        ),
        ("Cuboid(a: 1.0, b: 1.0)", "c"),
        ("Sphere(r: 1.0)", "r"),
    ];
    for (text, needle) in bad {
        let err = text.parse::<Shape>().unwrap_err().to_string();
        assert!(err.contains(needle), "{text}: {err}");
    }
}

/// Two cubes whose edges, 4×10⁻⁴ rad from parallel, cross by a hair as
/// the pair moves on (a pose from a 1000-cube jam near βPV/N = 6×10⁶):
/// the distance follows the motion smoothly through contact, falling at
/// the closing speed (about 2.6) to rounding of the size. Measured along
/// the edges' cross axis it jumped between +3.5e-12 and −5.7e-12 from one
/// 1e-13 step to the next, and the contact search narrowed onto the noise.
#[test]
fn crossing_edges_near_parallel_are_followed_smoothly_through_contact() {
    use hardbody::geometry::Relative;
    use nalgebra::{Quaternion, UnitQuaternion};
    let h = 0.7983203181215585;
    let cube: Shape = format!("Cuboid(a: {h}, b: {h}, c: {h})").parse().unwrap();
    let q = |x: f64, y: f64, z: f64, w: f64| {
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
    };
    let qa = q(
        0.12368484830011267,
        0.7328377759432454,
        -0.6003379238091197,
        0.29537303480191185,
    );
    let qb = q(
        -0.4308796494974274,
        0.6057089307362609,
        -0.6332634871443851,
        -0.2154919365661809,
    );
    let d = Vector3::new(0.17273340424221928, 1.6585897630615607, 0.6262396643374784);
    let dv = Vector3::new(0.9356789144281178, -0.9362004638202506, -1.3788976682229468)
        - Vector3::new(1.2658546432676054, 0.3648455745782013, -0.8723221182909074);
    let (wa, wb) = (
        Vector3::new(-2.4747614959824182, 0.8232245690816375, -1.0322908746072001),
        Vector3::new(1.071928459567773, -1.2207995183545668, -1.4094557862569828),
    );
    let at = |t: f64| {
        let rel = Relative::new(
            &(d + dv * t),
            &(UnitQuaternion::from_scaled_axis(wa * t) * qa),
            &(UnitQuaternion::from_scaled_axis(wb * t) * qb),
        );
        distance(&cube, &cube, &rel, &DistanceOptions::default(), None).distance
    };
    let times: Vec<f64> = (0..=100).map(|k| -8e-13 + 1e-14 * k as f64).collect();
    let distances: Vec<f64> = times.iter().map(|&t| at(t)).collect();
    assert!(distances[0] > 0.0 && distances[100] < 0.0, "{distances:?}");
    for (k, pair) in distances.windows(2).enumerate() {
        let fall = pair[0] - pair[1];
        assert!(
            (fall - 2.6e-14).abs() < 1e-14,
            "from t = {:e} to the next 1e-14: {:e} to {:e}",
            times[k],
            pair[0],
            pair[1]
        );
    }
}

/// Two cubes 5.5e-14 apart face to face, their orientations equal to
/// 4e-11 (a pose from 1000 cubes jammed at 1e-2, near βPV/N = 3×10¹¹, at a
/// collision that found its predicted contact missed). With the jam's
/// tolerances the distance is the gap of the faces (the closest features,
/// confirmed by a separating plane) to rounding, as the separating axes
/// say; GJK at its default
/// tolerance (1e-12 of the size) stopped at 8.5e-13, ten times the jam's
/// contact tolerance.
#[test]
fn nearly_aligned_cubes_face_to_face_are_measured_to_the_jams_tolerance() {
    use hardbody::edmd::PredictorOptions;
    use hardbody::edmd::jam::jam_predictor;
    use hardbody::geometry::Relative;
    use nalgebra::{Quaternion, UnitQuaternion};
    let h = 0.7940711496983947;
    let cube: Shape = format!("Cuboid(a: {h}, b: {h}, c: {h})").parse().unwrap();
    let q =
        |x: f64, y: f64, z: f64, w: f64| UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z));
    let qa = q(
        -0.8732334728556549,
        -0.3863746778955094,
        -0.2968966784051221,
        0.0055020466736741495,
    );
    let qb = q(
        0.8732334728557654,
        0.3863746778899644,
        0.29689667841233475,
        -0.0055020466563212985,
    );
    let d = Vector3::new(
        -0.7692151240011715,
        -1.0040429638795803,
        -0.8308346412226919,
    ) / 9.523809523810539e-1;
    let rel = Relative::new(&d, &qa, &qb);
    let options = jam_predictor(PredictorOptions::default()).distance;
    let c = distance(&cube, &cube, &rel, &options, None);
    assert!(
        (c.distance - 5.4845e-14).abs() < 1e-15,
        "{:e} by {:?}",
        c.distance,
        c.method
    );
    // The separating axes agree, to rounding.
    let (bound, _) = distance_lower_bound(&cube, &cube, &rel);
    assert!(
        (bound - c.distance).abs() < 1e-15,
        "{bound:e}, {:e}",
        c.distance
    );
}

/// Two superballs of exponent 12 nearly face to face (their faces 1e-6
/// apart in angle), from a jam of 1000 that found a predicted contact
/// missed: Newton had the distance to the bit, but the place of the
/// contact along the flat faces only to round-off over their small
/// curvature (1e-13), above the jam's tolerance (1e-14); it ran to its cap
/// and GJK, stopped short on the flat faces, called the pair 3e-10 apart
/// while it overlapped by 4e-11. Moved 1e-9 apart along the normal, the
/// distance is converged and bracketed: the support planes along its
/// normal are as far apart as its contact points, to rounding.
#[test]
fn superballs_of_high_exponent_face_to_face_are_measured_to_the_jams_tolerance() {
    use hardbody::edmd::PredictorOptions;
    use hardbody::edmd::jam::jam_predictor;
    use hardbody::geometry::{Relative, Status};
    let ball = superball_of_exponent_12(0.8000679111221226);
    let q = quaternion;
    let qa = q(
        0.5048570321315435,
        -0.4006720050578935,
        0.4416554456012484,
        0.6241168070489527,
    );
    let qb = q(
        -0.4461867803055936,
        -0.11429376199449952,
        -0.8507269780808999,
        0.25321512951443603,
    );
    let d = Vector3::new(
        -0.6111373317096126,
        -0.11940193085376537,
        -1.756838291362344,
    );
    let options = jam_predictor(PredictorOptions::default()).distance;
    let touching = Relative::new(&d, &qa, &qb);
    let overlap = distance(&ball, &ball, &touching, &options, None);
    assert!(
        matches!(overlap.status, Status::Converged { .. }),
        "{overlap:?}"
    );
    assert!(
        (overlap.distance + 4.36e-11).abs() < 1e-12,
        "{:e}",
        overlap.distance
    );
    let apart = Relative {
        translation: touching.translation + overlap.normal * 1e-9,
        ..touching
    };
    let c = distance(&ball, &ball, &apart, &options, None);
    assert!(matches!(c.status, Status::Converged { .. }), "{c:?}");
    assert!(
        (c.distance - (1e-9 + overlap.distance)).abs() < 1e-14,
        "{:e}",
        c.distance
    );
    assert_bracketed_by_support_planes(&ball, &apart, &c);
}

/// Two superballs of exponent 12 face to face, aligned to 2e-8, touching
/// (from a jam of 1000 that found a predicted contact missed near
/// βPV/N = 10⁷). They touch where the faces are flat to 1e-16 of the
/// size: Newton, started at the solution, wanders along the faces and
/// comes back in hundreds of steps, and at the default cap GJK, stalled on
/// the flat faces, called the pair 4.6e-10 apart. With the jam's
/// predictor the distance converges to the contact, and the support planes
/// along its normal bracket it.
#[test]
fn superballs_touching_on_aligned_flat_faces_are_measured_to_the_jams_tolerance() {
    let pose = FlatFacePose {
        h: 0.8107822918593783,
        qa: [
            -0.1624867279295282,
            0.19019123885695988,
            0.33634459004903644,
            0.907908405431713,
        ],
        qb: [
            -0.2739258710504157,
            -0.21441505098437277,
            -0.9355935314357632,
            -0.06046111987217579,
        ],
        d: [0.028012651999644915, 0.6957612400952845, 1.7065604759636543],
        point_a: [0.02167427711518242, -1.9578214445729537e-5],
        point_b: [
            -0.719192913036526,
            -0.12955522042162343,
            -0.7926847518524989,
        ],
        alpha: 1.10115776745411,
    };
    for distance in jam_distances(&pose) {
        assert!(distance.abs() < 1e-13, "{distance:e}");
    }
}

/// Exponent-12 superballs at the collision where a jam failed near
/// βPV/N = 1.8e7: a rounded edge of B lies along the flat face of A,
/// aligned to 1e-7. The distance is fixed to round-off, but the contact's
/// place along the edge is not: both bodies are flat along it. Newton's
/// steps there wander by 1e-9 of the size and change the gap by 1e-26;
/// they must count as settled, not run Newton to its cap and hand the
/// pair to GJK (which called it 4.7e-10 apart).
#[test]
fn superballs_touching_face_to_rim_are_measured_to_the_jams_tolerance() {
    let pose = FlatFacePose {
        h: 0.810781605930303,
        qa: [
            -0.16245783001933567,
            0.19018513699987769,
            0.3363110585090348,
            0.9079272763026117,
        ],
        qb: [
            -0.2740770063771336,
            -0.21436874899184938,
            -0.9355534330880928,
            -0.06056077829834772,
        ],
        d: [0.028328661138299495, 0.6955356179049941, 1.7067439963665394],
        point_a: [0.006206847624639159, -0.01628233124522564],
        point_b: [
            -0.7192452898667582,
            -0.10732922991093401,
            -0.7926659018452058,
        ],
        alpha: 1.1012350474780224,
    };
    for distance in jam_distances(&pose) {
        assert!((distance + 8.374e-13).abs() < 1e-15, "{distance:e}");
    }
}

/// Two exponent-12 superballs of half-width `h` at a jam's collision: B
/// at `d` from A, orientations `qa`, `qb` (vector part, then scalar), and
/// the collision's warm start (A's point on its face z = h, B's point in
/// B's frame, α).
struct FlatFacePose {
    h: f64,
    qa: [f64; 4],
    qb: [f64; 4],
    d: [f64; 3],
    point_a: [f64; 2],
    point_b: [f64; 3],
    alpha: f64,
}

/// The jam predictor's distances of `pose`, from its warm start and cold:
/// each converged and bracketed by the support planes.
fn jam_distances(pose: &FlatFacePose) -> [f64; 2] {
    use hardbody::edmd::PredictorOptions;
    use hardbody::edmd::jam::jam_predictor;
    use hardbody::geometry::contact::WarmStart;
    use hardbody::geometry::{Relative, Status};
    let ball = superball_of_exponent_12(pose.h);
    let [x, y, z, w] = pose.qa;
    let qa = quaternion(x, y, z, w);
    let [x, y, z, w] = pose.qb;
    let qb = quaternion(x, y, z, w);
    let rel = Relative::new(&Vector3::from(pose.d), &qa, &qb);
    let warm = WarmStart {
        point_a: Vector3::new(pose.point_a[0], pose.point_a[1], pose.h),
        point_b: Vector3::from(pose.point_b),
        alpha: pose.alpha,
    };
    let options = jam_predictor(PredictorOptions::default()).distance;
    [Some(&warm), None].map(|start| {
        let c = distance(&ball, &ball, &rel, &options, start);
        assert!(matches!(c.status, Status::Converged { .. }), "{c:?}");
        assert_bracketed_by_support_planes(&ball, &rel, &c);
        c.distance
    })
}

/// A superball of exponent 12 and half-width `h`.
fn superball_of_exponent_12(h: f64) -> Shape {
    format!("Superellipsoid(a: {h}, b: {h}, c: {h}, exponents: (12.0, 12.0, 12.0))")
        .parse()
        .unwrap()
}

/// The quaternion with vector part (x, y, z) and scalar part w.
fn quaternion(x: f64, y: f64, z: f64, w: f64) -> nalgebra::UnitQuaternion<f64> {
    nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, x, y, z))
}

/// `c`, the distance of two `ball`s placed by `rel`, lies within 1e-14
/// above the gap of the support planes along its normal (a lower bound on
/// the distance along any direction; the contact points, on the surfaces,
/// bound it from above).
fn assert_bracketed_by_support_planes(
    ball: &Shape,
    rel: &hardbody::geometry::Relative,
    c: &hardbody::geometry::Contact,
) {
    let n = c.normal;
    let support_gap =
        n.dot(&(rel.b_to_a(&ball.support(&(rel.rotation.transpose() * -n))) - ball.support(&n)));
    assert!(
        support_gap <= c.distance + 1e-15 && c.distance - support_gap < 1e-14,
        "support planes {support_gap:e} apart, contact points {:e}",
        c.distance
    );
}
