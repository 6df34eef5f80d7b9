//! The surfaces added with the Python package, sweeps, jamming and
//! `analyze`, as an adversary tried them (issue 51): one regression test
//! per fault, named `item_NN_...` after the issue's numbering.
//! docs/RELIABILITY.md lists the promises they check.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::AtomicBool;

mod common;

use common::cut_after_frames;
use hardbody::log::partial_path;
use hardbody::log::read::read_log;
use hardbody::run::{RunError, Silent, run_scene};
use hardbody::scene::Scene;

const EXE: &str = env!("CARGO_BIN_EXE_hardbody");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hardbody-surf-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// 24 rods and 8 balls: compressed, a little Monte Carlo and a little
/// dynamics, a frame every 20 sweeps and every 0.25 time units.
fn small(seed: u64, start: &str) -> String {
    format!(
        r#"Scene(
    seed: {seed},
    box: (7.0, 7.0, 7.0),
    start: {start},
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 24),
        Species(name: "ball", shape: Sphere(radius: 0.4), count: 8),
    ],
    stages: [
        Compress(packing_fraction: 0.25),
        MonteCarlo(ensemble: Nvt, sweeps: 60),
        Dynamics(duration: 0.5, stats_every: 0.1, frames_every: 0.25),
    ],
    log: Log(path: "unused.mcap", stats_every: 10, frames_every: 20),
)"#
    )
}

/// A sweep of `small` over seeds 1 and 2, made in `dir/w`.
fn two_seed_sweep(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("t.ron"), small(1, "Lattice")).unwrap();
    let w = dir.join("w");
    let (code, err) = cli(&[
        "sweep",
        s(&dir.join("t.ron")),
        "--set",
        "seed=1,2",
        "--workspace",
        s(&w),
    ]);
    assert_eq!(code, 0, "{err}");
    w
}

fn run_to(text: &str, path: &Path) {
    let scene = Scene::parse(text).unwrap();
    run_scene(&scene, text, path, &mut Silent, &AtomicBool::new(false)).unwrap();
}

