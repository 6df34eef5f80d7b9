//! Behaviour pinned: every shipped scene, shortened, writes the same
//! `/state` and `/stats` messages byte for byte as the reference recorded
//! in `tests/golden/states.txt`. A change that alters any trajectory, start,
//! compression or hand-off fails here.
//!
//! After a deliberate change of behaviour, record the new reference with
//! `HARDBODY_BLESS=1 cargo test --release --test golden` and say why in the
//! commit.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::AtomicBool;

use common::scene_files;
use hardbody::log::read::{ReadOptions, read_log_with};
use hardbody::run::{Silent, run_scene};
use hardbody::scene::{Scene, Stage, ValidScene};

const REFERENCE: &str = "tests/golden/states.txt";

/// The scene cut short: Monte Carlo stages of at most 300 sweeps, dynamics
/// of at most 1 time unit, compressions to at most φ = 0.45, jams at
/// γ ≥ 10⁻² to βPV/N = 10⁴ at most, and
/// frames often enough that every stage writes several.
fn shortened(scene: ValidScene) -> ValidScene {
    let mut scene = scene.into_scene();
    scene.log.frames_every = 50;
    scene.log.stats_every = 50;
    for stage in &mut scene.stages {
        match stage {
            Stage::Compress {
                packing_fraction: Some(phi),
                ..
            } => *phi = phi.min(0.45),
            Stage::Compress { .. } => {}
            Stage::MonteCarlo { sweeps, .. } => *sweeps = (*sweeps).min(300),
            Stage::Dynamics {
                duration,
                stats_every,
                frames_every,
                ..
            } => {
                *duration = duration.min(1.0);
                *stats_every = Some(*duration / 5.0);
                *frames_every = Some(*duration / 4.0);
            }
            Stage::Jam {
                growth_rate,
                pressure,
                ..
            } => {
                *growth_rate = Some(growth_rate.unwrap_or(0.0).max(1e-2));
                *pressure = Some(pressure.unwrap_or(1e4).min(1e4));
            }
        }
    }
    scene.validated().expect("a shortened scene is valid")
}

/// FNV-1a over the bytes: enough to tell any change (nothing here is
/// adversarial), and the same on every platform and toolchain.
fn fnv1a(hash: &mut u64, bytes: &[u8]) {
    for &b in bytes {
        *hash ^= u64::from(b);
        *hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
}

/// Number of `/state` messages and the digest of their log times and
/// bytes, and the same of the `/stats` messages.
fn state_digest(path: &Path) -> (usize, u64, usize, u64) {
    let log = read_log_with(
        path,
        ReadOptions {
            all_states: false,
            messages: true,
        },
    )
    .unwrap();
    assert!(
        log.failure.is_none(),
        "{}: {:?}",
        path.display(),
        log.failure
    );
    let digest = |wanted: &str| {
        let mut hash = 0xcbf2_9ce4_8422_2325;
        let mut count = 0;
        for (topic, time, data) in &log.messages {
            if topic == wanted {
                fnv1a(&mut hash, &time.to_le_bytes());
                fnv1a(&mut hash, data);
                count += 1;
            }
        }
        (count, hash)
    };
    let (states, state_hash) = digest("/state");
    let (stats, stats_hash) = digest("/stats");
    (states, state_hash, stats, stats_hash)
}

/// Every shipped scene, shortened and run once for the tests of this
/// file: (name, scene as run, text, log).
fn shortened_runs() -> &'static [(String, ValidScene, PathBuf)] {
    static RUNS: OnceLock<Vec<(String, ValidScene, PathBuf)>> = OnceLock::new();
    RUNS.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        scene_files("data/scenes")
            .iter()
            .map(|file| {
                let name = file.file_stem().unwrap().to_string_lossy().to_string();
                let text = std::fs::read_to_string(file).unwrap();
                let scene = shortened(Scene::parse(&text).unwrap());
                let out = dir.join(format!("{name}.mcap"));
                run_scene(&scene, &text, &out, &mut Silent, &AtomicBool::new(false))
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
                (name, scene, out)
            })
            .collect()
    })
}

#[test]
fn every_shipped_scene_writes_the_reference_states() {
    let reference_path = Path::new(env!("CARGO_MANIFEST_DIR")).join(REFERENCE);
    let measured: BTreeMap<String, (usize, u64, usize, u64)> = shortened_runs()
        .iter()
        .map(|(name, _, log)| (name.clone(), state_digest(log)))
        .collect();

    let lines: String = measured
        .iter()
        .map(|(name, (count, hash, stats, stats_hash))| {
            format!("{name} {count} {hash:016x} {stats} {stats_hash:016x}\n")
        })
        .collect();
    if std::env::var_os("HARDBODY_BLESS").is_some() {
        std::fs::write(&reference_path, &lines).unwrap();
        return;
    }
    let reference = std::fs::read_to_string(&reference_path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (record it with HARDBODY_BLESS=1)",
            reference_path.display()
        )
    });
    for (name, (count, ..)) in &measured {
        assert!(*count >= 2, "{name}: only {count} frames");
    }
    let differing: Vec<_> = lines
        .lines()
        .zip(reference.lines())
        .filter(|(now, then)| now != then)
        .collect();
    assert!(
        differing.is_empty() && lines.lines().count() == reference.lines().count(),
        "states differ from the reference (now, then): {differing:?}"
    );
}

