//! Equilibrium averages a researcher can quote: NPT stages whose move
//! sizes follow the density until it settles, and `hardbody analyze`
//! reporting the hard-sphere equation of state within its errors and
//! flagging a stage that never equilibrated.

use hardbody::analysis::eos::carnahan_starling_packing_fraction;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use hardbody::log::Stats;
use hardbody::log::averages::{StageAverages, stage_averages};
use hardbody::log::read::read_log;
use hardbody::run::{Silent, run_scene};
use hardbody::scene::Scene;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hardbody-eq-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `text` and returns its `/stats`.
fn stats_of(text: &str, log: &Path) -> Vec<Stats> {
    let scene = Scene::parse(text).unwrap();
    run_scene(&scene, text, log, &mut Silent, &AtomicBool::new(false)).unwrap();
    read_log(log, false)
        .unwrap()
        .stats
        .into_iter()
        .map(|(_, s)| s)
        .collect()
}

/// 216 hard spheres from a dilute lattice (φ = 0.06) at βP = 6, 6000
/// sweeps, with `tune` the stage's tuning option.
fn dilute_npt(tune: &str) -> String {
    format!(
        r#"Scene(
    seed: 3,
    box: (13.0, 13.0, 13.0),
    species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 216)],
    stages: [MonteCarlo(ensemble: Npt(pressure: 6.0), sweeps: 6000{tune})],
    log: Log(path: "unused.mcap", stats_every: 50, frames_every: 3000),
)"#
    )
}

/// Mean translation acceptance and packing fraction over the last 1000
/// sweeps.
fn last_stretch(stats: &[Stats]) -> (f64, f64) {
    let tail = &stats[stats.len() - 20..];
    let mean = |f: &dyn Fn(&Stats) -> f64| tail.iter().map(f).sum::<f64>() / tail.len() as f64;
    (
        mean(&|s| s.acceptance_translate.unwrap()),
        mean(&|s| s.packing_fraction),
    )
}

/// An NPT stage from a dilute start reaches the equilibrium density within
/// its first thousands of sweeps. The box moves alone could not: a shrink
/// in ln V is refused as soon as the closest pair would overlap, a gap of
/// order 1/N of the box in a dense fluid, so the box crept (216 spheres
/// were at φ 0.38 after 7000 sweeps, 4096 at 0.34 after 10⁵). The stage
/// now starts with an approach that lets shrinks overlap and measures the
/// pressure; its move sizes are tuned on until the density settles.
#[test]
fn npt_from_a_dilute_start_reaches_the_equilibrium_density() {
    let dir = scratch("npt");
    let stats = stats_of(&dilute_npt(""), &dir.join("dilute.mcap"));
    let (acceptance, phi) = last_stretch(&stats);
    let expected = carnahan_starling_packing_fraction(6.0);
    assert!((acceptance - 0.3).abs() < 0.05, "{acceptance}");
    assert!(
        (phi / expected - 1.0).abs() < 0.02,
        "{phi} after 6000 sweeps, Carnahan-Starling {expected}"
    );
    // From the first stats on, not only at the end.
    let first = &stats[..20];
    let early = first.iter().map(|s| s.packing_fraction).sum::<f64>() / 20.0;
    assert!(
        (early / expected - 1.0).abs() < 0.03,
        "{early} over the first 1000 sweeps"
    );
}

/// The averages of the stage with index `index`.
fn stage(averages: &[StageAverages], index: usize) -> &StageAverages {
    averages.iter().find(|s| s.stage_index == index).unwrap()
}

#[test]
fn analyze_flags_a_stage_that_never_equilibrated() {
    let dir = scratch("short");
    // 400 sweeps of the dilute start between hard walls (no approach to
    // the pressure first: it is measured in a periodic box): the density
    // rises throughout.
    let text = dilute_npt("")
        .replace("sweeps: 6000", "sweeps: 400")
        .replace("    species:", "    walls: [Z],\n    species:");
    let text = text.replace("stats_every: 50", "stats_every: 10");
    let averages = stage_averages(&stats_of(&text, &dir.join("short.mcap")));
    let s = stage(&averages, 0);
    assert!(!s.equilibrated, "{s:?}");
    assert!(s.not_equilibrated.contains(&"packing_fraction".to_string()));
    // The command says so.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["analyze", dir.join("short.mcap").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success());
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(stdout.contains("NOT EQUILIBRATED"), "{stdout}");
    assert!(stderr.contains("stage 0 never equilibrated"), "{stderr}");
}

