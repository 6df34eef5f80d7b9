//! Polydisperse hard spheres in Monte Carlo: every body's own size
//! honoured by the overlap tests (against brute force), and the pressure
//! against the Boublik–Mansoori–Carnahan–Starling–Leland equation of state.

mod common;

use std::f64::consts::PI;

use common::polydisperse::{bmcsl_pressure, compressed_fluid, spheres};

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

    // A wall at x = 3 is 0.55 from a centre at 2.45: size 1 clears it,
    // size 1.2 (radius 0.6) crosses it.
    let walled = box_.with_walls([true, false, false]).unwrap();
    let near = vec![at(2.45), at(-1.0)];
    assert!(System::with_sizes(walled, spheres(), near.clone(), vec![1.0, 1.0]).is_ok());
    assert_eq!(
        System::with_sizes(walled, spheres(), near, vec![1.2, 1.0]).unwrap_err(),
        StateError::WallOverlap(0)
    );

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

/// A size swap is taken exactly where it leaves no overlap: refused where
/// the larger size would overlap a neighbour, or across species; over many
/// swaps every state stays overlap-free at its sizes (brute force) and the
/// sizes stay the same set.
#[test]
fn size_swaps_are_taken_where_they_leave_no_overlap() {
    use hardbody::mc::moves::sweep_with_swaps;
    let box_ = PeriodicBox::new(Vector3::repeat(6.0)).unwrap();
    let at = |x: f64| Particle {
        position: Vector3::new(x, 0.0, 0.0),
        orientation: UnitQuaternion::identity(),
        species: 0,
    };
    let row = vec![at(0.0), at(1.0), at(2.15)];
    let mut system = System::with_sizes(box_, spheres(), row, vec![0.9, 1.0, 1.2]).unwrap();
    // 0 at size 1.2 would reach 0.6 + 0.5 = 1.1 > 1 into its neighbour.
    assert!(!system.try_swap_sizes(0, 2));
    assert_eq!(system.sizes(), Some(&[0.9, 1.0, 1.2][..]));
    assert!(system.try_swap_sizes(0, 1));
    assert_eq!(system.sizes(), Some(&[1.0, 0.9, 1.2][..]));
    assert!(!system.try_swap_sizes(1, 1));
    let mut two = spheres();
    two.push(Species {
        name: "other".into(),
        ..two[0].clone()
    });
    let mixed = vec![
        at(0.0),
        Particle {
            species: 1,
            ..at(2.0)
        },
    ];
    let mut mixed = System::with_sizes(box_, two, mixed, vec![0.9, 1.1]).unwrap();
    assert!(!mixed.try_swap_sizes(0, 1), "across species");

    let mut rng = Pcg64::seed_from_u64(8);
    let n = 300;
    let uniform = SizeDistribution::Uniform { min: 0.6, max: 1.4 };
    let (mut system, sizes, moves) = compressed_fluid(n, uniform, 0.5, 0.1, &mut rng);
    let box_ = *system.periodic_box();
    let mut sorted = sizes.clone();
    sorted.sort_by(f64::total_cmp);
    let mut swapped = hardbody::mc::moves::Count::default();
    for round in 0..4 {
        for _ in 0..50 {
            swapped =
                swapped + sweep_with_swaps(&mut system, &moves, &Ensemble::Nvt, 0.5, &mut rng).swap;
        }
        let now = system.sizes().unwrap().to_vec();
        let p = system.particles();
        for i in 0..n {
            for j in i + 1..n {
                let d = box_.minimum_image(&(p[j].position - p[i].position)).norm();
                assert!(
                    d > 0.5 * (now[i] + now[j]),
                    "round {round}: {i} and {j} overlap"
                );
            }
        }
        let mut again = now.clone();
        again.sort_by(f64::total_cmp);
        assert_eq!(again, sorted, "the sizes are exchanged, never changed");
        assert_ne!(now, sizes, "round {round}: no swap taken");
        assert_eq!(system.first_overlap_all_pairs(), None);
    }
    assert!(
        swapped.tried == 4 * 50 * 150 && swapped.accepted > 0,
        "{swapped:?}"
    );
}