/// `hardbody check` tells the truth: on every shipped scene, what the
/// plan says of the start's orientations, of each dynamics stage's
/// neighbour structure and of the nematic order is what the run then did.
#[test]
fn the_plan_says_what_the_run_does() {
    use hardbody::log::read::read_log;
    use hardbody::scene::plan::Plan;
    let (mut aligned, mut cells, mut lists) = (0, 0, 0);
    for (name, scene, out) in shortened_runs() {
        let plan = Plan::of(scene);
        let log = read_log(out, true).unwrap();
        let volumes: Vec<f64> = plan
            .species
            .iter()
            .map(|s| s.species.shape.volume())
            .collect();

        let first = &log.states[0].1;
        let identity = |q: &[f64; 4]| (q[0].abs() - 1.0).abs() < 1e-12;
        let turns = plan.species.iter().any(|s| !s.species.shape.is_sphere());
        match plan.random_orientations {
            Some(false) => {
                aligned += 1;
                assert!(
                    first.orientations.iter().all(identity),
                    "{name}: aligned start"
                );
            }
            Some(true) if turns => assert!(
                !first.orientations.iter().all(identity),
                "{name}: random orientations"
            ),
            _ => {}
        }

        for (index, shell) in &plan.dynamics_shells {
            let Some(shell) = shell else { continue };
            let (_, start) = log
                .states
                .iter()
                .find(|(_, s)| s.stage_index == *index)
                .unwrap();
            let volume: f64 = start.species_of.iter().map(|&k| volumes[k as usize]).sum();
            let phi = volume / start.box_lengths.iter().product::<f64>();
            // What the dynamics stage was built with (run/dynamics.rs).
            assert_eq!(
                scene.neighbour_shell(phi),
                *shell,
                "{name}: stage {index} starts at phi {phi}"
            );
            match shell {
                None => cells += 1,
                Some(_) => lists += 1,
            }
        }

        let measured = log.stats.iter().any(|(_, s)| s.nematic_order.is_some());
        assert_eq!(measured, plan.nematic_order, "{name}: nematic order");
    }
    assert!(
        aligned > 0 && cells > 0 && lists > 0,
        "{aligned} {cells} {lists}"
    );
}

/// `hardbody check --json` is the plan the run then used: on every shipped
/// scene, each stage's entry of the plan equals what the run recorded of
/// that stage as its driver was built (the log's `hardbody.stage`
/// metadata: the Monte Carlo system's neighbour structure, the dynamics'
/// lists or cells). A default changed on either side alone fails here.
#[test]
fn check_json_is_the_plan_the_run_records() {
    use hardbody::log::read::read_log;
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden-plans");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut compared = BTreeMap::<String, usize>::new();
    for (name, scene, out) in shortened_runs() {
        let file = dir.join(format!("{name}.ron"));
        std::fs::write(&file, scene.to_ron()).unwrap();
        let check = std::process::Command::new(env!("CARGO_BIN_EXE_hardbody"))
            .args(["check", "--json"])
            .arg(&file)
            .output()
            .unwrap();
        assert!(check.status.success(), "{name}: {check:?}");
        let plan: serde_json::Value = serde_json::from_slice(&check.stdout).unwrap();
        let log = read_log(out, false).unwrap();
        let stages = plan["stages"].as_array().unwrap();
        assert_eq!(stages.len(), scene.stages.len(), "{name}");
        for planned in stages {
            let index = planned["stage"].as_u64().unwrap() as usize;
            let recorded: serde_json::Value = serde_json::from_str(
                log.stage_plans
                    .get(&index)
                    .unwrap_or_else(|| panic!("{name}: no record of stage {index}")),
            )
            .unwrap();
            let kind = planned["kind"].as_str().unwrap().to_string();
            assert_eq!(recorded["kind"], planned["kind"], "{name}: stage {index}");
            if planned["neighbours"] == "decided at the stage's start" {
                assert!(recorded["neighbours"].is_object(), "{name}: stage {index}");
                continue;
            }
            assert_eq!(
                &recorded, planned,
                "{name}: stage {index}: the run's record, then the plan"
            );
            *compared.entry(kind).or_default() += 1;
        }
    }
    for kind in ["compress", "monte_carlo", "dynamics", "jam"] {
        assert!(compared.get(kind).is_some_and(|&n| n > 0), "{compared:?}");
    }
}

/// The README's tutorial shows what `hardbody check` prints for its
/// scene, to the character: a default or a message changed without the
/// README fails here.
#[test]
fn the_readme_shows_what_check_prints() {
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let scene = "data/scenes/tutorial_rods.ron";
    let check = std::process::Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["check", scene])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(check.status.success(), "{check:?}");
    let printed = String::from_utf8(check.stdout).unwrap();
    let shown = readme
        .split("```text\n")
        .filter_map(|block| block.split("\n```").next())
        .find(|block| block.starts_with(&format!("{scene}: valid")))
        .expect("the README shows the tutorial scene's check");
    assert_eq!(shown, printed.trim_end(), "README, then what check prints");
}
