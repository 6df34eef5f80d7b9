//! Scenes end to end: the good and bad scene files, the parser under random
//! mutation, a run through every kind of stage with its log read back, the
//! hand-off between stages, failures that leave existing files alone,
//! interruption, a log cut off mid-write, and the log decoded by the
//! standard Python readers.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

mod common;

use common::{cut_after_frames, scene_files};
use hardbody::log::read::read_log;
use hardbody::log::{StateRecord, partial_path};
use hardbody::run::{RunError, Silent, resume_run, run_scene, system_from_record};
use hardbody::scene::plan::Plan;
use hardbody::scene::{Scene, SceneError};
use rand::{Rng, SeedableRng};

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hardbody-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn every_shipped_scene_is_valid() {
    let files = scene_files("data/scenes");
    assert!(files.iter().any(|p| p.ends_with("default.ron")));
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        if let Err(e) = Scene::parse(&text) {
            panic!("{}: {e}", path.display());
        }
    }
}

#[test]
fn every_bad_scene_gives_its_message() {
    let files = scene_files("data/scenes/bad");
    assert!(files.len() >= 10);
    let mut wrong = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let expect = text
            .lines()
            .next()
            .and_then(|l| l.strip_prefix("// expect: "))
            .unwrap_or_else(|| panic!("{}: first line must be // expect: ...", path.display()));
        match Scene::parse(&text) {
            Ok(_) => wrong.push(format!("{}: accepted", path.display())),
            Err(e) if !e.to_string().contains(expect) => wrong.push(format!(
                "{}: got \"{e}\", expected it to contain \"{expect}\"",
                path.display()
            )),
            Err(_) => {}
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn the_parser_survives_random_mutation() {
    let good: Vec<String> = scene_files("data/scenes")
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    let alphabet = b"(),:[]{}\"0123456789.-+eE_abcxyzSphereNvt \n/*";
    let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
    let (mut rejected, mut accepted) = (0, 0);
    for case in 0..4000 {
        let mut bytes = good[case % good.len()].clone().into_bytes();
        for _ in 0..rng.gen_range(1..4) {
            let at = rng.gen_range(0..bytes.len());
            match rng.gen_range(0..3) {
                0 => {
                    bytes.remove(at);
                }
                1 => bytes.insert(at, alphabet[rng.gen_range(0..alphabet.len())]),
                _ => bytes[at] = alphabet[rng.gen_range(0..alphabet.len())],
            }
        }
        let Ok(text) = String::from_utf8(bytes) else {
            continue;
        };
        // No panic; an error always says where.
        match Scene::parse(&text) {
            Ok(_) => accepted += 1,
            Err(SceneError::Syntax { line, .. }) => {
                assert!(line >= 1);
                rejected += 1;
            }
            Err(SceneError::Invalid { field, .. }) => {
                assert!(!field.is_empty());
                rejected += 1;
            }
        }
    }
    // Most mutations break the scene; some (in comments, digits) do not.
    assert!(rejected > 1000 && accepted > 10, "{rejected} / {accepted}");
}

const SMALL: &str = r#"Scene(
    seed: 5,
    box: (9.0, 9.0, 9.0),
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 48),
        Species(name: "ball", shape: Sphere(radius: 0.4), count: 16),
    ],
    stages: [
        Compress(packing_fraction: 0.30),
        MonteCarlo(ensemble: Npt(pressure: 2.0), sweeps: 100),
        MonteCarlo(ensemble: Nvt, sweeps: 100),
        Dynamics(duration: 0.5, stats_every: 0.1, frames_every: 0.25, msd: true, c2: true),
    ],
    log: Log(path: "unused.mcap", stats_every: 20, frames_every: 50),
)"#;

fn bits(s: &StateRecord) -> Vec<u64> {
    s.positions
        .iter()
        .flatten()
        .chain(s.orientations.iter().flatten())
        .chain(s.box_lengths.iter())
        .map(|x| x.to_bits())
        .collect()
}