/// NVT at φ = 0.45 with Gaussian sizes of deviation 0.1 (mean diameter 1):
/// the scale-distribution pressure agrees with BMCSL within 1 % and its
/// error, while the Carnahan–Starling pressure of equal spheres at the
/// same φ is told apart.
#[test]
fn polydisperse_pressure_follows_bmcsl() {
    pressure_against_bmcsl(0.0);
}

/// With size swaps the pressure is the same: they sample the same
/// distribution (a biased swap would change the structure, and with it the
/// pressure).
#[test]
fn polydisperse_pressure_with_swaps_follows_bmcsl() {
    pressure_against_bmcsl(0.1);
}

fn pressure_against_bmcsl(swaps: f64) {
    use hardbody::mc::moves::sweep_with_swaps;
    let mut rng = Pcg64::seed_from_u64(3);
    let n = 1000;
    let phi = 0.45;
    let gaussian = SizeDistribution::Gaussian { std: 0.1 };
    let (mut system, sizes, moves) = compressed_fluid(n, gaussian, phi, 0.1, &mut rng);
    assert!((system.packing_fraction() - phi).abs() < 1e-9);
    let mut swapped = hardbody::mc::moves::Count::default();
    for _ in 0..2000 {
        sweep_with_swaps(&mut system, &moves, &Ensemble::Nvt, swaps, &mut rng);
    }
    let mut estimates = Vec::new();
    for _ in 0..48 {
        let mut sdf = Sdf::new(0.02, 200);
        for _ in 0..100 {
            for _ in 0..5 {
                let counts = sweep_with_swaps(&mut system, &moves, &Ensemble::Nvt, swaps, &mut rng);
                swapped = swapped + counts.swap;
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
        "polydisperse phi = {phi}, swaps {swaps} (accepted {:.3}): SDF betaP = {mean:.4} ± {se:.4}, BMCSL {bmcsl:.4}, equal spheres {equal:.4}",
        swapped.rate()
    );
    assert_eq!(swapped.tried > 0, swaps > 0.0);
    assert!(
        swaps == 0.0 || swapped.accepted > swapped.tried / 10,
        "{swapped:?}"
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
        stages: [Compress(packing_fraction: 0.4), MonteCarlo(ensemble: Npt(pressure: 5.0), sweeps: 300, swaps: 0.2)],
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
    let radius = |i: usize, sizes: &[f64]| if i < 100 { 0.4 } else { 0.5 } * sizes[i];
    // Each species' sizes, as a set: swaps exchange them within a species.
    let sets = |sizes: &[f64]| {
        let mut sets = [sizes[..100].to_vec(), sizes[100..].to_vec()];
        sets.iter_mut().for_each(|s| s.sort_by(f64::total_cmp));
        sets
    };
    assert_eq!(log.states[0].1.sizes.as_deref(), Some(sizes.as_slice()));
    for (_, state) in &log.states {
        let now = state.sizes.as_deref().unwrap();
        assert_eq!(sets(now), sets(&sizes));
        let system = system_from_record(state, &plan).unwrap();
        let p = system.particles();
        let box_ = system.periodic_box();
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                let d = box_.minimum_image(&(p[j].position - p[i].position)).norm();
                assert!(
                    d > radius(i, now) + radius(j, now),
                    "{i} and {j} overlap at their sizes"
                );
            }
        }
    }
    // Swaps are counted where the stage asks for them.
    for (_, s) in &log.stats {
        let swapped = s.acceptance_swap;
        match s.stage_index {
            0 => assert_eq!(swapped, None),
            _ => assert!(swapped.is_some_and(|a| a > 0.0 && a < 1.0), "{swapped:?}"),
        }
    }
    let last = &log.states.last().unwrap().1;
    let volume: f64 = (0..250)
        .map(|i| 4.0 / 3.0 * PI * radius(i, &sizes).powi(3))
        .sum();
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
    assert_eq!(
        again.states[0].1.sizes, last.sizes,
        "resumed at the log's sizes"
    );
    assert_ne!(
        last.sizes.as_deref(),
        Some(sizes.as_slice()),
        "the swaps exchanged sizes"
    );
    let bare = resumed
        .replace(", sizes: LogNormal(std: 0.15)", "")
        .replace(", sizes: Uniform(min: 0.9, max: 1.1)", "")
        .replace(", swaps: 0.2", "");
    let refused = hardbody::run::check_start(&Scene::parse(&bare).unwrap())
        .unwrap_err()
        .to_string();
    assert!(refused.contains("sizes of their own"), "{refused}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The self overlap Q(t) = ⟨θ(a − |Δrᵢ(t)|)⟩ over bodies and time origins
/// (a = 0.3 mean diameters), from unwrapped centres sampled `every`
/// sweeps; and the first lag (in sweeps) where it falls below 1/e.
fn overlap_decay(
    system: &mut System,
    moves: &MoveSizes,
    swaps: f64,
    samples: usize,
    every: usize,
    rng: &mut Pcg64,
) -> (Vec<f64>, Option<usize>) {
    use hardbody::mc::moves::sweep_with_swaps;
    let n = system.len();
    let box_ = *system.periodic_box();
    let mut unwrapped: Vec<Vector3<f64>> = system.particles().iter().map(|p| p.position).collect();
    let mut last = unwrapped.clone();
    let mut trajectory = vec![unwrapped.clone()];
    for _ in 1..samples {
        for _ in 0..every {
            sweep_with_swaps(system, moves, &Ensemble::Nvt, swaps, rng);
        }
        for (i, p) in system.particles().iter().enumerate() {
            unwrapped[i] += box_.minimum_image(&(p.position - last[i]));
            last[i] = p.position;
        }
        trajectory.push(unwrapped.clone());
    }
    let q: Vec<f64> = (0..samples / 2)
        .map(|lag| {
            let origins = samples - lag;
            let mut held = 0usize;
            for t in 0..origins {
                held += (0..n)
                    .filter(|&i| (trajectory[t + lag][i] - trajectory[t][i]).norm() < 0.3)
                    .count();
            }
            held as f64 / (origins * n) as f64
        })
        .collect();
    let tau = q
        .iter()
        .position(|&x| x < (-1.0f64).exp())
        .map(|lag| lag * every);
    (q, tau)
}

/// Size swaps (0.25 per body per sweep) cut the decorrelation time of a
/// dense polydisperse fluid (500 spheres, Gaussian sizes of deviation 0.15,
/// φ = 0.58): τ, where the self overlap falls to 1/e, in sweeps, at least 3
/// times shorter (measured: 96 000 against 14 000 sweeps; the time per
/// sweep, printed, is 1.7 times longer with swaps). `PHI`, `STD`,
/// `SAMPLES` and `EVERY` set the state and the sampling
/// (docs/polydisperse.md has the table).
#[test]
#[ignore = "measurement, about 40 s: the decorrelation time with and without swaps"]
fn swaps_decorrelate_a_dense_polydisperse_fluid_faster() {
    let var =
        |name: &str, default: f64| std::env::var(name).map_or(default, |s| s.parse().unwrap());
    let (std, phi) = (var("STD", 0.15), var("PHI", 0.58));
    let (samples, every) = (
        var("SAMPLES", 300.0) as usize,
        var("EVERY", 1000.0) as usize,
    );
    let mut rng = Pcg64::seed_from_u64(21);
    let gaussian = SizeDistribution::Gaussian { std };
    let (system, _, moves) = compressed_fluid(500, gaussian, phi, 0.08, &mut rng);
    let longest = samples / 2 * every;
    let mut taus = Vec::new();
    for swaps in [0.0, 0.25] {
        let mut s = system.clone();
        let t0 = std::time::Instant::now();
        let (q, tau) = overlap_decay(&mut s, &moves, swaps, samples, every, &mut rng);
        let per_sweep = t0.elapsed().as_secs_f64() / (samples * every) as f64;
        let shown: Vec<String> = q.iter().step_by(10).map(|x| format!("{x:.3}")).collect();
        eprintln!(
            "phi {phi}, std {std}, swaps {swaps}: tau {} sweeps, {:.1} us per sweep, Q every {} sweeps {shown:?}",
            tau.map_or(format!("> {longest}"), |t| t.to_string()),
            1e6 * per_sweep,
            10 * every
        );
        taus.push(tau);
    }
    let swapped = taus[1].expect("with swaps Q falls below 1/e");
    let plain = taus[0].unwrap_or(longest);
    assert!(
        plain >= 3 * swapped,
        "tau {plain} without swaps, {swapped} with"
    );
}

/// A lattice start spaces its sites for each species' largest body, so
/// that every body at its own size fits: the start is overlap-free at the
/// drawn sizes, and a box that holds the sites for bodies of size 1 but
/// not for the largest is refused as too small.
#[test]
fn a_polydisperse_lattice_start_spaces_its_sites_for_the_largest_body() {
    use hardbody::run::{Silent, run_scene};
    use hardbody::scene::Scene;
    use std::sync::atomic::AtomicBool;

    let text = |edge: f64| {
        format!(
            r#"Scene(seed: 2, box: ({edge}, {edge}, {edge}),
            species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 125, sizes: Uniform(min: 0.8, max: 1.3))],
            start: Lattice, stages: [MonteCarlo(ensemble: Nvt, sweeps: 20)],
            log: Log(path: "lattice.mcap", stats_every: 10, frames_every: 10))"#
        )
    };
    // Five sites of size-1 spheres fit along 5.5, not five of the largest.
    let refused = Scene::parse(&text(5.5)).unwrap_err().to_string();
    assert!(refused.contains("a lattice in this box holds"), "{refused}");
    let scene = Scene::parse(&text(7.0)).unwrap();
    let dir = std::env::temp_dir().join(format!("hardbody-poly-lattice-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("lattice.mcap");
    run_scene(
        &scene,
        &text(7.0),
        &path,
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap();
    let log = hardbody::log::read::read_log(&path, true).unwrap();
    let first = &log.states[0].1;
    let sizes = first.sizes.as_deref().unwrap();
    assert_eq!(sizes, scene.body_sizes().unwrap().as_slice());
    let box_ = first.periodic_box([false; 3]).unwrap();
    for i in 0..125 {
        for j in i + 1..125 {
            let d = Vector3::from(first.positions[j]) - Vector3::from(first.positions[i]);
            let d = box_.minimum_image(&d).norm();
            assert!(d > 0.5 * (sizes[i] + sizes[j]), "{i} and {j} overlap");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The first frame of the scene `text`, run to a log in a fresh directory
/// named after `tag`.
fn first_frame(tag: &str, text: &str) -> hardbody::log::StateRecord {
    use hardbody::run::{Silent, run_scene};
    use std::sync::atomic::AtomicBool;
    let dir = std::env::temp_dir().join(format!("hardbody-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.mcap");
    let scene = hardbody::scene::Scene::parse(text).unwrap();
    run_scene(&scene, text, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
    let log = hardbody::log::read::read_log(&path, true).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    log.states[0].1.clone()
}

/// Each pair of the frame apart by more than the sum of its radii (all
/// pairs), the radius of body i `radius(i)` times its size.
fn assert_apart(frame: &hardbody::log::StateRecord, radius: impl Fn(usize) -> f64) {
    let box_ = frame.periodic_box([false; 3]).unwrap();
    let n = frame.positions.len();
    for i in 0..n {
        for j in i + 1..n {
            let d = Vector3::from(frame.positions[j]) - Vector3::from(frame.positions[i]);
            let sigma = radius(i) * frame.size_of(i) + radius(j) * frame.size_of(j);
            assert!(box_.minimum_image(&d).norm() > sigma, "{i} and {j} overlap");
        }
    }
}

/// A polydisperse fcc crystal: its packing fraction counts each body at
/// its size (the box is larger than equal spheres' by the cube root of
/// ⟨f³⟩), its bodies sit on the fcc sites overlap-free at their sizes,
/// and one so dense that its largest body would touch on its site is
/// refused, naming where. A layered start of two polydisperse species
/// puts each in its layer at its own sizes.
#[test]
fn polydisperse_crystal_and_layered_starts_hold_each_body_at_its_size() {
    let crystal = |phi: f64| {
        format!(
            r#"Scene(seed: 4,
            species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 108, sizes: Gaussian(std: 0.04))],
            start: Crystal(lattice: Fcc, cells: (3, 3, 3), packing_fraction: {phi}),
            stages: [MonteCarlo(ensemble: Nvt, sweeps: 10)],
            log: Log(path: "c.mcap", stats_every: 10, frames_every: 10))"#
        )
    };
    let frame = first_frame("poly-crystal", &crystal(0.5));
    let sizes = frame.sizes.clone().unwrap();
    let mean_cube = sizes.iter().map(|f| f.powi(3)).mean();
    let volume: f64 = frame.box_lengths.iter().product();
    let phi = 108.0 * PI / 6.0 * mean_cube / volume;
    assert!((phi - 0.5).abs() < 1e-12, "{phi}");
    // Equal spheres at 0.5 in the same cells: the box is scaled by ⟨f³⟩^⅓.
    let equal = 108.0 * PI / 6.0 / 0.5;
    assert!((volume / equal - mean_cube).abs() < 1e-12);
    assert_apart(&frame, |_| 0.5);
    let largest = sizes.iter().copied().fold(0.0, f64::max);
    let limit = PI / 18f64.sqrt() * mean_cube / largest.powi(3);
    let refused = hardbody::scene::Scene::parse(&crystal(limit + 1e-3))
        .unwrap_err()
        .to_string();
    let stated: f64 = refused
        .split("its bodies touch at ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("{refused}"));
    assert!((stated - limit).abs() < 1e-9, "{limit}: {refused}");
    hardbody::scene::Scene::parse(&crystal(limit - 1e-3)).unwrap();

    let layered = r#"Scene(seed: 5, box: (16.0, 8.0, 8.0),
        species: [Species(name: "a", shape: Sphere(radius: 0.5), count: 100, sizes: Uniform(min: 0.7, max: 1.3)),
                  Species(name: "b", shape: Sphere(radius: 0.4), count: 100, sizes: Gaussian(std: 0.1))],
        start: Layered(X), stages: [MonteCarlo(ensemble: Nvt, sweeps: 10)],
        log: Log(path: "l.mcap", stats_every: 10, frames_every: 10))"#;
    let frame = first_frame("poly-layered", layered);
    let drawn = hardbody::scene::Scene::parse(layered)
        .unwrap()
        .body_sizes()
        .unwrap();
    assert_eq!(frame.sizes.as_deref(), Some(drawn.as_slice()));
    let radius = |i: usize| if frame.species_of[i] == 0 { 0.5 } else { 0.4 };
    assert_apart(&frame, radius);
    let frame = &frame;
    let x = |s: u16| {
        (0..200)
            .filter(move |&i| frame.species_of[i] == s)
            .map(|i| frame.positions[i][0])
    };
    let a_high = x(0).fold(f64::NEG_INFINITY, f64::max);
    let b_low = x(1).fold(f64::INFINITY, f64::min);
    assert!(a_high <= b_low, "a up to {a_high}, b from {b_low}");
}
