//! Polydisperse hard spheres in Monte Carlo: every body's own size
//! honoured by the overlap tests (against brute force), and the pressure
//! against the Boublik–Mansoori–Carnahan–Starling–Leland equation of state.

use std::f64::consts::PI;

use hardbody::mc::compress::{CompressOptions, compress};
use hardbody::mc::moves::{Ensemble, MoveSizes, sweep};
use hardbody::mc::sdf::Sdf;
use hardbody::space::PeriodicBox;
use hardbody::state::sizes::SizeDistribution;
use hardbody::state::start::random_insertion_sized;
use hardbody::state::{Particle, Species, StateError, System};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use statrs::statistics::Statistics;

fn spheres() -> Vec<Species> {
    vec![Species {
        name: "sphere".into(),
        shape: "Sphere(radius: 0.5)".parse().unwrap(),
        rotation: false,
    }]
}

/// βP of additive hard spheres of diameters σᵢ at number density ρ by
/// Boublik–Mansoori–Carnahan–Starling–Leland (Mansoori, Carnahan,
/// Starling and Leland, J. Chem. Phys. 54, 1523 (1971); Boublík, J. Chem.
/// Phys. 53, 471 (1970)):
/// with ξₖ = (π/6) ρ ⟨σᵏ⟩,
/// βP = (6/π) [ξ₀/(1 − ξ₃) + 3ξ₁ξ₂/(1 − ξ₃)² + (3 − ξ₃) ξ₂³/(1 − ξ₃)³].
fn bmcsl_pressure(rho: f64, diameters: &[f64]) -> f64 {
    let n = diameters.len() as f64;
    let xi = |k: i32| PI / 6.0 * rho * diameters.iter().map(|s| s.powi(k)).sum::<f64>() / n;
    let (x0, x1, x2, x3) = (xi(0), xi(1), xi(2), xi(3));
    let e = 1.0 - x3;
    6.0 / PI * (x0 / e + 3.0 * x1 * x2 / (e * e) + (3.0 - x3) * x2.powi(3) / e.powi(3))
}

/// For one size it is Carnahan–Starling, βPσ³ = ρσ³(1 + η + η² − η³)/(1 − η)³.
#[test]
fn bmcsl_of_one_size_is_carnahan_starling() {
    let phi: f64 = 0.4;
    let rho = 6.0 * phi / PI;
    let cs = rho * (1.0 + phi + phi * phi - phi.powi(3)) / (1.0 - phi).powi(3);
    assert!((bmcsl_pressure(rho, &[1.0; 10]) - cs).abs() < 1e-12 * cs);
}

/// Each body's own radius decides: the cells, the lists and the all-pairs
/// check agree with brute force over a random polydisperse state and after
/// sweeps, and a pair that only the larger size would make touch is told
/// apart from one that does.
#[test]
fn each_body_overlaps_at_its_own_size() {
    let box_ = PeriodicBox::new(Vector3::repeat(6.0)).unwrap();
    let at = |x: f64| Particle {
        position: Vector3::new(x, 0.0, 0.0),
        orientation: UnitQuaternion::identity(),
        species: 0,
    };
    // Centres 1.0 apart: sizes 0.9 and 1.2 make radii 0.45 and 0.6.
    let pair = vec![at(0.0), at(1.0)];
    assert!(System::with_sizes(box_, spheres(), pair.clone(), vec![0.9, 1.05]).is_ok());
    assert_eq!(
        System::with_sizes(box_, spheres(), pair.clone(), vec![0.9, 1.2]).unwrap_err(),
        StateError::Overlap(0, 1)
    );
    assert!(matches!(
        System::with_sizes(box_, spheres(), pair.clone(), vec![1.0]),
        Err(StateError::SizesCount {
            sizes: 1,
            particles: 2
        })
    ));
    assert!(matches!(
        System::with_sizes(box_, spheres(), pair, vec![1.0, -0.5]),
        Err(StateError::BadSize(1, _))
    ));

    let mut rng = Pcg64::seed_from_u64(11);
    let n = 400;
    let sizes = SizeDistribution::Uniform { min: 0.6, max: 1.4 }
        .draw(n, &mut rng)
        .unwrap();
    let box_ = PeriodicBox::new(Vector3::repeat(10.0)).unwrap();
    let mut system = random_insertion_sized(
        box_,
        spheres(),
        &[n],
        Some(sizes.clone()),
        1_000_000,
        &mut rng,
    )
    .unwrap();
    assert_eq!(system.sizes(), Some(sizes.as_slice()));
    let volume: f64 = sizes.iter().map(|f| PI / 6.0 * f.powi(3)).sum();
    assert!((system.packing_fraction() - volume / 1000.0).abs() < 1e-12);
    let moves = MoveSizes {
        translate: 0.15,
        rotate: 0.0,
        volume: 0.0,
        shear: 0.01,
    };
    for round in 0..4 {
        for _ in 0..50 {
            sweep(&mut system, &moves, &Ensemble::Nvt, &mut rng);
        }
        let p = system.particles();
        let (mut closest, mut closest_small) = (f64::INFINITY, f64::INFINITY);
        for i in 0..n {
            for j in i + 1..n {
                let d = box_.minimum_image(&(p[j].position - p[i].position)).norm();
                let gap = d - 0.5 * (sizes[i] + sizes[j]);
                closest = closest.min(gap);
                if sizes[i] < 0.8 && sizes[j] < 0.8 {
                    closest_small = closest_small.min(gap);
                }
            }
        }
        assert!(closest > 0.0, "round {round}: a pair overlaps by {closest}");
        assert_eq!(system.first_overlap_all_pairs(), None);
        assert_eq!(system.first_overlap(), None);
        // Small spheres come close to one another: kept apart at a common
        // larger radius, no two of them would come within 0.8.
        assert!(
            closest_small < 0.1,
            "round {round}: smallest spheres {closest_small} apart"
        );
    }
}