#[test]
fn a_scene_runs_every_stage_and_its_log_reads_back() {
    let dir = scratch("run");
    let path = dir.join("small.mcap");
    let scene = Scene::parse(SMALL).unwrap();
    let stop = AtomicBool::new(false);
    let summary = run_scene(&scene, SMALL, &path, &mut Silent, &stop).unwrap();
    assert_eq!(summary.log, path);
    assert_eq!(summary.stages.len(), 4);
    assert!(!summary.interrupted);
    assert!(!partial_path(&path).exists(), "the partial log was renamed");

    let log = read_log(&path, true).unwrap();
    assert!(!log.truncated);
    assert_eq!(log.scene_text(), Some(SMALL));
    assert_eq!(
        Scene::parse(&log.metadata["scene_resolved"]).unwrap(),
        scene
    );
    // Stats: every stage, with the fields its kind measures.
    for (index, kind) in ["compress", "monte_carlo", "monte_carlo", "dynamics"]
        .iter()
        .enumerate()
    {
        let stats: Vec<_> = log
            .stats
            .iter()
            .filter(|(_, s)| s.stage_index == index)
            .map(|(_, s)| s)
            .collect();
        assert!(!stats.is_empty(), "stage {index}");
        assert!(stats.iter().all(|s| s.stage == *kind));
        let last = stats.last().unwrap();
        assert!(last.nematic_order.is_some(), "rods turn: S2 is measured");
        // Undecided overlap tests are counted by the Monte Carlo stages
        // (none here: no test of rods and spheres is left to GJK), the
        // solver's work by the dynamics.
        let monte_carlo = index < 3;
        assert!(
            stats
                .iter()
                .all(|s| s.overlap_strains.is_some() == monte_carlo)
        );
        assert!(stats.iter().all(|s| s.solver.is_some() != monte_carlo));
        match index {
            0 => assert!((last.packing_fraction - 0.30).abs() < 1e-9),
            1 => assert_eq!(last.pressure, Some(2.0)),
            2 => assert!(last.pressure.is_some_and(|p| p > 0.0), "SDF pressure"),
            _ => {
                assert_eq!(last.time, Some(0.5));
                assert!(last.collisions.unwrap() > 0);
                assert!((last.temperature.unwrap() - 1.0).abs() < 1e-9);
                assert!(last.msd.unwrap() > 0.0 && last.c2.unwrap() < 1.0);
                assert_eq!(stats.len(), 5);
            }
        }
    }
    // Log times never go back.
    assert!(log.stats.windows(2).all(|w| w[0].0 <= w[1].0));
    // Every frame is a valid, overlap-free state by an all-pairs check.
    let plan = Plan::of(&scene);
    assert!(log.states.len() >= 8);
    for (_, s) in &log.states {
        let system = system_from_record(s, &plan).unwrap();
        assert_eq!(system.first_overlap_all_pairs(), None);
    }
    // Hand-off: each stage starts from exactly the state the previous one
    // ended with (the stage's first frame against the last frame before).
    for index in 1..4 {
        let first = log
            .states
            .iter()
            .position(|(_, s)| s.stage_index == index)
            .unwrap();
        let (before, after) = (&log.states[first - 1].1, &log.states[first].1);
        assert_eq!(before.stage_index, index - 1);
        assert_eq!(bits(before), bits(after), "hand-off into stage {index}");
    }
    let dynamics: Vec<_> = log
        .states
        .iter()
        .filter(|(_, s)| s.stage == "dynamics")
        .collect();
    assert!(dynamics.iter().all(|(_, s)| s.velocities.is_some()));
}

