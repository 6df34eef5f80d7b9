//! Parameter sweeps (`hardbody sweep`): refusals before anything is
//! written; a small hard-sphere sweep run with row's own launcher, one job
//! killed mid-run and resumed by the next submission, collected, and every
//! state point's density against Carnahan–Starling; the workspace opened
//! with signac. The row test is skipped with a message where `row` is not
//! installed (`cargo install row`), the signac check where the Python
//! package is not.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const HARDBODY: &str = env!("CARGO_BIN_EXE_hardbody");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hardbody-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const TEMPLATE: &str = r#"Scene(
    seed: 1,
    box: (12.0, 12.0, 12.0),
    species: [Species(name: "sphere", shape: Sphere(radius: 0.5), count: 256)],
    start: Lattice,
    stages: [MonteCarlo(ensemble: Npt(pressure: 1.0), sweeps: 12000)],
    log: Log(path: "eos.mcap", stats_every: 100, frames_every: 1000),
)"#;

fn hardbody(args: &[&str], dir: &Path) -> std::process::Output {
    Command::new(HARDBODY)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn bad_keys_and_values_are_refused_before_anything_is_written() {
    let dir = scratch("sweep-refusals");
    std::fs::write(dir.join("t.ron"), TEMPLATE).unwrap();
    for (set, says) in [
        ("stages[0].ensemble.presure=1,2", "no field \"presure\""),
        ("stages[3].sweeps=10", "has 1 entries"),
        ("stages[0].ensemble.pressure=1,-2", "pressure=-2"),
        ("species[0].count=ten", "count=ten"),
        ("stages[0].sweeps", "KEY=V1,V2"),
    ] {
        let out = hardbody(&["sweep", "t.ron", "--set", set, "--workspace", "w"], &dir);
        assert_eq!(out.status.code(), Some(2), "{set}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{set}: {err}");
        assert!(!dir.join("w").exists(), "{set}: wrote the workspace");
    }
    // A folder that holds something else is not a workspace to write in.
    std::fs::create_dir_all(dir.join("busy")).unwrap();
    std::fs::write(dir.join("busy/notes.txt"), "mine").unwrap();
    let out = hardbody(
        &["sweep", "t.ron", "--set", "seed=1,2", "--workspace", "busy"],
        &dir,
    );
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(dir.join("busy/notes.txt")).unwrap(),
        "mine"
    );
}