/// NVT Monte Carlo (scale-distribution pressure) and dynamics (collision
/// virial) of 256 hard spheres at the Carnahan–Starling density of βP = 4,
/// each averaged by `analyze`: two independent routes to the pressure
/// agree with each other within their combined errors (three of them) and
/// with the equation of state within 1 %.
#[test]
fn analyze_gives_two_pressure_routes_that_agree_within_their_errors() {
    let dir = scratch("routes");
    let phi = carnahan_starling_packing_fraction(4.0);
    let text = format!(
        r#"Scene(
    seed: 11,
    box: (12.0, 12.0, 12.0),
    species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 256)],
    stages: [
        Compress(packing_fraction: {phi:.6}),
        MonteCarlo(ensemble: Nvt, sweeps: 40000),
        Dynamics(duration: 200.0, stats_every: 1.0),
    ],
    log: Log(path: "unused.mcap", stats_every: 100, frames_every: 20000),
)"#
    );
    let averages = stage_averages(&stats_of(&text, &dir.join("routes.mcap")));
    let pressure = |index: usize| {
        let s = stage(&averages, index);
        assert!(s.equilibrated, "stage {index}: {s:?}");
        s.observables["pressure"].estimate
    };
    let (sdf, virial) = (pressure(1), pressure(2));
    let combined = (sdf.error.powi(2) + virial.error.powi(2)).sqrt();
    let line = format!(
        "SDF {:.4} +- {:.4}, virial {:.4} +- {:.4}, Carnahan-Starling 4",
        sdf.mean, sdf.error, virial.mean, virial.error
    );
    assert!(combined > 0.0 && combined < 0.05, "{line}");
    assert!((sdf.mean - virial.mean).abs() < 3.0 * combined, "{line}");
    for route in [sdf, virial] {
        assert!((route.mean / 4.0 - 1.0).abs() < 0.01, "{line}");
    }
    // The dynamics conserves the temperature: reported as constant.
    assert!(stage(&averages, 2).observables["temperature"].constant);
    // The fluid's pressure tensor, averaged component by component, is
    // the pressure times the unit tensor; Monte Carlo stages have none.
    let dynamics = stage(&averages, 2);
    for (name, expected) in [
        ("pressure_xx", virial.mean),
        ("pressure_yy", virial.mean),
        ("pressure_zz", virial.mean),
        ("pressure_xy", 0.0),
        ("pressure_xz", 0.0),
        ("pressure_yz", 0.0),
    ] {
        let c = dynamics.observables[name].estimate;
        assert!(
            c.error > 0.0 && (c.mean - expected).abs() < 4.0 * c.error.hypot(virial.error),
            "{name}: {} ± {} against {expected}",
            c.mean,
            c.error
        );
    }
    assert!(!stage(&averages, 1).observables.contains_key("pressure_xx"));
}

/// The hard-sphere equation of state scene, one log, through `analyze`,
/// against Carnahan–Starling: every stage equilibrated, every density
/// within 0.5 % and within three errors. (A long run: `HARDBODY_LONG=1`,
/// about two and a half minutes on one core.)
#[test]
fn analyze_reports_the_hard_sphere_equation_of_state() {
    if std::env::var_os("HARDBODY_LONG").is_none() {
        eprintln!(
            "skipped: set HARDBODY_LONG=1 to run the equation-of-state scene (about two and a half minutes)"
        );
        return;
    }
    let dir = scratch("eos");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/hard_sphere_eos.ron");
    let text = std::fs::read_to_string(path).unwrap();
    let scene = Scene::parse(&text).unwrap();
    let averages = stage_averages(&stats_of(&text, &dir.join("eos.mcap")));
    let mut table = Vec::new();
    let mut wrong = Vec::new();
    for (index, st) in scene.stages.iter().enumerate() {
        let hardbody::scene::Stage::MonteCarlo {
            ensemble: hardbody::scene::Ensemble::Npt { pressure, .. },
            ..
        } = st
        else {
            continue;
        };
        let s = stage(&averages, index);
        let phi = s.observables["packing_fraction"].estimate;
        let expected = carnahan_starling_packing_fraction(*pressure);
        let line = format!(
            "betaP {pressure}: phi {:.5} +- {:.5} (Carnahan-Starling {expected:.5}, {:+.2} %)",
            phi.mean,
            phi.error,
            100.0 * (phi.mean / expected - 1.0),
        );
        eprintln!("{line}");
        let off = (phi.mean - expected).abs();
        if !s.equilibrated || off > 0.005 * expected || off > 3.0 * phi.error {
            wrong.push(line.clone());
        }
        table.push(line);
    }
    assert_eq!(table.len(), 5);
    assert!(wrong.is_empty(), "{}", table.join("\n"));
}