#[test]
fn a_failing_run_leaves_an_existing_log_alone() {
    let dir = scratch("fail");
    let path = dir.join("precious.mcap");
    std::fs::write(&path, b"an earlier result").unwrap();
    // Five sweeps cannot compress 64 rods from 0.04 to 0.5.
    let text = SMALL.replace(
        "Compress(packing_fraction: 0.30)",
        "Compress(packing_fraction: 0.50, max_sweeps: 5)",
    );
    let scene = Scene::parse(&text).unwrap();
    let err = run_scene(&scene, &text, &path, &mut Silent, &AtomicBool::new(false)).unwrap_err();
    match &err {
        RunError::Stage { index, partial, .. } => {
            assert_eq!(*index, 0);
            assert_eq!(*partial, partial_path(&path));
            // The partial log is complete and readable, and says why.
            let log = read_log(partial, false).unwrap();
            assert!(!log.truncated);
            assert!(log.last_state.is_some());
            let (_, failure) = log.failure.as_ref().expect("a /failure message");
            assert_eq!(failure.stage_index, 0);
            assert!(failure.message.contains("5 sweeps"), "{}", failure.message);
            // Only dynamics failures carry a dump.
            assert_eq!(failure.dump, None);
            // Resumed, it fails the same way; the new log keeps the old
            // frames but not the old failure.
            let again = dir.join("again.mcap");
            let err = resume_run(partial, &again, &mut Silent, &AtomicBool::new(false));
            assert!(matches!(err, Err(RunError::Stage { .. })), "{err:?}");
            let log = read_log(&partial_path(&again), false).unwrap();
            assert_eq!(log.counts.get("/failure"), Some(&1));
        }
        other => panic!("{other}"),
    }
    assert!(!err.is_bad_input());
    assert!(err.to_string().contains("5 sweeps"), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), b"an earlier result");
}

#[test]
fn a_stopped_run_ends_cleanly_with_a_frame() {
    let dir = scratch("stop");
    let path = dir.join("stopped.mcap");
    let scene = Scene::parse(SMALL).unwrap();
    let stop = AtomicBool::new(true);
    let summary = run_scene(&scene, SMALL, &path, &mut Silent, &stop).unwrap();
    assert!(summary.interrupted);
    assert_eq!(summary.stages.len(), 1);
    let log = read_log(&path, true).unwrap();
    assert!(!log.truncated);
    // The start frame and the frame where it stopped.
    assert_eq!(log.states.len(), 2);
    assert_eq!(log.states[1].1.sweep, Some(1));
}

#[test]
fn a_log_cut_off_mid_write_reads_up_to_its_last_frame() {
    let dir = scratch("cut");
    let path = dir.join("whole.mcap");
    let scene = Scene::parse(SMALL).unwrap();
    run_scene(&scene, SMALL, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let whole = read_log(&path, true).unwrap();
    let mut frames_seen = Vec::new();
    for fraction in [0.3, 0.6, 0.9] {
        let cut = dir.join(format!("cut-{fraction}.mcap"));
        std::fs::write(&cut, &bytes[..(bytes.len() as f64 * fraction) as usize]).unwrap();
        let log = read_log(&cut, true).unwrap();
        assert!(log.truncated);
        assert_eq!(log.scene_text(), Some(SMALL));
        // What it has is a prefix of the whole log.
        assert!(!log.states.is_empty());
        for ((t, s), (tw, sw)) in log.states.iter().zip(&whole.states) {
            assert_eq!((t, bits(s)), (tw, bits(sw)));
        }
        frames_seen.push(log.states.len());
    }
    assert!(
        frames_seen.windows(2).all(|w| w[0] <= w[1]),
        "{frames_seen:?}"
    );
}

/// Imports the Python readers, installing them with pip if they are missing
/// (so that `cargo test` alone sets up what it needs).
fn python_with_readers() -> bool {
    let has = || {
        std::process::Command::new("python3")
            .args([
                "-c",
                "import mcap.reader, foxglove_schemas_protobuf.SceneUpdate_pb2, gsd.hoomd",
            ])
            .status()
            .is_ok_and(|s| s.success())
    };
    if has() {
        return true;
    }
    let _ = std::process::Command::new("python3")
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "mcap==1.6.0",
            "foxglove-schemas-protobuf==0.4.0",
            "gsd==5.0.1",
        ])
        .status();
    has()
}