/// NVT at φ = 0.45 with Gaussian sizes of deviation 0.1 (mean diameter 1):
/// the scale-distribution pressure agrees with BMCSL within 1 % and its
/// error, while the Carnahan–Starling pressure of equal spheres at the
/// same φ is told apart.
#[test]
fn polydisperse_pressure_follows_bmcsl() {
    let mut rng = Pcg64::seed_from_u64(3);
    let n = 1000;
    let sizes = SizeDistribution::Gaussian { std: 0.1 }
        .draw(n, &mut rng)
        .unwrap();
    let volume: f64 = sizes.iter().map(|f| PI / 6.0 * f.powi(3)).sum();
    let box_ = PeriodicBox::new(Vector3::repeat((volume / 0.25).cbrt())).unwrap();
    let mut system = random_insertion_sized(
        box_,
        spheres(),
        &[n],
        Some(sizes.clone()),
        1_000_000,
        &mut rng,
    )
    .unwrap();
    let moves = MoveSizes {
        translate: 0.1,
        rotate: 0.0,
        volume: 0.0,
        shear: 0.01,
    };
    let phi = 0.45;
    compress(&mut system, moves, &CompressOptions::to(phi), &mut rng).unwrap();
    assert!((system.packing_fraction() - phi).abs() < 1e-9);
    for _ in 0..2000 {
        sweep(&mut system, &moves, &Ensemble::Nvt, &mut rng);
    }
    let mut estimates = Vec::new();
    for _ in 0..48 {
        let mut sdf = Sdf::new(0.02, 200);
        for _ in 0..100 {
            for _ in 0..5 {
                sweep(&mut system, &moves, &Ensemble::Nvt, &mut rng);
            }
            sdf.add(&system);
        }
        estimates.push(sdf.pressure().unwrap());
    }
    let mean = estimates.iter().mean();
    let se = estimates.iter().std_dev() / (estimates.len() as f64).sqrt();
    let rho = n as f64 / system.periodic_box().volume();
    let bmcsl = bmcsl_pressure(rho, &sizes);
    let equal = bmcsl_pressure(rho * sizes.iter().map(|f| f.powi(3)).mean(), &[1.0]);
    eprintln!(
        "polydisperse phi = {phi}: SDF betaP = {mean:.4} ± {se:.4}, BMCSL {bmcsl:.4}, equal spheres {equal:.4}"
    );
    assert!(se < 0.003 * bmcsl, "error {se} too large to judge 1 %");
    assert!(
        (mean - bmcsl).abs() < (3.0 * se).max(0.002 * bmcsl) && (mean - bmcsl).abs() < 0.01 * bmcsl,
        "SDF βP = {mean} ± {se}, BMCSL {bmcsl}"
    );
    assert!(
        (mean - equal).abs() > 5.0 * se,
        "equal spheres {equal} not told apart"
    );
}