/// 64 rods compressed to 0.35, then dynamics for t = 1 with the Newton
/// tolerance `tolerance`: its summary and its dynamics `/stats`.
fn rods_with_newton_tolerance(tolerance: &str, log: &Path) -> (Vec<String>, Vec<Stats>) {
    let text = format!(
        r#"Scene(
    seed: 5,
    box: (9.0, 9.0, 9.0),
    species: [Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 64)],
    stages: [Compress(packing_fraction: 0.35), Dynamics(duration: 1.0, stats_every: 0.1)],
    accuracy: Accuracy(newton_tolerance: {tolerance}),
)"#
    );
    let scene = Scene::parse(&text).unwrap();
    let summary = run_scene(&scene, &text, log, &mut Silent, &AtomicBool::new(false)).unwrap();
    let stats = read_log(log, false)
        .unwrap()
        .stats
        .into_iter()
        .map(|(_, s)| s)
        .filter(|s| s.stage == "dynamics")
        .collect();
    (summary.notes, stats)
}

#[test]
fn solver_strains_are_counted_in_stats_and_reported_at_the_end() {
    let dir = scratch("strains");
    // The default tolerance: Newton converges every time.
    let (notes, stats) = rods_with_newton_tolerance("1e-12", &dir.join("easy.mcap"));
    assert!(notes.is_empty(), "{notes:?}");
    let work = stats.last().unwrap().solver.unwrap();
    assert!(work.distances > 1000 && work.iterations >= work.distances);
    assert_eq!(work.strains(), vec![]);
    // A tolerance no iterate meets: Newton gives up, GJK answers.
    let (notes, stats) = rods_with_newton_tolerance("1e-300", &dir.join("strained.mcap"));
    let counts: Vec<_> = stats.iter().map(|s| s.solver.unwrap()).collect();
    let last = counts.last().unwrap();
    assert!(last.fallbacks > 100, "{last:?}");
    // Counted since the stage began: never decreasing.
    assert!(
        counts
            .windows(2)
            .all(|w| w[1].fallbacks >= w[0].fallbacks && w[1].distances >= w[0].distances)
    );
    // analyze reports the stage's counts.
    let averages = stage_averages(&stats);
    assert_eq!(averages[0].solver.as_ref(), Some(last));
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains(&format!("{} solver fallbacks", last.fallbacks)),
        "{notes:?}"
    );
}

/// `hardbody analyze` with these arguments: (exit code, stdout as JSON if
/// it is JSON, stderr).
fn analyze_cli(args: &[&str]) -> (i32, Option<serde_json::Value>, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .arg("analyze")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap(),
        serde_json::from_slice(&out.stdout).ok(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn analyze_averages_replicas_and_refuses_runs_of_other_scenes() {
    let dir = scratch("replicas");
    let scene = |seed: u64, sweeps: u64| {
        format!(
            r#"Scene(
    seed: {seed},
    box: (6.0, 6.0, 6.0),
    species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 64)],
    stages: [Compress(packing_fraction: 0.3), MonteCarlo(ensemble: Nvt, sweeps: {sweeps})],
    log: Log(path: "unused.mcap", stats_every: 20, frames_every: 1000),
)"#
        )
    };
    let logs: Vec<PathBuf> = (1..=3)
        .map(|seed| {
            let log = dir.join(format!("seed{seed}.mcap"));
            stats_of(&scene(seed, 2000), &log);
            log
        })
        .collect();
    let names: Vec<&str> = logs.iter().map(|p| p.to_str().unwrap()).collect();
    let (code, json, err) = analyze_cli(&[names[0], names[1], names[2], "--json"]);
    assert_eq!(code, 0, "{err}");
    let json = json.unwrap();
    let combined = &json["stages"][1]["observables"]["pressure"];
    // The mean of the three runs' means, each as analyze gives it alone.
    let alone: Vec<f64> = names
        .iter()
        .map(|n| {
            let (_, j, _) = analyze_cli(&[n, "--json"]);
            j.unwrap()["stages"][1]["observables"]["pressure"]["mean"]
                .as_f64()
                .unwrap()
        })
        .collect();
    let mean = alone.iter().sum::<f64>() / 3.0;
    assert!((combined["mean"].as_f64().unwrap() - mean).abs() < 1e-12);
    assert_eq!(combined["replicas"].as_u64(), Some(3));
    let spread = combined["spread"].as_f64().unwrap();
    assert!(combined["error"].as_f64().unwrap() >= spread / 3f64.sqrt() - 1e-15);
    // A run of another scene (longer) is no replica.
    let other = dir.join("other.mcap");
    stats_of(&scene(4, 2400), &other);
    let (code, _, err) = analyze_cli(&[names[0], other.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not a replica"), "{err}");
}