/// Runs `tests/python/SCRIPT` on `args` and returns the JSON it prints,
/// failing with its standard error if it fails.
fn python_report(name: &str, script: &str, args: &[&Path]) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(script);
    let out = std::process::Command::new("python3")
        .arg(&script)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn the_python_readers_decode_every_channel_and_the_gsd_export() {
    assert!(
        python_with_readers(),
        "python3 with the mcap, foxglove-schemas-protobuf and gsd packages is needed (pip install mcap foxglove-schemas-protobuf gsd)"
    );
    let dir = scratch("python");
    for (name, species) in [
        (
            "mixed",
            r#"Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 20),
               Species(name: "brick", shape: Cuboid(a: 0.5, b: 0.3, c: 0.3), count: 20),
               Species(name: "ball", shape: Sphere(radius: 0.4), count: 20),
               Species(name: "blob", shape: Superellipsoid(a: 0.5, b: 0.4, c: 0.4, exponents: (4.0, 4.0, 4.0)), count: 20)"#,
        ),
        (
            "single",
            r#"Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.25), count: 27)"#,
        ),
    ] {
        let text = format!(
            "Scene(box: (9.0, 9.0, 9.0), species: [{species}], stages: [MonteCarlo(ensemble: Nvt, sweeps: 40), Dynamics(duration: 0.05)], log: Log(stats_every: 10, frames_every: 20))"
        );
        let scene = Scene::parse(&text).unwrap();
        let path = dir.join(format!("{name}.mcap"));
        run_scene(&scene, &text, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
        let report = python_report(name, "read_log.py", &[&path]);
        let log = read_log(&path, true).unwrap();
        for (topic, count) in &log.counts {
            assert_eq!(
                report["messages"][topic].as_u64(),
                Some(*count),
                "{name} {topic}"
            );
        }
        // The GSD export, read back by the gsd package against the log.
        let gsd = dir.join(format!("{name}.gsd"));
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_hardbody"))
            .args([
                "export",
                path.to_str().unwrap(),
                "--gsd",
                gsd.to_str().unwrap(),
            ])
            .stdout(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success());
        let report = python_report(name, "read_gsd.py", &[&path, &gsd]);
        assert_eq!(report["frames"].as_u64(), Some(log.states.len() as u64));
    }
}

#[test]
fn a_run_resumed_from_any_frame_continues_bit_for_bit() {
    let dir = scratch("resume");
    let path = dir.join("whole.mcap");
    let scene = Scene::parse(SMALL).unwrap();
    run_scene(&scene, SMALL, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
    let whole = read_log(&path, true).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let mut stages_resumed = std::collections::BTreeSet::new();
    // A cut just after each frame (each frame closes a chunk).
    let cuts: Vec<usize> = (1..whole.states.len())
        .map(|k| cut_after_frames(&bytes, k))
        .collect();
    for (k, &len) in cuts.iter().enumerate() {
        let fraction = format!("frame {k}");
        let cut = dir.join(format!("cut-{k}.mcap.partial"));
        std::fs::write(&cut, &bytes[..len]).unwrap();
        let from = read_log(&cut, false).unwrap().last_state.unwrap().1;
        stages_resumed.insert(from.stage_index);
        let out = dir.join(format!("resumed-{k}.mcap"));
        let summary = hardbody::run::resume_run(&cut, &out, &mut Silent, &AtomicBool::new(false))
            .unwrap_or_else(|e| panic!("{fraction}: {e}"));
        assert!(!summary.interrupted);
        let resumed = read_log(&out, true).unwrap();
        assert_eq!(resumed.scene_text(), Some(SMALL));
        // Every frame, those copied and those computed again, is the
        // uninterrupted run's, at the same log time, bit for bit.
        assert_eq!(resumed.states.len(), whole.states.len(), "{fraction}");
        for (k, ((t, s), (tw, sw))) in resumed.states.iter().zip(&whole.states).enumerate() {
            assert_eq!(t, tw, "{fraction}: frame {k}");
            assert!(
                bits(s) == bits(sw),
                "{fraction}: frame {k} (stage {}) differs",
                s.stage_index
            );
            let v = |s: &StateRecord| {
                s.velocities
                    .iter()
                    .flatten()
                    .flatten()
                    .map(|x| x.to_bits())
                    .collect::<Vec<_>>()
            };
            assert!(v(s) == v(sw), "{fraction}: velocities of frame {k} differ");
        }
    }
    // Resumed from every frame of every stage.
    assert_eq!(stages_resumed.len(), 4, "{stages_resumed:?}");
}

/// Starts `hardbody run` on a scene of 64 rods (compressed to 0.35, then
/// dynamics for `duration` with a frame every 0.5) and returns the child,
/// its log path and the scene text once its partial log holds `frames`
/// dynamics frames.
fn run_until_frames(
    name: &str,
    seed: u64,
    duration: f64,
    frames: usize,
) -> (std::process::Child, PathBuf, String) {
    let exe = env!("CARGO_BIN_EXE_hardbody");
    let dir = scratch(name);
    let text = format!(
        r#"Scene(
        seed: {seed},
        box: (9.0, 9.0, 9.0),
        species: [Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 64)],
        stages: [
            Compress(packing_fraction: 0.35),
            Dynamics(duration: {duration:?}, stats_every: 0.5, frames_every: 0.5),
        ],
    )"#
    );
    let scene_file = dir.join(format!("{name}.ron"));
    std::fs::write(&scene_file, &text).unwrap();
    let log = dir.join(format!("{name}.mcap"));
    let child = std::process::Command::new(exe)
        .args([
            "run",
            scene_file.to_str().unwrap(),
            "--out",
            log.to_str().unwrap(),
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let clock = std::time::Instant::now();
    loop {
        std::thread::sleep(std::time::Duration::from_millis(50));
        if let Ok(l) = read_log(&partial_path(&log), true)
            && l.states
                .iter()
                .filter(|(_, s)| s.stage == "dynamics")
                .count()
                >= frames
        {
            break;
        }
        assert!(
            clock.elapsed().as_secs() < 120,
            "{name}: no frames after two minutes"
        );
    }
    (child, log, text)
}

#[test]
fn a_killed_run_resumes_from_its_partial_log() {
    // Killed (SIGKILL) once a few dynamics frames are on disk.
    let (mut child, killed, text) = run_until_frames("kill", 9, 20.0, 4);
    let partial = partial_path(&killed);
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!killed.exists(), "a killed run leaves only the partial log");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["run", "--resume", partial.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    // The same scene uninterrupted.
    let whole = killed.with_file_name("whole.mcap");
    let scene = Scene::parse(&text).unwrap();
    run_scene(&scene, &text, &whole, &mut Silent, &AtomicBool::new(false)).unwrap();
    let (a, b) = (
        read_log(&killed, true).unwrap(),
        read_log(&whole, true).unwrap(),
    );
    assert!(!a.truncated);
    assert_eq!(a.states.len(), b.states.len());
    let (last_a, last_b) = (&a.states.last().unwrap().1, &b.states.last().unwrap().1);
    assert_eq!(last_a.time, Some(20.0));
    assert!(
        bits(last_a) == bits(last_b),
        "the resumed run ends elsewhere"
    );
}

#[test]
fn ctrl_c_finishes_the_log_cleanly() {
    let (mut child, log, _) = run_until_frames("sigint", 4, 1000.0, 1);
    let sent = std::process::Command::new("kill")
        .args(["-s", "INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let status = child.wait().unwrap();
    assert_eq!(
        status.code(),
        Some(130),
        "exit code of a run stopped by Ctrl-C"
    );
    // The log is complete (footer and summary written) under its name.
    let l = read_log(&log, true).unwrap();
    assert!(!l.truncated);
    assert!(!partial_path(&log).exists());
    let last = &l.states.last().unwrap().1;
    assert_eq!(last.stage, "dynamics");
    assert!(last.time.unwrap() < 1000.0);
    // And it resumes from there.
    assert!(last.resume.as_ref().is_some_and(|r| !r.stage_complete));
}

/// Runs `scene` (spelt `text`) on a rayon pool of `threads` threads into
/// `dir/threads-{threads}.mcap`, and reads back the log with every state.
fn run_on_threads(
    scene: &hardbody::scene::ValidScene,
    text: &str,
    dir: &Path,
    threads: usize,
) -> hardbody::log::read::LogContents {
    let path = dir.join(format!("threads-{threads}.mcap"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| run_scene(scene, text, &path, &mut Silent, &AtomicBool::new(false)).unwrap());
    read_log(&path, true).unwrap()
}

/// A Monte Carlo stage of 4000 rods sweeps on slabs (`hardbody check` says
/// so), here cut across hard walls (the longest axis, z, has them): the run
/// is the same bit for bit on one thread and on two, and a run resumed from
/// its middle frame ends where the whole run did.
#[test]
fn large_monte_carlo_stages_sweep_on_slabs_the_same_on_any_thread_count() {
    const LARGE: &str = r#"Scene(
    seed: 11,
    box: (22.0, 22.0, 24.0),
    walls: [Z],
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 4000),
    ],
    stages: [
        MonteCarlo(ensemble: Nvt, sweeps: 20),
        MonteCarlo(ensemble: Npt(pressure: 1.0), sweeps: 10),
    ],
    log: Log(path: "unused.mcap", stats_every: 5, frames_every: 10),
)"#;
    let scene = Scene::parse(LARGE).unwrap();
    let plan = Plan::of(&scene);
    let report = hardbody::scene::plan::Report {
        scene: &scene,
        plan: &plan,
    }
    .to_string();
    assert!(report.contains("Monte Carlo sweeps: on slabs"), "{report}");
    let dir = scratch("slabs");
    let ends: Vec<(Vec<u64>, usize)> = [1, 2]
        .iter()
        .map(|&threads| {
            let log = run_on_threads(&scene, LARGE, &dir, threads);
            let end = &log.states.last().unwrap().1;
            // Overlap-free by all pairs, and clear of the walls.
            let system = system_from_record(end, &plan).unwrap();
            assert_eq!(system.first_overlap_all_pairs(), None, "{threads} threads");
            assert_eq!(system.first_wall_overlap(), None, "{threads} threads");
            (bits(end), log.states.len())
        })
        .collect();
    assert!(ends[0] == ends[1], "one thread and two end apart");
    // Resumed from the frame after sweep 10 of the first stage.
    let whole = dir.join("threads-2.mcap");
    let bytes = std::fs::read(&whole).unwrap();
    let cut = dir.join("cut.mcap.partial");
    std::fs::write(&cut, &bytes[..cut_after_frames(&bytes, 2)]).unwrap();
    let out = dir.join("resumed.mcap");
    hardbody::run::resume_run(&cut, &out, &mut Silent, &AtomicBool::new(false)).unwrap();
    let resumed = read_log(&out, true).unwrap();
    assert!(
        bits(&resumed.states.last().unwrap().1) == ends[1].0,
        "the resumed run ends elsewhere"
    );
}

/// A Monte Carlo stage of 4000 dense spheres (φ = 0.5), whose slabs are
/// wide enough for the two threads to share one system, compressed by
/// NPT: the run is the same bit for bit on one thread and on two, and no
/// pair overlaps by all pairs.
#[test]
fn dense_spheres_sharing_a_system_run_the_same_on_any_thread_count() {
    const DENSE: &str = r#"Scene(
    seed: 5,
    box: (16.2, 16.2, 16.2),
    species: [
        Species(name: "ball", shape: Sphere(radius: 0.5), count: 4000),
    ],
    stages: [
        MonteCarlo(ensemble: Nvt, sweeps: 30),
        MonteCarlo(ensemble: Npt(pressure: 14.0), sweeps: 20),
    ],
    log: Log(path: "unused.mcap", stats_every: 7, frames_every: 10),
)"#;
    let scene = Scene::parse(DENSE).unwrap();
    let plan = Plan::of(&scene);
    let dir = scratch("shared-spheres");
    let ends: Vec<Vec<u64>> = [1, 2]
        .iter()
        .map(|&threads| {
            let log = run_on_threads(&scene, DENSE, &dir, threads);
            let end = &log.states.last().unwrap().1;
            let system = system_from_record(end, &plan).unwrap();
            assert_eq!(system.first_overlap_all_pairs(), None, "{threads} threads");
            assert!(system.packing_fraction() > 0.49, "{threads} threads");
            if threads == 2 {
                let sweeps = hardbody::mc::parallel::ParallelSweeps::new();
                assert!(
                    sweeps.would_share(&system, 2),
                    "the end state is not shared"
                );
            }
            bits(end)
        })
        .collect();
    assert!(ends[0] == ends[1], "one thread and two end apart");
}

/// Compression stages as a scene writes them: to the jam (ends with
/// success and says where), and to a pressure (then NPT at it); every
/// frame of the log is overlap-free by all pairs, and resuming from the
/// compression's frames continues bit for bit.
#[test]
fn compression_to_the_jam_and_to_a_pressure_through_a_scene() {
    const SCENE: &str = r#"Scene(
    seed: 5,
    box: (12.0, 12.0, 12.0),
    species: [Species(name: "ball", shape: Sphere(radius: 0.5), count: 216)],
    stages: [
        Compress(pressure: 4.0),
        MonteCarlo(ensemble: Npt(pressure: 4.0), sweeps: 400),
        Compress(packing_fraction: 0.74, until_jammed: true),
    ],
    log: Log(path: "unused.mcap", stats_every: 50, frames_every: 200),
)"#;
    let dir = scratch("compress-kinds");
    let path = dir.join("whole.mcap");
    let scene = Scene::parse(SCENE).unwrap();
    let summary = run_scene(&scene, SCENE, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
    assert!(
        summary.stages[0].contains("reached packing fraction"),
        "{:?}",
        summary.stages
    );
    assert!(
        summary.stages[2].contains("jammed at packing fraction"),
        "{:?}",
        summary.stages
    );
    let whole = read_log(&path, true).unwrap();
    let plan = Plan::of(&scene);
    for (_, record) in &whole.states {
        let system = system_from_record(record, &plan).unwrap();
        assert_eq!(
            system.first_overlap_all_pairs(),
            None,
            "stage {}",
            record.stage_index
        );
    }
    let (_, last) = whole.states.last().unwrap();
    assert_eq!(last.stage_index, 2);
    let phi = system_from_record(last, &plan).unwrap().packing_fraction();
    assert!(phi > 0.6 && phi < 0.66, "jammed at {phi}");
    // Resumed from frames of both compressions (two of the first, three
    // of the second): the same log.
    let bytes = std::fs::read(&path).unwrap();
    let of_stage = |i: usize| -> Vec<usize> {
        (1..whole.states.len())
            .filter(|&k| whole.states[k - 1].1.stage_index == i)
            .collect()
    };
    let (first, second) = (of_stage(0), of_stage(2));
    let picked = [
        first[1.min(first.len() - 1)],
        first[first.len() / 2],
        second[0],
        second[second.len() / 2],
        second[second.len() - 1],
    ];
    for k in picked {
        let cut = dir.join(format!("cut-{k}.mcap.partial"));
        std::fs::write(&cut, &bytes[..cut_after_frames(&bytes, k)]).unwrap();
        let out = dir.join(format!("resumed-{k}.mcap"));
        resume_run(&cut, &out, &mut Silent, &AtomicBool::new(false)).unwrap();
        let resumed = read_log(&out, true).unwrap();
        assert_eq!(resumed.states.len(), whole.states.len(), "frame {k}");
        assert!(
            bits(&resumed.states.last().unwrap().1) == bits(&whole.states.last().unwrap().1),
            "frame {k}"
        );
    }
}

/// A run taken step by step, paused part way through every stage, writes
/// the states of the run in one go: the Monte Carlo stages' bit for bit
/// at every log time both hold a frame, the dynamics' (which restarts
/// its predictions at a pause) to round-off.
#[test]
fn a_run_taken_step_by_step_gives_the_run_in_one_go() {
    use hardbody::run::{Advance, Simulation};
    let dir = scratch("steps");
    let scene = Scene::parse(SMALL).unwrap();
    let whole_path = dir.join("whole.mcap");
    run_scene(
        &scene,
        SMALL,
        &whole_path,
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap();
    let stop = AtomicBool::new(false);
    let steps_path = dir.join("steps.mcap");
    let mut sim = Simulation::new(&scene, SMALL, &steps_path).unwrap();
    // Stage 0 (compress): 7 sweeps, then the rest.
    let step = sim.advance(Advance::Sweeps(7), &mut Silent, &stop).unwrap();
    assert!(!step.stage_done && sim.paused() && step.stage_index == 0);
    assert_eq!(sim.state().unwrap().sweep, Some(7));
    assert!(sim.run_stage(&mut Silent, &stop).unwrap().stage_done);
    // Stages 1 and 2 (NPT, NVT): pauses off the output cadence.
    for _ in 0..2 {
        let mut done = false;
        while !done {
            done = sim
                .advance(Advance::Sweeps(33), &mut Silent, &stop)
                .unwrap()
                .stage_done;
        }
    }
    // Stage 3 (dynamics) runs in time, not sweeps.
    let e = sim
        .advance(Advance::Sweeps(10), &mut Silent, &stop)
        .unwrap_err();
    assert!(e.to_string().contains("dynamics stage"), "{e}");
    let step = sim
        .advance(Advance::Time(0.13), &mut Silent, &stop)
        .unwrap();
    assert!(!step.stage_done);
    assert!((sim.state().unwrap().time.unwrap() - 0.13).abs() < 1e-12);
    assert!(sim.run_stage(&mut Silent, &stop).unwrap().stage_done);
    assert_eq!(sim.stage_index(), None);
    let e = sim.run_stage(&mut Silent, &stop).unwrap_err();
    assert!(e.to_string().contains("every stage"), "{e}");
    let summary = sim.finish().unwrap();
    assert_eq!(summary.stages.len(), 4);
    assert!(!summary.interrupted);

    let whole = read_log(&whole_path, true).unwrap();
    let steps = read_log(&steps_path, true).unwrap();
    // The pauses add frames; every frame of the whole run is there.
    assert!(steps.states.len() > whole.states.len());
    let mut compared = 0;
    for (t, s) in &whole.states {
        let (_, p) = steps
            .states
            .iter()
            .find(|(tp, _)| tp == t)
            .unwrap_or_else(|| panic!("no frame at log time {t}"));
        if s.stage == "dynamics" && s.time.unwrap() > 0.13 {
            let worst = s
                .positions
                .iter()
                .flatten()
                .zip(p.positions.iter().flatten())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-8, "log time {t}: positions differ by {worst}");
        } else {
            assert!(
                bits(s) == bits(p),
                "log time {t} (stage {}) differs",
                s.stage_index
            );
        }
        compared += 1;
    }
    assert_eq!(compared, whole.states.len());
    // The /stats messages at the output cadence are the same, too.
    let at_cadence: Vec<_> = steps
        .stats
        .iter()
        .filter(|(t, _)| whole.stats.iter().any(|(tw, _)| tw == t))
        .collect();
    assert_eq!(at_cadence.len(), whole.stats.len());
}

/// A configuration set between steps is checked: overlapping bodies are
/// refused with the state unchanged; a rigid shift of every body is
/// taken and the run goes on from it.
#[test]
fn a_configuration_set_between_steps_is_checked() {
    use hardbody::run::{Advance, Simulation};
    let dir = scratch("set-state");
    let scene = Scene::parse(SMALL).unwrap();
    let stop = AtomicBool::new(false);
    let mut sim = Simulation::new(&scene, SMALL, &dir.join("set.mcap")).unwrap();
    sim.run_stage(&mut Silent, &stop).unwrap();
    sim.advance(Advance::Sweeps(10), &mut Silent, &stop)
        .unwrap();
    let before = sim.state().unwrap();
    let mut positions = before.positions.clone();
    positions[1] = positions[0];
    let e = sim
        .set_configuration(&positions, &before.orientations)
        .unwrap_err();
    assert!(e.to_string().contains("overlap"), "{e}");
    assert!(bits(&sim.state().unwrap()) == bits(&before));
    let mut bad = before.orientations.clone();
    bad[3] = [2.0, 0.0, 0.0, 0.0];
    let e = sim.set_configuration(&before.positions, &bad).unwrap_err();
    assert!(e.to_string().contains("unit quaternion"), "{e}");
    let shifted: Vec<[f64; 3]> = before
        .positions
        .iter()
        .map(|p| [p[0] + 0.25, p[1], p[2]])
        .collect();
    sim.set_configuration(&shifted, &before.orientations)
        .unwrap();
    let after = sim.state().unwrap();
    // Shifted by 0.25, or by 0.25 less the box edge where it wrapped.
    let off = after.positions[5][0] - before.positions[5][0] - 0.25;
    let l = after.box_lengths[0];
    assert!(off.abs() < 1e-12 || (off.abs() - l).abs() < 1e-12, "{off}");
    while sim.stage_index().is_some() {
        sim.run_stage(&mut Silent, &stop).unwrap();
    }
    sim.finish().unwrap();
}
