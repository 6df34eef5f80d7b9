//! Stability: near-singular Newton systems (issue 7). Two superellipsoids
//! with flat faces (exponents 8, 10, 20), face to face with coincident or
//! nearly coincident normals (tilts 0 to 1e-3 rad) at exact distances 1e-9
//! to 1e-2 of the size, built by touching them at their support points
//! along a common normal and moving them apart: there the contact point is
//! nearly undetermined (a whole face touches) and the Newton system nearly
//! singular. Newton–Raphson alone must converge to the exact distance or
//! report failure, never a wrong distance as converged; the full distance
//! kernel (Newton with its fallbacks) must always give the exact distance.

mod common;

use common::{rng, touching};
use hardbody::geometry::implicit::SmoothSurface;
use hardbody::geometry::newton::{NewtonOptions, newton_distance};
use hardbody::geometry::{DistanceOptions, Shape, Superellipsoid, distance};
use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;

#[test]
fn parallel_flat_faces_converge_or_fail_never_lie() {
    let mut report = Vec::new();
    let mut wrong = Vec::new();
    for p in [8.0, 10.0, 20.0] {
        let s = Superellipsoid::new(0.5, 0.5, 0.5, (p, p, p)).unwrap();
        let shape = Shape::Superellipsoid(s);
        let len = 0.5;
        let (mut converged, mut failed) = (0, 0);
        for i in 0..300u64 {
            let mut g = rng(900 + p as u64, i);
            let tilt = if i % 3 == 0 {
                0.0
            } else {
                10f64.powf(-8.0 + 5.0 * g.r#gen::<f64>())
            };
            let axis = Vector3::new(0.0, g.r#gen::<f64>() - 0.5, g.r#gen::<f64>() - 0.5)
                .try_normalize(0.0)
                .unwrap_or(Vector3::y());
            let q = UnitQuaternion::from_scaled_axis(axis * tilt);
            let delta = len * 10f64.powf(-9.0 + 7.0 * g.r#gen::<f64>());
            // Faces along x: the common normal of the two flat faces.
            let rel = touching(&shape, &shape, &q, &Vector3::x(), delta);
            let c = newton_distance(&s, &s, &rel, &NewtonOptions::default(), None);
            if c.is_converged() {
                converged += 1;
                if (c.distance - delta).abs() > 1e-8 * len.max(delta) {
                    wrong.push(format!(
                        "p {p}, tilt {tilt:e}, exact {delta:e}: Newton claimed {:e}",
                        c.distance
                    ));
                }
            } else {
                failed += 1;
            }
            let k = distance(&shape, &shape, &rel, &DistanceOptions::default(), None);
            if (k.distance - delta).abs() > 1e-8 * len.max(delta) {
                wrong.push(format!(
                    "p {p}, tilt {tilt:e}, exact {delta:e}: the kernel gave {:e} ({:?}, {:?})",
                    k.distance, k.status, k.method
                ));
            }
        }
        report.push(format!(
            "p {p}: Newton converged {converged}, reported failure {failed}"
        ));
    }
    eprintln!("{}", report.join("; "));
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // The implicit surface really is flat there (the test is near-singular).
    let s = Superellipsoid::new(0.5, 0.5, 0.5, (20.0, 20.0, 20.0)).unwrap();
    let h = s.implicit(&Vector3::new(0.5, 0.1, 0.1)).hessian;
    assert!(h[(1, 1)].abs() < 1e-6 * h[(0, 0)].abs().max(1.0), "{h}");
}