/// Runs the command line; (exit code, standard output and error).
fn cli(args: &[&str]) -> (i32, String) {
    let out = Command::new(EXE)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    (
        out.status.code().expect("exited, not killed by a signal"),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn write(path: &Path, text: &str) -> PathBuf {
    std::fs::write(path, text).unwrap();
    path.to_path_buf()
}

/// A killed run's partial log at `path`: the first `k` frames of `log`.
fn cut_to(log: &Path, k: usize, path: &Path) {
    let bytes = std::fs::read(log).unwrap();
    std::fs::write(path, &bytes[..cut_after_frames(&bytes, k)]).unwrap();
}

#[test]
fn item_01_a_scene_never_replaces_the_log_it_starts_from() {
    let dir = scratch("resume-start");
    let log = dir.join("x.mcap");
    run_to(&small(1, "Lattice"), &log);
    let before = std::fs::read(&log).unwrap();
    let partial = partial_path(&dir.join("y.mcap"));
    std::fs::copy(&log, &partial).unwrap();
    let partial_before = std::fs::read(&partial).unwrap();
    for (start, out) in [(&log, &log), (&partial, &dir.join("y.mcap"))] {
        let text = small(2, &format!("Resume({:?})", s(start))).replace("unused.mcap", s(out));
        let scene = write(&dir.join("s.ron"), &text);
        // The scene's own log path, and the same path given by --out.
        for args in [
            vec!["run", s(&scene)],
            vec!["check", s(&scene)],
            vec!["run", s(&scene), "--out", s(out)],
        ] {
            let (code, err) = cli(&args);
            assert_eq!(code, 2, "{args:?}: {err}");
            assert!(err.contains("is the input"), "{args:?}: {err}");
        }
        // The library refuses it too, whoever calls it.
        let parsed = Scene::parse(&text).unwrap();
        let refused = run_scene(&parsed, &text, out, &mut Silent, &AtomicBool::new(false));
        assert!(matches!(refused, Err(RunError::Output(_))), "{refused:?}");
    }
    assert!(std::fs::read(&log).unwrap() == before);
    assert!(std::fs::read(&partial).unwrap() == partial_before);
    // Written elsewhere, the same scene runs.
    let text =
        small(2, &format!("Resume({:?})", s(&log))).replace("unused.mcap", s(&dir.join("z.mcap")));
    let scene = write(&dir.join("s.ron"), &text);
    let (code, err) = cli(&["run", s(&scene)]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn item_02_continue_never_replaces_a_complete_log_with_a_stray_partial() {
    let dir = scratch("stray");
    let a = write(&dir.join("a.ron"), &small(1, "Lattice"));
    let b = write(&dir.join("b.ron"), &small(2, "Lattice"));
    let out = dir.join("job.mcap");
    run_to(&small(1, "Lattice"), &out);
    let other = dir.join("other.mcap");
    run_to(&small(2, "Lattice"), &other);
    cut_to(&other, 3, &partial_path(&out));
    let complete = std::fs::read(&out).unwrap();
    let stray = std::fs::read(partial_path(&out)).unwrap();
    let (code, err) = cli(&["run", s(&a), "--out", s(&out), "--continue"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("nothing to do"), "{err}");
    // A complete log of another scene is not this job's result.
    let (code, err) = cli(&["run", s(&b), "--out", s(&out), "--continue"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("seed 1") && err.contains("seed 2"), "{err}");
    assert!(std::fs::read(&out).unwrap() == complete);
    assert!(std::fs::read(partial_path(&out)).unwrap() == stray);
}

#[test]
fn item_03_a_link_at_a_partial_path_is_never_written_through() {
    let dir = scratch("links");
    let victim = write(&dir.join("victim.txt"), "another user's file\n");
    let scene = write(&dir.join("s.ron"), &small(1, "Lattice"));
    let linked = |path: &Path| {
        let _ = std::fs::remove_file(path);
        std::os::unix::fs::symlink(&victim, path).unwrap();
    };
    // The partial log of a run.
    let out = dir.join("x.mcap");
    linked(&partial_path(&out));
    let (code, err) = cli(&["run", s(&scene), "--out", s(&out)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("symbolic link"), "{err}");
    // The file an in-place resume writes first.
    let log = dir.join("l.mcap");
    run_to(&small(1, "Lattice"), &log);
    let resumed = dir.join("r.mcap");
    cut_to(&log, 3, &partial_path(&resumed));
    let mut resuming = partial_path(&resumed).into_os_string();
    resuming.push(".resuming");
    linked(Path::new(&resuming));
    let (code, err) = cli(&["run", "--resume", s(&partial_path(&resumed))]);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("symbolic link"), "{err}");
    // A GSD export's partial file.
    let gsd = dir.join("x.gsd");
    linked(&partial_path(&gsd));
    let (code, err) = cli(&["export", s(&log), "--gsd", s(&gsd)]);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("symbolic link"), "{err}");
    assert_eq!(
        std::fs::read_to_string(&victim).unwrap(),
        "another user's file\n"
    );
    assert!(!gsd.exists());
}

#[test]
fn item_04_plots_never_write_through_links_or_over_an_input() {
    let dir = scratch("plots");
    let log = dir.join("l.mcap");
    run_to(&small(1, "Lattice"), &log);
    // The plots' names, from a clean folder.
    let clean = dir.join("clean");
    for args in [
        vec!["analyze", s(&log), "--plot", s(&clean)],
        vec!["analyze", s(&log), "--packing", "--plot", s(&clean)],
    ] {
        let (code, err) = cli(&args);
        assert_eq!(code, 0, "{err}");
    }
    let names: Vec<_> = std::fs::read_dir(&clean)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(names.len() >= 4, "{names:?}");
    // Every plot's name a link to a file of someone else's.
    let linked = dir.join("linked");
    std::fs::create_dir_all(&linked).unwrap();
    let victim = write(&dir.join("victim.txt"), "keep me\n");
    for name in &names {
        std::os::unix::fs::symlink(&victim, linked.join(name)).unwrap();
    }
    for args in [
        vec!["analyze", s(&log), "--plot", s(&linked)],
        vec!["analyze", s(&log), "--packing", "--plot", s(&linked)],
    ] {
        let (code, err) = cli(&args);
        assert_eq!(code, 0, "{err}");
    }
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me\n");
    for name in &names {
        let plot = std::fs::read_to_string(linked.join(name)).unwrap();
        assert!(plot.contains("<svg"), "{name:?}");
    }
    // The input log under a plot's name, in the plot folder.
    for name in &names {
        let input = linked.join(name);
        std::fs::copy(&log, &input).unwrap();
        let before = std::fs::read(&input).unwrap();
        let stage_plot = name.to_string_lossy().starts_with("stage");
        let mut args = vec!["analyze", s(&input), "--plot", s(&linked)];
        if !stage_plot {
            args.insert(2, "--packing");
        }
        let (code, err) = cli(&args);
        assert_eq!(code, 2, "{name:?}: {err}");
        assert!(err.contains("is the input"), "{err}");
        assert!(std::fs::read(&input).unwrap() == before, "{name:?}");
    }
}

#[test]
fn item_08_continue_refuses_a_partial_log_of_another_scene() {
    let dir = scratch("continue-scene");
    let a = write(&dir.join("a.ron"), &small(1, "Lattice"));
    let out = dir.join("job.mcap");
    let full = dir.join("full.mcap");
    run_to(&small(1, "Lattice"), &full);
    cut_to(&full, 3, &partial_path(&out));
    let partial = std::fs::read(partial_path(&out)).unwrap();
    // Another seed, another pressure, or a scene file that is gone.
    let b = write(&dir.join("b.ron"), &small(7, "Lattice"));
    let c = write(
        &dir.join("c.ron"),
        &small(1, "Lattice").replace("sweeps: 60", "sweeps: 80"),
    );
    for (scene, says) in [
        (b.clone(), "seed"),
        (c, "a scene other than"),
        (dir.join("gone.ron"), "gone.ron"),
    ] {
        let (code, err) = cli(&["run", s(&scene), "--out", s(&out), "--continue"]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(says), "{says}: {err}");
        assert!(std::fs::read(partial_path(&out)).unwrap() == partial);
        assert!(!out.exists());
    }
    // --seed names the run the partial log is of.
    let (code, err) = cli(&["run", s(&b), "--out", s(&out), "--continue", "--seed", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(same_last_state(&out, &full));
    // Its own scene continues it, bit for bit.
    std::fs::remove_file(&out).unwrap();
    cut_to(&full, 3, &partial_path(&out));
    let (code, err) = cli(&["run", s(&a), "--out", s(&out), "--continue"]);
    assert_eq!(code, 0, "{err}");
    assert!(same_last_state(&out, &full));
}

/// Whether two logs end in the same state, bit for bit.
fn same_last_state(a: &Path, b: &Path) -> bool {
    let last = |p: &Path| {
        let (time, state) = read_log(p, false).unwrap().last_state.unwrap();
        let bits: Vec<u64> = state
            .positions
            .iter()
            .flatten()
            .chain(state.orientations.iter().flatten())
            .chain(state.velocities.iter().flatten().flatten())
            .map(|x| x.to_bits())
            .collect();
        (time, bits)
    };
    last(a) == last(b)
}

#[test]
fn item_07_one_run_is_never_averaged_as_two_replicas() {
    let dir = scratch("replicas");
    let a = dir.join("a.mcap");
    run_to(&small(1, "Lattice"), &a);
    let b = dir.join("b.mcap");
    run_to(&small(2, "Lattice"), &b);
    let copy = dir.join("copy.mcap");
    std::fs::copy(&a, &copy).unwrap();
    let (early, late) = (dir.join("early.mcap"), dir.join("late.mcap"));
    cut_to(&a, 2, &early);
    cut_to(&a, 5, &late);
    for (x, y) in [(&a, &copy), (&early, &late)] {
        let (code, err) = cli(&["analyze", s(x), s(y)]);
        assert_eq!(code, 2, "{err}");
        assert!(
            err.contains("the same run") && err.contains("seed 1"),
            "{err}"
        );
    }
    let (code, err) = cli(&["analyze", s(&a), s(&b)]);
    assert_eq!(code, 0, "{err}");
    // A sweep job holding another job's log is not averaged.
    let w = two_seed_sweep(&dir);
    let mut jobs: Vec<PathBuf> = std::fs::read_dir(w.join("workspace"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    jobs.sort();
    let first = &jobs[0];
    let (code, err) = cli(&[
        "run",
        s(&first.join("scene.ron")),
        "--out",
        s(&first.join("log.mcap")),
    ]);
    assert_eq!(code, 0, "{err}");
    std::fs::copy(first.join("log.mcap"), jobs[1].join("log.mcap")).unwrap();
    let out = Command::new(EXE)
        .args(["sweep", "collect", s(&w), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let row = &rows[0];
    assert_eq!(row["finished"], 1, "{row}");
    assert_eq!(row["foreign"], 1, "{row}");
    let (code, err) = cli(&["sweep", "collect", s(&w)]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("another scene"), "{err}");
}

/// 64 spheres of two species, of masses 1 and `heavy`, compressed to
/// 0.3 and grown at 10⁻² to βPV/N = 10⁸.
fn two_masses(heavy: f64) -> String {
    format!(
        r#"Scene(
    seed: 3,
    box: (6.0, 6.0, 6.0),
    species: [
        Species(name: "light", shape: Sphere(radius: 0.5), count: 32),
        Species(name: "heavy", shape: Sphere(radius: 0.5), count: 32, mass: {heavy:e}),
    ],
    stages: [Compress(packing_fraction: 0.3), Jam(growth_rate: 1e-2, pressure: 1e8)],
    log: Log(path: "unused.mcap"),
)"#
    )
}

#[test]
fn item_05_a_jam_does_not_depend_on_the_masses() {
    let dir = scratch("jam-masses");
    let last = |heavy: f64| {
        let log = dir.join(format!("m{heavy:e}.mcap"));
        run_to(&two_masses(heavy), &log);
        read_log(&log, false).unwrap().last_state.unwrap().1
    };
    let equal = last(1.0);
    let phi = |s: &hardbody::log::StateRecord| {
        let volume: f64 = s.box_lengths.iter().product();
        64.0 * s.species[0].shape.volume() / volume
    };
    assert!(phi(&equal) > 0.6, "phi {}", phi(&equal));
    for heavy in [1e-6, 1e6] {
        let other = last(heavy);
        // The same packing, bit for bit: the growth never sees a mass.
        assert!(other.positions == equal.positions, "mass {heavy:e}");
    }
}

#[test]
fn item_12_22_jams_that_would_never_end_or_call_a_gas_jammed_are_refused() {
    let jam = |stage: &str| {
        small(1, "Lattice").replace(
            "Dynamics(duration: 0.5, stats_every: 0.1, frames_every: 0.25)",
            stage,
        )
    };
    for (stage, says) in [
        ("Jam(growth_rate: 1e-9)", "growth_rate"),
        ("Jam(growth_rate: 1e-300)", "growth_rate"),
        ("Jam(fluid_rate: 1e-7)", "fluid_rate"),
        ("Jam(pressure: 1.0000001)", "pressure"),
        ("Jam(pressure: 100.0)", "pressure"),
    ] {
        let err = Scene::parse(&jam(stage)).unwrap_err().to_string();
        assert!(err.contains(says), "{stage}: {err}");
    }
    // In a box the grown bodies fit (64 spheres), the bounds are taken.
    for stage in ["Jam(growth_rate: 1e-6, pressure: 1e3)", "Jam()"] {
        let text = two_masses(1.0).replace("Jam(growth_rate: 1e-2, pressure: 1e8)", stage);
        assert!(Scene::parse(&text).is_ok(), "{stage}");
    }
}

#[test]
fn item_10_a_damaged_or_cut_log_says_what_is_analysed() {
    let dir = scratch("damaged-analyze");
    let log = dir.join("l.mcap");
    run_to(&small(1, "Lattice"), &log);
    // Cut after three frames, as a kill leaves it.
    let cut = dir.join("cut.mcap");
    cut_to(&log, 3, &cut);
    let (code, err) = cli(&["analyze", s(&cut)]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("ends before its footer"), "{err}");
    let out = Command::new(EXE)
        .args(["analyze", s(&cut), "--json"])
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["truncated"], true);
    let out = Command::new(EXE)
        .args(["analyze", s(&log), "--json"])
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["truncated"], false);
    assert!(json["damage"].is_null());
    // A frame whose orientation is no unit quaternion (item 11) is
    // damage: the packing analysed is the last intact frame, and the
    // command says so.
    let bytes = std::fs::read(&log).unwrap();
    let contents = read_log(&log, true).unwrap();
    let frames = contents.states.len();
    let (_, last) = contents.states.last().unwrap();
    let q = last.orientations[0];
    let resolved = contents.metadata.get("scene_resolved").unwrap();
    let plan = hardbody::scene::plan::Plan::of(&Scene::parse(resolved).unwrap());
    let mut writer = hardbody::log::LogWriter::create(
        &dir.join("bad.mcap"),
        contents.scene_text().unwrap(),
        resolved,
        &plan.mc_species(),
    )
    .unwrap();
    for (t, state) in &contents.states {
        writer.frame(*t, state).unwrap();
    }
    let mut zero = last.clone();
    zero.orientations[0] = [0.0; 4];
    writer.frame(u64::MAX / 2, &zero).unwrap();
    writer.finish().unwrap();
    let bad = dir.join("bad.mcap");
    let damaged = read_log(&bad, true).unwrap();
    assert_eq!(damaged.states.len(), frames, "the zero quaternion was read");
    assert!(
        damaged
            .damage
            .unwrap()
            .to_string()
            .contains("unit quaternion")
    );
    let (code, err) = cli(&["analyze", s(&bad), "--packing"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("unit quaternion") && err.contains("intact frames"),
        "{err}"
    );
    let (code, err) = cli(&["run", "--resume", s(&bad), "--out", s(&dir.join("r.mcap"))]);
    assert!(err.contains("unit quaternion"), "{code}: {err}");
    assert!(q.iter().map(|x| x * x).sum::<f64>() > 0.99);
    assert!(!bytes.is_empty());
}

#[test]
fn item_14_15_21_inputs_that_block_and_counts_without_end_are_refused() {
    use std::time::{Duration, Instant};
    let dir = scratch("fifo-inputs");
    let (fifo, scene_fifo) = (dir.join("pipe.mcap"), dir.join("pipe.ron"));
    for path in [&fifo, &scene_fifo] {
        let made = Command::new("mkfifo").arg(path).status().unwrap();
        assert!(made.success());
    }
    let within = |args: &[&str]| {
        let mut child = Command::new(EXE)
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        loop {
            if let Some(status) = child.try_wait().unwrap() {
                let mut err = String::new();
                std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
                return (status.code().unwrap(), err);
            }
            if started.elapsed() > Duration::from_secs(20) {
                let _ = child.kill();
                panic!("{args:?} blocked");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    for args in [
        vec!["inspect", s(&fifo)],
        vec!["analyze", s(&fifo)],
        vec!["analyze", "/dev/zero"],
        vec!["export", s(&fifo), "--gsd", s(&dir.join("x.gsd"))],
        vec!["run", s(&scene_fifo)],
        vec!["check", "/dev/zero"],
    ] {
        let (code, err) = within(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains("not a regular file"), "{args:?}: {err}");
    }
    // Counts that would exhaust the machine before any work.
    let template = dir.join("t.ron");
    std::fs::write(&template, small(1, "Lattice")).unwrap();
    let (code, err) = within(&[
        "sweep",
        s(&template),
        "--set",
        "stages[1].sweeps=10,20",
        "--replicas",
        "100000000",
        "--workspace",
        s(&dir.join("w")),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("at most 100000 jobs"), "{err}");
    assert!(!dir.join("w").exists());
    let (code, err) = within(&["run", s(&template), "--threads", "100000"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--threads"), "{err}");
    // A byte-order mark before the scene is no syntax error.
    let text = small(1, "Lattice").replace("unused.mcap", s(&dir.join("bom.mcap")));
    assert!(Scene::parse(&format!("\u{feff}{text}")).is_ok());
}

#[test]
fn item_18_a_pressure_past_the_jam_advises_what_can_be_run() {
    let dir = scratch("pressure-jam");
    let scene = write(
        &dir.join("p.ron"),
        r#"Scene(
    seed: 2,
    box: (5.0, 5.0, 5.0),
    species: [Species(name: "ball", shape: Sphere(radius: 0.5), count: 64)],
    stages: [Compress(pressure: 1000.0)],
    log: Log(path: "unused.mcap"),
)"#,
    );
    let (code, err) = cli(&["run", s(&scene), "--out", s(&dir.join("p.mcap"))]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("before betaP reached 1000"), "{err}");
    assert!(
        !err.contains("target"),
        "a target the user never gave: {err}"
    );
    // What it advises is a scene that runs.
    let advised = std::fs::read_to_string(&scene).unwrap().replace(
        "Compress(pressure: 1000.0)",
        "Compress(packing_fraction: 0.74, until_jammed: true)",
    );
    assert!(Scene::parse(&advised).is_ok());
}

#[test]
fn item_17_a_jam_that_would_outgrow_its_box_is_refused() {
    let tiny = |stage: &str| {
        format!(
            r#"Scene(
    box: (2.5, 2.5, 2.5),
    species: [Species(name: "ball", shape: Sphere(radius: 0.5), count: 8)],
    stages: [{stage}],
)"#
        )
    };
    for stage in ["Jam(packing_fraction: 0.6)", "Jam()"] {
        let err = Scene::parse(&tiny(stage)).unwrap_err().to_string();
        assert!(err.contains("minimum image"), "{stage}: {err}");
    }
    // A packing fraction the box holds is accepted.
    assert!(Scene::parse(&tiny("Jam(packing_fraction: 0.3)")).is_ok());
}

#[test]
fn item_24_collect_leaves_out_folders_that_are_not_jobs() {
    let dir = scratch("foreign-folders");
    let w = two_seed_sweep(&dir);
    // A folder with a state point that is not JSON, and one of notes.
    let stray = w.join("workspace/stray");
    std::fs::create_dir_all(&stray).unwrap();
    std::fs::write(stray.join("signac_statepoint.json"), "{not json").unwrap();
    std::fs::write(stray.join("scene.ron"), small(1, "Lattice")).unwrap();
    let notes = w.join("workspace/notes");
    std::fs::create_dir_all(&notes).unwrap();
    std::fs::write(notes.join("todo.txt"), "mine").unwrap();
    let out = Command::new(EXE)
        .args(["sweep", "collect", s(&w), "--json"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("stray") && err.contains("notes"), "{err}");
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(rows[0]["not_started"], 2, "{rows:?}");
}

#[test]
fn item_16_a_damaged_job_log_recovers_on_the_next_submission() {
    let dir = scratch("damaged-job");
    let a = write(&dir.join("a.ron"), &small(1, "Lattice"));
    let whole = dir.join("whole.mcap");
    run_to(&small(1, "Lattice"), &whole);
    let out = dir.join("job.mcap");
    let mut bytes = std::fs::read(&whole).unwrap();
    let at = bytes.len() * 3 / 5;
    bytes[at] ^= 0x40;
    std::fs::write(&out, &bytes).unwrap();
    assert!(read_log(&out, false).unwrap().damage.is_some());
    // The analyze action of a sweep does not count it done.
    let (code, err) = cli(&["analyze", s(&out)]);
    assert_eq!(code, 2, "{err}");
    let (code, err) = cli(&["run", s(&a), "--out", s(&out), "--continue"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("damaged") && err.contains(".damaged"), "{err}");
    let kept = dir.join("job.mcap.damaged");
    assert!(std::fs::read(&kept).unwrap() == bytes);
    assert!(same_last_state(&out, &whole));
    assert!(read_log(&out, false).unwrap().damage.is_none());
}

#[test]
fn item_23_a_grown_state_goes_on_only_with_the_species_it_was_grown_from() {
    let dir = scratch("grown-resume");
    let grown = dir.join("grown.mcap");
    run_to(&two_masses(1.0), &grown);
    let resumed = |radius: &str| {
        let text = two_masses(1.0)
            .replace(
                "stages: [Compress(packing_fraction: 0.3), Jam(growth_rate: 1e-2, pressure: 1e8)]",
                &format!(
                    "start: Resume({:?}), stages: [MonteCarlo(ensemble: Nvt, sweeps: 10)]",
                    s(&grown)
                ),
            )
            .replace("radius: 0.5", &format!("radius: {radius}"));
        hardbody::run::check_start(&Scene::parse(&text).unwrap())
    };
    assert!(resumed("0.5").is_ok());
    let err = resumed("0.3").unwrap_err().to_string();
    assert!(err.contains("grown from the species"), "{err}");
}

#[test]
fn item_21_log_paths_the_file_system_refuses_are_refused_by_check() {
    for path in [
        "a\\u{0}b.mcap".to_string(),
        "x".repeat(5000),
        format!("{}.mcap", "y".repeat(250)),
    ] {
        let text = small(1, "Lattice").replace("unused.mcap", &path);
        let err = Scene::parse(&text).unwrap_err().to_string();
        assert!(err.contains("log.path"), "{err}");
    }
}

/// The longest run of decimal digits in `text`.
fn longest_digit_run(text: &str) -> usize {
    text.split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0)
}

#[test]
fn item_26_numbers_print_short_and_never_round_to_zero() {
    let dir = scratch("numbers");
    let scene = |edge: &str, stages: &str| {
        format!(
            r#"Scene(
    seed: 1,
    box: ({edge}, {edge}, {edge}),
    species: [Species(name: "s", shape: Sphere(radius: 1e-30), count: 8)],
    stages: [{stages}],
    log: Log(path: "{}", stats_every: 10, frames_every: 20),
)"#,
            dir.join("tiny.mcap").display()
        )
    };
    let checked = write(
        &dir.join("checked.ron"),
        &scene(
            "10.0",
            "Compress(pressure: 1e100), MonteCarlo(ensemble: Npt(pressure: 1e99), sweeps: 10)",
        ),
    );
    let (code, out) = cli(&["check", s(&checked)]);
    assert_eq!(code, 0, "{out}");
    assert!(longest_digit_run(&out) <= 17, "{out}");
    assert!(
        out.contains("betaP = 1e100") && out.contains("betaP = 1e99"),
        "{out}"
    );
    assert!(
        !out.contains("0.0000"),
        "a length or fraction rounded to zero: {out}"
    );

    let run = write(
        &dir.join("run.ron"),
        &scene("10.0", "MonteCarlo(ensemble: Nvt, sweeps: 20)"),
    );
    let (code, out) = cli(&["run", s(&run)]);
    assert_eq!(code, 0, "{out}");
    assert!(longest_digit_run(&out) <= 17, "{out}");
    assert!(out.contains("packing fraction 3.3510e-92"), "{out}");
    for args in [vec!["analyze"], vec!["analyze", "--packing"]] {
        let tiny = dir.join("tiny.mcap");
        let (code, out) = cli(&[args.as_slice(), &[s(&tiny)]].concat());
        assert!(code == 0 || code == 1, "{args:?}: {out}");
        assert!(longest_digit_run(&out) <= 17, "{args:?}: {out}");
        assert!(!out.contains("0.0000 (constant)"), "{args:?}: {out}");
    }

    // A box whose volume has no floating-point value is refused, named.
    let huge = write(
        &dir.join("huge.ron"),
        &scene("1e300", "MonteCarlo(ensemble: Nvt, sweeps: 20)"),
    );
    let (code, out) = cli(&["check", s(&huge)]);
    assert_eq!(code, 2, "{out}");
    assert!(
        out.contains("box: edges must lie in [1e-100, 1e100], got (1e300, 1e300, 1e300)"),
        "{out}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs each of `commands` (arguments of the `hardbody` executable, `M`
/// standing for the mount point) in a mount namespace of its own on a
/// tmpfs of `kib` KiB (read-only when `read_only`); per command its exit
/// code and standard error, then the files left on the mount with their
/// sizes. None where no mount namespace can be made (it needs root).
fn on_small_disk(
    dir: &Path,
    kib: u32,
    read_only: bool,
    commands: &[&[&str]],
) -> Option<(Vec<(i32, String)>, String)> {
    let mount = dir.join(format!("disk{kib}{read_only}"));
    std::fs::create_dir_all(&mount).unwrap();
    let m = s(&mount);
    let mut script = format!("mount -t tmpfs -o size={kib}k tmpfs {m} || exit 99; ");
    if read_only {
        script += &format!("mount -o remount,ro {m} || exit 99; ");
    }
    for (k, args) in commands.iter().enumerate() {
        let args: Vec<String> = args
            .iter()
            .map(|a| format!("'{}'", a.replace('M', m)))
            .collect();
        script += &format!(
            "{EXE} {} >/dev/null 2>{m}/../err{k}; echo $? >{m}/../code{k}; ",
            args.join(" ")
        );
    }
    script += &format!("cd {m} && find . -mindepth 1 -printf '%p %s\\n'");
    let out = Command::new("unshare")
        .args(["-m", "sh", "-c", &script])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let results = (0..commands.len())
        .map(|k| {
            let read = |name: &str| {
                std::fs::read_to_string(dir.join(format!("{name}{k}"))).unwrap_or_default()
            };
            (read("code").trim().parse().unwrap(), read("err"))
        })
        .collect();
    Some((results, String::from_utf8_lossy(&out.stdout).into_owned()))
}

#[test]
fn item_20_a_full_or_read_only_disk_fails_named_and_leaves_nothing_empty() {
    let dir = scratch("disk");
    let log = dir.join("l.mcap");
    run_to(&small(1, "Lattice"), &log);
    let template = write(&dir.join("t.ron"), &small(1, "Lattice"));
    let (log, template) = (s(&log), s(&template));
    let commands: [&[&str]; 5] = [
        &["analyze", log, "--plot", "M/plots"],
        &["analyze", log, "--packing", "--plot", "M/packing"],
        &["export", log, "--gsd", "M/x.gsd"],
        &[
            "sweep",
            template,
            "--set",
            "seed=1,2,3,4,5,6,7,8",
            "--workspace",
            "M/w",
        ],
        &["run", template, "--out", "M/out.mcap"],
    ];
    let Some((full, files)) = on_small_disk(&dir, 8, false, &commands) else {
        eprintln!("item_20: no mount namespace here (needs root); skipped");
        return;
    };
    for ((code, err), args) in full.iter().zip(&commands) {
        assert_eq!(*code, 1, "{args:?}: {err}");
        assert!(err.contains("no space left on device"), "{args:?}: {err}");
        assert!(!err.contains("I/O error"), "{args:?}: {err}");
    }
    for line in files.lines() {
        let (path, size) = line.rsplit_once(' ').unwrap();
        assert!(
            size != "0" || !path.contains('.'),
            "an empty file is left behind: {files}"
        );
        assert!(
            !path.contains("x.gsd") && !path.starts_with("./w"),
            "{files}"
        );
    }
    let (read_only, files) = on_small_disk(&dir, 64, true, &commands).unwrap();
    for ((code, err), args) in read_only.iter().zip(&commands) {
        assert_eq!(*code, 1, "{args:?}: {err}");
        assert!(err.contains("Read-only file system"), "{args:?}: {err}");
    }
    assert!(files.trim().is_empty(), "{files}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn item_13_many_species_are_refused_clearly_before_any_table_is_built() {
    let dir = scratch("species");
    let scene = |n: usize| {
        let species: Vec<String> = (0..n)
            .map(|i| {
                format!(
                    r#"Species(name: "s{i}", shape: Sphere(radius: {}), count: 1)"#,
                    0.3 + 0.2 * i as f64 / n as f64
                )
            })
            .collect();
        write(
            &dir.join(format!("{n}.ron")),
            &format!(
                r#"Scene(seed: 1, box: (40.0, 40.0, 40.0), species: [{}],
    stages: [MonteCarlo(ensemble: Nvt, sweeps: 10), Dynamics(duration: 0.1)],
    log: Log(path: "many.mcap", stats_every: 10, frames_every: 10))"#,
                species.join(", ")
            ),
        )
    };
    // At the bound the plan is made (a one-species-per-particle
    // polydisperse system of 1024 bodies)...
    let (code, out) = cli(&["check", s(&scene(1024))]);
    assert_eq!(code, 0, "{}", &out[..out.len().min(2000)]);
    // ... above it the scene is refused, naming the field and the bound,
    // whatever the count (6000 species aborted on allocation).
    for n in [1025, 6000] {
        let (code, out) = cli(&["check", s(&scene(n))]);
        assert_eq!(code, 2, "{n}: {out}");
        assert!(
            out.contains(&format!("species: {n} species: at most 1024")),
            "{n}: {out}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn item_06_a_pressure_target_with_walls_is_refused_not_misread() {
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes/bad/walls_pressure_target.ron");
    let dir = scratch("walls");
    let out = dir.join("w.mcap");
    for args in [
        vec!["check", s(&scene)],
        vec!["run", s(&scene), "--out", s(&out)],
    ] {
        let (code, err) = cli(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            err.contains("stages[0].pressure: a pressure target is measured by the scale distribution, which has no wall term"),
            "{args:?}: {err}"
        );
        assert!(
            err.contains("Npt(pressure"),
            "the advice names what holds a pressure: {err}"
        );
    }
    assert!(!out.exists() && !hardbody::log::partial_path(&out).exists());
    // Without the walls the same target is accepted.
    let periodic = write(
        &dir.join("periodic.ron"),
        &std::fs::read_to_string(&scene)
            .unwrap()
            .replace("walls: [Z],", ""),
    );
    let (code, err) = cli(&["check", s(&periodic)]);
    assert_eq!(code, 0, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene in `dir` that jams 64 spheres (to betaPV/N = 10^12 in about 3
/// s), then runs `last`; the scene file and its log's path.
fn jammed_spheres_then(dir: &Path, last: &str) -> (PathBuf, PathBuf) {
    let log = dir.join("j.mcap");
    let scene = format!(
        r#"Scene(
    seed: 2,
    box: (5.2, 5.2, 5.2),
    species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 64)],
    stages: [Compress(packing_fraction: 0.5), Jam(growth_rate: 1e-3), {last}],
    log: Log(path: "{}", stats_every: 20, frames_every: 60),
)"#,
        log.display()
    );
    (write(&dir.join("j.ron"), &scene), log)
}

#[test]
fn item_09_10_the_pressure_of_a_jammed_packing_is_its_own_and_a_jam_is_not_averaged() {
    let dir = scratch("jammed-sdf");
    let (text, log) = jammed_spheres_then(&dir, "MonteCarlo(ensemble: Nvt, sweeps: 60)");
    let (code, out) = cli(&["run", s(&text)]);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("stage 1 (jam): jammed at"), "{out}");
    // The jam ends where its collisions put betaPV/N past 10^12; the scale
    // distribution of the packing it hands over must say as much (a fit on
    // a fixed window of 0.02 read 62).
    let contents = read_log(&log, false).unwrap();
    let (_, last) = contents.stats.last().unwrap();
    assert_eq!(last.stage, "monte_carlo");
    let volume: f64 = last.box_lengths.iter().product();
    let reduced = last.pressure.unwrap() * volume / 64.0;
    assert!(
        (2e11..5e12).contains(&reduced),
        "betaPV/N from the scale distribution {reduced:e}"
    );
    // A jam grows its bodies: no equilibrium averages, no "equilibrated".
    let (code, out) = cli(&["analyze", s(&log)]);
    assert_eq!(code, 0, "{out}");
    assert!(
        out.contains("growth to a jam (not an equilibrium stage: no averages)"),
        "{out}"
    );
    let (_, json) = cli(&["analyze", s(&log), "--json"]);
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    let jam = &report["stages"][1];
    assert_eq!(jam["stage"], "jam");
    assert_eq!(jam["equilibrated"], false);
    assert!(jam["observables"].as_object().unwrap().is_empty(), "{jam}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn no_stage_runs_without_a_bound_on_its_work() {
    // Dynamics from a jammed packing: 10^12 collisions per body and unit
    // time, so t = 1 would never end. It fails at once, saying why, with
    // the log up to there kept.
    let dir = scratch("budget");
    let (scene, log) = jammed_spheres_then(&dir, "Dynamics(duration: 1.0)");
    let (code, out) = cli(&["run", s(&scene)]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("stage 2 (dynamics): ")
            && out.contains("collisions per body and unit time")
            && out.contains("more than the 1e9 a dynamics stage may run"),
        "{out}"
    );
    let partial = hardbody::log::partial_path(&log);
    let kept = read_log(&partial, false).unwrap();
    assert_eq!(
        kept.last_state.unwrap().1.stage_index,
        2,
        "the jammed packing is kept"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn item_25_a_resume_with_a_scene_writes_where_the_readme_says_never_over_its_log() {
    let dir = scratch("resume-scene");
    let log = dir.join("l.mcap");
    run_to(&small(1, "Lattice"), &log);
    let before = std::fs::read(&log).unwrap();
    let other = dir.join("o.mcap");
    let scene = write(
        &dir.join("next.ron"),
        &small(1, "Lattice").replace("unused.mcap", s(&other)),
    );
    // Without --out: at the scene's log.path.
    let (code, out) = cli(&["run", "--resume", s(&log), s(&scene)]);
    assert_eq!(code, 0, "{out}");
    assert!(read_log(&other, false).unwrap().last_state.is_some());
    assert_eq!(
        std::fs::read(&log).unwrap(),
        before,
        "the log resumed from changed"
    );
    // A scene whose log.path is the log resumed from is refused.
    let onto = write(
        &dir.join("onto.ron"),
        &small(1, "Lattice").replace("unused.mcap", s(&log)),
    );
    let (code, out) = cli(&["run", "--resume", s(&log), s(&onto)]);
    assert_eq!(code, 2, "{out}");
    assert_eq!(
        std::fs::read(&log).unwrap(),
        before,
        "the log resumed from changed"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