/// A scene with `sizes` runs end to end: its log carries each body's size
/// (the scene's draw from its seed), every frame is overlap-free at those
/// sizes by brute force, a resumed run takes them from the log, and a scene
/// that resumes it without `sizes` is refused.
#[test]
fn a_polydisperse_scene_logs_its_sizes_and_resumes_with_them() {
    use hardbody::log::read::read_log;
    use hardbody::run::{Silent, run_scene, system_from_record};
    use hardbody::scene::Scene;
    use hardbody::scene::plan::Plan;
    use std::sync::atomic::AtomicBool;

    let dir = std::env::temp_dir().join(format!("hardbody-poly-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let text = r#"Scene(
        seed: 9,
        box: (9.0, 9.0, 9.0),
        species: [
            Species(name: "small", shape: Sphere(radius: 0.4), count: 100, sizes: LogNormal(std: 0.15)),
            Species(name: "big", shape: Sphere(radius: 0.5), count: 150, sizes: Uniform(min: 0.9, max: 1.1)),
        ],
        start: Random,
        stages: [Compress(packing_fraction: 0.4), MonteCarlo(ensemble: Npt(pressure: 5.0), sweeps: 300)],
        log: Log(path: "poly.mcap", stats_every: 50, frames_every: 100),
    )"#;
    let scene = Scene::parse(text).unwrap();
    let sizes = scene.body_sizes().unwrap();
    assert_eq!(sizes.len(), 250);
    assert_eq!(
        Scene::parse(text).unwrap().body_sizes().unwrap(),
        sizes,
        "drawn from the seed"
    );
    let path = dir.join("poly.mcap");
    let stop = AtomicBool::new(false);
    run_scene(&scene, text, &path, &mut Silent, &stop).unwrap();
    let log = read_log(&path, true).unwrap();
    let plan = Plan::of(&scene);
    assert!(log.states.len() >= 4);
    let radius = |i: usize| if i < 100 { 0.4 } else { 0.5 } * sizes[i];
    for (_, state) in &log.states {
        assert_eq!(state.sizes.as_deref(), Some(sizes.as_slice()));
        let system = system_from_record(state, &plan).unwrap();
        let p = system.particles();
        let box_ = system.periodic_box();
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                let d = box_.minimum_image(&(p[j].position - p[i].position)).norm();
                assert!(
                    d > radius(i) + radius(j),
                    "{i} and {j} overlap at their sizes"
                );
            }
        }
    }
    let compressed = log.stats.iter().find(|(_, s)| s.stage_index == 0).unwrap();
    assert!(compressed.1.packing_fraction > 0.0);
    let last = &log.states.last().unwrap().1;
    let volume: f64 = (0..250).map(|i| 4.0 / 3.0 * PI * radius(i).powi(3)).sum();
    let phi = volume / last.box_lengths.iter().product::<f64>();
    assert!(
        (log.stats.last().unwrap().1.packing_fraction - phi).abs() < 1e-9,
        "the logged packing fraction counts each body at its size"
    );

    let resumed = text
        .replace(
            "start: Random",
            &format!("start: Resume({:?})", path.display().to_string()),
        )
        .replace("Compress(packing_fraction: 0.4), ", "");
    let scene = Scene::parse(&resumed).unwrap();
    run_scene(
        &scene,
        &resumed,
        &dir.join("again.mcap"),
        &mut Silent,
        &stop,
    )
    .unwrap();
    let again = read_log(&dir.join("again.mcap"), true).unwrap();
    assert_eq!(again.states[0].1.sizes.as_deref(), Some(sizes.as_slice()));
    let bare = resumed
        .replace(", sizes: LogNormal(std: 0.15)", "")
        .replace(", sizes: Uniform(min: 0.9, max: 1.1)", "");
    let refused = hardbody::run::check_start(&Scene::parse(&bare).unwrap())
        .unwrap_err()
        .to_string();
    assert!(refused.contains("sizes of their own"), "{refused}");
    let _ = std::fs::remove_dir_all(&dir);
}
