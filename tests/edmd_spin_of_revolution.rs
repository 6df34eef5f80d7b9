//! The spin of a body of revolution about its own axis, which no
//! collision changes (every normal of such a body meets its axis): it is
//! no degree of freedom of the fluid. The dynamics starts bodies without
//! it; bodies given such a spin keep it, read the temperature of the rest
//! and the same pressure; and the degrees of freedom that are exchanged
//! share the kinetic energy equally.

mod common;

use common::compressed_state;
use hardbody::edmd::{Dynamics, DynamicsOptions};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use statrs::statistics::Statistics;

type V3 = Vector3<f64>;

const PROLATE: &str = "Ellipsoid(a: 0.5, b: 0.5, c: 1.0)";
const ROD: &str = "Spherocylinder(radius: 0.5, length: 1.0)";

/// The lab direction of body axis z of each body.
fn axes(md: &Dynamics) -> Vec<V3> {
    md.particles()
        .iter()
        .map(|p| p.orientation * V3::z())
        .collect()
}

/// βP from the collision virial over `blocks` blocks of t = 1 after t = 2:
/// the mean and its error.
fn pressure(md: &mut Dynamics, blocks: usize) -> (f64, f64) {
    md.run_until(md.time() + 2.0).unwrap();
    md.sample();
    let samples: Vec<f64> = (0..blocks)
        .map(|_| {
            md.run_until(md.time() + 1.0).unwrap();
            md.sample().pressure.unwrap()
        })
        .collect();
    (
        samples.iter().mean(),
        samples.iter().std_dev() / (blocks as f64).sqrt(),
    )
}

/// Spheroids (as spherical tops and with their own inertia) and
/// spherocylinders: the dynamics starts them without spin about their
/// axes. Given a spin of 5 about its axis on top of that start, each body
/// keeps it to 1e-9 through the collisions while the rest of its spin is
/// exchanged; the temperature read is the start's to 1e-12 at the end,
/// though the kinetic energy is more than half as large again; and the
/// pressure agrees with the run without the spins within three errors.
/// (The spin does move the axes, as a gyroscope's: the two runs follow
/// different trajectories.)
#[test]
fn a_spin_about_the_axis_is_kept_and_not_counted() {
    for (shape, true_inertia) in [(PROLATE, false), (PROLATE, true), (ROD, true)] {
        let system = compressed_state(&[shape], 5, 0.45, 3);
        let options = DynamicsOptions {
            true_inertia,
            ..DynamicsOptions::default()
        };
        let mut rng = Pcg64::seed_from_u64(4);
        let mut plain = Dynamics::from_state(&system, &options, &mut rng).unwrap();
        for ((_, w), u) in plain.velocities().iter().zip(axes(&plain)) {
            assert!(w.dot(&u).abs() < 1e-12 * w.norm().max(1.0), "{shape}");
        }
        let spun_velocities: Vec<(V3, V3)> = (plain.velocities().iter())
            .zip(axes(&plain))
            .map(|(&(v, w), u)| (v, w + u * 5.0))
            .collect();
        let axial: Vec<f64> = (spun_velocities.iter().zip(axes(&plain)))
            .map(|((_, w), u)| w.dot(&u))
            .collect();
        let mut spun = Dynamics::from_parts(&system, &spun_velocities, &options, 0.0, 0).unwrap();
        assert!(
            spun.kinetic_energy() > 1.5 * plain.kinetic_energy(),
            "{shape}"
        );
        let kt = plain.temperature();
        assert!((kt - 1.0).abs() < 1e-12, "{shape}: {kt}");
        let (p_plain, e_plain) = pressure(&mut plain, 10);
        let (p_spun, e_spun) = pressure(&mut spun, 10);
        assert!(spun.collisions() > 10_000, "{shape}: {}", spun.collisions());
        assert!(
            (spun.temperature() - kt).abs() < 1e-12,
            "{shape}: {}",
            spun.temperature()
        );
        let now = spun.velocities();
        for ((w, u), a) in now.iter().map(|(_, w)| w).zip(axes(&spun)).zip(&axial) {
            assert!(
                (w.dot(&u) - a).abs() < 1e-9,
                "{shape}: {} against {a}",
                w.dot(&u)
            );
        }
        let exchanged = (now.iter().zip(&spun_velocities))
            .map(|((_, w), (_, w0))| (w - w0).norm())
            .fold(0.0, f64::max);
        assert!(exchanged > 0.1, "{shape}: no spin exchanged at all");
        eprintln!(
            "{shape}: betaP {p_plain:.4} ± {e_plain:.4}, with spins {p_spun:.4} ± {e_spun:.4}"
        );
        assert!(
            (p_plain - p_spun).abs() < 3.0 * e_plain.hypot(e_spun),
            "{shape}: betaP {p_plain} ± {e_plain} against {p_spun} ± {e_spun}"
        );
    }
}

/// 216 spherocylinders (their own inertia) and 216 spheroids (spherical
/// tops) at φ = 0.4 after t = 5: the kinetic energy of translation per
/// degree of freedom and that of rotation per exchanged degree of freedom
/// (two per body) agree within three errors of their block means, and
/// their weighted mean is the temperature the dynamics reads.
#[test]
fn the_exchanged_degrees_of_freedom_share_the_energy() {
    for (shape, true_inertia) in [(ROD, true), (PROLATE, false)] {
        let system = compressed_state(&[shape], 6, 0.4, 8);
        let n = system.len() as f64;
        let options = DynamicsOptions {
            true_inertia,
            ..DynamicsOptions::default()
        };
        let mut rng = Pcg64::seed_from_u64(9);
        let mut md = Dynamics::from_state(&system, &options, &mut rng).unwrap();
        assert_eq!(md.degrees_of_freedom(), 3.0 * n - 3.0 + 2.0 * n, "{shape}");
        md.run_until(5.0).unwrap();
        let (mut translation, mut rotation) = (Vec::new(), Vec::new());
        for k in 1..=40 {
            md.run_until(5.0 + 0.5 * k as f64).unwrap();
            let trans = md.translational_kinetic_energy();
            translation.push(trans / (1.5 * n - 1.5));
            rotation.push((md.kinetic_energy() - trans) / n);
        }
        let error = |x: &[f64]| x.iter().std_dev() / (x.len() as f64).sqrt();
        let (t, r) = (translation.iter().mean(), rotation.iter().mean());
        let combined = error(&translation).hypot(error(&rotation));
        eprintln!("{shape}: kT by translation {t:.4}, by rotation {r:.4} ± {combined:.4}");
        assert!(
            (t - r).abs() < 3.0 * combined,
            "{shape}: {t} against {r} ± {combined}"
        );
        let kt = md.temperature();
        let last = (translation.last().unwrap() * (3.0 * n - 3.0)
            + rotation.last().unwrap() * 2.0 * n)
            / (5.0 * n - 3.0);
        assert!((kt - last).abs() < 1e-12 * kt, "{shape}: {kt} {last}");
    }
}