#[test]
fn a_sweep_made_twice_keeps_its_jobs_and_adds_new_ones() {
    let dir = scratch("sweep-again");
    std::fs::write(dir.join("t.ron"), TEMPLATE).unwrap();
    let make = |values: &str| {
        hardbody(
            &[
                "sweep",
                "t.ron",
                "--set",
                &format!("stages[0].ensemble.pressure={values}"),
                "--workspace",
                "w",
            ],
            &dir,
        )
    };
    assert!(make("1,2").status.success());
    let jobs = |dir: &Path| std::fs::read_dir(dir.join("w/workspace")).unwrap().count();
    assert_eq!(jobs(&dir), 2);
    let marker = std::fs::read_dir(dir.join("w/workspace"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path()
        .join("mine");
    std::fs::write(&marker, "kept").unwrap();
    let out = make("1,2,3");
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 new, 2 already there"));
    assert_eq!(jobs(&dir), 3);
    assert!(marker.exists());
    // Another template is another sweep.
    std::fs::write(
        dir.join("t.ron"),
        TEMPLATE.replace("count: 256", "count: 200"),
    )
    .unwrap();
    assert_eq!(make("1").status.code(), Some(2));
}

/// `row` on the PATH or where `cargo install` puts it.
fn row() -> Option<PathBuf> {
    let candidates = std::env::var_os("PATH")
        .map(|p| {
            std::env::split_paths(&p)
                .map(|d| d.join("row"))
                .collect::<Vec<_>>()
        })
        .unwrap_or_default()
        .into_iter()
        .chain(std::env::var_os("CARGO_HOME").map(|h| PathBuf::from(h).join("bin/row")))
        .chain(std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo/bin/row")));
    candidates.into_iter().find(|p| p.is_file())
}

fn submit(row: &Path, dir: &Path) -> Command {
    let mut c = Command::new(row);
    c.args(["submit", "--cluster=none", "--yes", "--action", "run"])
        .current_dir(dir)
        .env("ROW_NO_PROGRESS", "true")
        .stdin(Stdio::null());
    c
}

#[test]
fn a_sweep_runs_with_row_resumes_a_killed_job_and_matches_carnahan_starling() {
    let Some(row) = row() else {
        eprintln!("skipped: row is not installed (cargo install row)");
        return;
    };
    let dir = scratch("sweep-row");
    std::fs::write(dir.join("t.ron"), TEMPLATE).unwrap();
    let out = hardbody(
        &[
            "sweep",
            "t.ron",
            "--set",
            "stages[0].ensemble.pressure=1,3",
            "--replicas",
            "2",
            "--workspace",
            "eos",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let project = dir.join("eos");
    let workspace = project.join("workspace");

    // Run, and kill everything once the first job's partial log holds a
    // frame after its start: a job killed mid-run (a node lost).
    let mut first = {
        use std::os::unix::process::CommandExt;
        submit(&row, &project)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .process_group(0)
            .spawn()
            .unwrap()
    };
    let started = Instant::now();
    let killed = loop {
        let partial = std::fs::read_dir(&workspace)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.path().join("log.mcap.partial"))
            .find(|p| std::fs::metadata(p).is_ok_and(|m| m.len() > 40_000));
        if let Some(p) = partial {
            break p;
        }
        if let Ok(Some(status)) = first.try_wait() {
            panic!("row ended ({status}) before a job got going");
        }
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no job got going"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    // SIGKILL to row's process group: row, its shell and hardbody.
    unsafe_kill_group(first.id());
    let _ = first.wait();
    let folder = killed.parent().unwrap().to_path_buf();
    assert!(killed.exists() && !folder.join("log.mcap").exists());

    // Submitted again: the killed job resumes, the others run.
    let again = submit(&row, &project).output().unwrap();
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&again.stdout),
        String::from_utf8_lossy(&again.stderr)
    );
    assert!(again.status.success(), "{said}");
    assert!(said.contains("resuming"), "{said}");
    assert!(folder.join("log.mcap").exists() && !killed.exists());

    let out = hardbody(&["sweep", "collect", "eos", "--json"], &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for row in rows {
        assert_eq!(row["finished"], 2, "{row}");
        let phi = &row["observables"]["packing_fraction"];
        let (mean, error) = (
            phi["mean"].as_f64().unwrap(),
            phi["error"].as_f64().unwrap(),
        );
        let cs = row["carnahan_starling"].as_f64().unwrap();
        assert!(error > 0.0 && error < 0.01, "{row}");
        assert!(
            (mean - cs).abs() < 3.0 * error,
            "pressure {}: phi {mean} +- {error}, Carnahan-Starling {cs}",
            row["parameters"]["pressure"]
        );
    }
    let table = hardbody(&["sweep", "collect", "eos"], &dir);
    let text = String::from_utf8_lossy(&table.stdout);
    assert!(
        text.contains("2/0/0/0") && text.contains("Carnahan-Starling"),
        "{text}"
    );

    // The workspace opens with signac, every job with its state point.
    let script = "import signac, sys, json\n\
                  p = signac.get_project(sys.argv[1])\n\
                  print(json.dumps(sorted([j.sp['pressure'], j.sp['seed'], j.id] for j in p.find_jobs())))";
    match Command::new("python3")
        .args(["-c", script])
        .arg(&project)
        .output()
    {
        Ok(o) if o.status.success() => {
            let jobs: Vec<(f64, u64, String)> = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(jobs.len(), 4);
            for (_, _, id) in &jobs {
                assert!(workspace.join(id).join("signac_statepoint.json").exists());
            }
            assert_eq!(
                jobs.iter().map(|j| (j.0, j.1)).collect::<Vec<_>>(),
                [(1.0, 1), (1.0, 2), (3.0, 1), (3.0, 2)]
            );
        }
        _ => eprintln!(
            "skipped the signac check: the Python package signac is not installed (pip install signac)"
        ),
    }
}

/// SIGKILL to the process group `pid` leads.
fn unsafe_kill_group(pid: u32) {
    let status = Command::new("kill")
        .args(["-KILL", "--", &format!("-{pid}")])
        .status()
        .unwrap();
    assert!(status.success());
}

/// `run --continue`, what a sweep's job runs: stopped by SIGTERM (what a
/// scheduler sends a job it preempts or that ran out of time; Ctrl-C
/// stops it the same way), its log stays partial (so row does not take
/// it as done); run again, it resumes to the log of the run in one go, bit
/// for bit; run once more, there is nothing to do.
#[test]
fn a_job_stopped_and_continued_ends_as_the_run_in_one_go() {
    let dir = scratch("continue");
    let scene = TEMPLATE.replace("sweeps: 12000", "sweeps: 60000");
    std::fs::write(dir.join("t.ron"), &scene).unwrap();
    let args = [
        "run",
        "t.ron",
        "--out",
        "job.mcap",
        "--continue",
        "--threads",
        "1",
    ];
    let child = Command::new(HARDBODY)
        .args(args)
        .current_dir(&dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let partial = dir.join("job.mcap.partial");
    let started = Instant::now();
    while std::fs::metadata(&partial).map_or(true, |m| m.len() < 60_000) {
        assert!(started.elapsed() < Duration::from_secs(120), "no frames");
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(partial.exists() && !dir.join("job.mcap").exists());
    // Continued: resumed, complete.
    let out = hardbody(&args, &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("resuming"));
    assert!(dir.join("job.mcap").exists() && !partial.exists());
    // The same as the run in one go.
    let whole = hardbody(
        &["run", "t.ron", "--out", "whole.mcap", "--threads", "1"],
        &dir,
    );
    assert!(whole.status.success());
    let read = |name: &str| hardbody::log::read::read_log(&dir.join(name), true).unwrap();
    let (a, b) = (read("job.mcap"), read("whole.mcap"));
    let last = |c: &hardbody::log::read::LogContents| c.states.last().unwrap().1.positions.clone();
    assert_eq!(last(&a), last(&b));
    assert_eq!(a.stats.len(), b.stats.len());
    // Nothing left to do.
    let out = hardbody(&args, &dir);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("nothing to do"));
    // --threads 0 is refused.
    let out = hardbody(&["run", "t.ron", "--out", "x.mcap", "--threads", "0"], &dir);
    assert_eq!(out.status.code(), Some(2));
}
