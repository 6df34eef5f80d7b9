//! Hard spherocylinders: compressed to a dense isotropic fluid and swept
//! there by Monte Carlo, no pair of the final state overlaps by an
//! independent test (GJK on the support mappings, run to a generous cap),
//! and the fluid of short rods stays isotropic; three routes to its
//! equation of state agree (the scale distribution, the dynamics'
//! collision virial, NPT).

mod common;

use common::{compressed_state, gjk_oracle};
use hardbody::analysis::order::nematic_order;
use hardbody::geometry::Relative;
use hardbody::mc::moves::{Counts, Ensemble, MoveSizes, sweep};
use hardbody::mc::tuning::Tuner;

use rand::SeedableRng;
use rand_pcg::Pcg64;

#[test]
fn a_dense_fluid_of_spherocylinders_stays_overlap_free_and_isotropic() {
    let rod = "Spherocylinder(radius: 0.5, length: 1.0)";
    let mut system = compressed_state(&[rod], 6, 0.40, 5);
    let mut rng = Pcg64::seed_from_u64(6);
    let mut sizes = MoveSizes {
        translate: 0.1,
        rotate: 0.1,
        volume: 0.0,
        shear: 0.0,
    };
    let tuner = Tuner {
        target: 0.3,
        max_translate: 1.0,
    };
    let mut accepted = Counts::default();
    for s in 0..1500 {
        let counts = sweep(&mut system, &sizes, &Ensemble::Nvt, &mut rng);
        accepted += counts;
        if s < 500 && s % 50 == 49 {
            tuner.update(&mut sizes, &accepted);
            accepted = Counts::default();
        }
    }
    assert!(accepted.translate.rate() > 0.1, "{accepted:?}");
    assert!(accepted.rotate.rate() > 0.1, "{accepted:?}");
    let (box_, species, particles) = (system.periodic_box(), system.species(), system.particles());
    let mut pairs = 0;
    for (i, a) in particles.iter().enumerate() {
        for b in &particles[i + 1..] {
            let d = box_.minimum_image(&(b.position - a.position));
            let rel = Relative::new(&d, &a.orientation, &b.orientation);
            let (sa, sb) = (
                &species[a.species as usize].shape,
                &species[b.species as usize].shape,
            );
            assert!(!gjk_oracle(sa, sb, &rel), "bodies overlap at {d}");
            pairs += 1;
        }
    }
    assert_eq!(pairs, 216 * 215 / 2);
    // Rods of aspect 2 at φ = 0.4 are far below their isotropic–nematic
    // transition (none below an aspect of about 3.7): S₂ is a finite-size
    // remnant, O(N^-1/2).
    let axes: Vec<_> = (particles.iter())
        .map(|p| p.orientation * nalgebra::Vector3::z())
        .collect();
    let s2 = nematic_order(axes).unwrap();
    assert!(s2 < 0.2, "S2 = {s2}");
}

/// Runs the stages `stages` on 128 rods (aspect 3: radius 0.5, length 2)
/// and returns, for each (stage index, observable) of `wanted`, its
/// average over two replicas: mean, error, whether both equilibrated.
fn rods_averages(seed: u64, stages: &str, wanted: &[(usize, &str)]) -> Vec<(f64, f64, bool)> {
    let scene = |replica: u64| {
        format!(
            r#"Scene(
    seed: {},
    box: (16.0, 16.0, 16.0),
    species: [Species(name: "rod", shape: Spherocylinder(radius: 0.5, length: 2.0), count: 128)],
    stages: [{stages}],
    log: Log(path: "unused.mcap", stats_every: 50, frames_every: 1000000),
)"#,
            seed + replica
        )
    };
    common::replica_averages("rods", scene, wanted)
}

/// Three routes to the isotropic fluid's equation of state of rods of
/// aspect 3 at φ = 0.30: the scale-distribution pressure of NVT sweeps,
/// the collision virial of the dynamics from the same states, and the
/// density NPT sweeps settle at under that pressure, agree within three
/// combined errors; the pressure lies above the second-virial value
/// 1 + B₂ρ (B₂ by Onsager's closed form; the further virial coefficients
/// of a convex body's fluid are positive at this density).
#[test]
fn three_routes_to_the_rods_pressure_agree() {
    let phi = 0.30;
    let start =
        format!("Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: 4000)");
    let nvt = format!(
        "{start}, MonteCarlo(ensemble: Nvt, sweeps: 6000), Dynamics(duration: 20.0, stats_every: 0.25, true_inertia: false)"
    );
    let routes = rods_averages(40, &nvt, &[(2, "pressure"), (3, "pressure")]);
    let [
        (pressure, pressure_error, settled),
        (virial, virial_error, dynamics_settled),
    ] = routes[..]
    else {
        unreachable!("two routes asked for")
    };
    assert!(settled && dynamics_settled, "not equilibrated");
    assert!(
        (virial - pressure).abs() < 3.0 * virial_error.hypot(pressure_error),
        "scale distribution {pressure} ± {pressure_error}, collision virial {virial} ± {virial_error}"
    );
    let (density, density_error, settled) = rods_averages(
        50,
        &format!("{start}, MonteCarlo(ensemble: Npt(pressure: {pressure}), sweeps: 20000)"),
        &[(2, "packing_fraction")],
    )[0];
    assert!(settled, "NPT not equilibrated");
    // The NPT density's error carries the pressure's through the
    // compressibility: dφ/dβP from the two ends of a short secant.
    let (r, l) = (0.5_f64, 2.0_f64);
    let volume = std::f64::consts::PI * r * r * (l + 4.0 / 3.0 * r);
    let b2 = (32.0 * std::f64::consts::PI * r.powi(3) / 3.0
        + 8.0 * std::f64::consts::PI * l * r * r
        + std::f64::consts::PI * l * l * r)
        / 2.0;
    let rho = phi / volume;
    let z = pressure / rho;
    assert!(
        z > 1.0 + b2 * rho,
        "βP/ρ = {z} at φ = {phi}, 1 + B₂ρ = {}",
        1.0 + b2 * rho
    );
    let slope = phi / pressure; // an upper bound on dφ/dβP of a fluid whose Z grows with φ
    let combined = (density_error.powi(2) + (slope * pressure_error).powi(2)).sqrt();
    assert!(
        (density - phi).abs() < 3.0 * combined,
        "NVT βP = {pressure} ± {pressure_error} at φ = {phi}; NPT at it: φ = {density} ± {density_error}"
    );
}
