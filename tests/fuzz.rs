//! Fuzzing the two parsers of untrusted input, the scene and the log, with
//! generated mutations of real inputs. Bounded for CI; for a longer run,
//! `PROPTEST_CASES=100000 cargo test --release --test fuzz`.
//!
//! Properties: no panic, abort or hang; a scene is either refused with a
//! line and field or valid within the documented bounds (its `Resume`
//! start checked against its log); a mutated log is either reported
//! damaged or cut off, or read exactly as written; a list of logs is
//! averaged as replicas only where they are distinct runs of one scene; a
//! sweep's workspace with foreign folders is collected with each folder
//! counted once, as a job or as a stray.

mod common;

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::thread::ThreadId;

use hardbody::log::read::{Fault, LogContents, ReadOptions, read_log_bytes};
use hardbody::run::{Silent, run_scene};
use hardbody::scene::plan::Plan;
use hardbody::scene::{
    MAX_PARTICLES, MAX_SPECIES, MIN_GROWTH_RATE, MIN_JAM_PRESSURE, Scene, SceneError, Stage, Start,
    VALUE_RANGE,
};
use proptest::prelude::*;

/// `PROPTEST_CASES` if set, else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// The shipped scenes, the refused ones of `data/scenes/bad`, and scenes
/// of the surfaces added with them: a jam of bodies of different masses
/// with every parameter given, and a `Resume` start from a real log.
fn shipped_scenes() -> &'static Vec<String> {
    static SCENES: OnceLock<Vec<String>> = OnceLock::new();
    SCENES.get_or_init(|| {
        // The refused scenes too: one edit can make them valid, and they
        // hold the shapes and values nearest the bounds.
        let mut files = common::scene_files("data/scenes");
        files.extend(common::scene_files("data/scenes/bad"));
        let mut scenes: Vec<String> = files
            .iter()
            .map(|p| std::fs::read_to_string(p).unwrap())
            .collect();
        scenes.push(
            r#"Scene(
    seed: 3,
    box: (9.0, 9.0, 9.0),
    species: [
        Species(name: "light", shape: Sphere(radius: 0.5), count: 40, mass: 1.0),
        Species(name: "heavy", shape: Ellipsoid(a: 0.6, b: 0.5, c: 0.4), count: 20, mass: 1000.0),
    ],
    stages: [
        Compress(packing_fraction: 0.3),
        Jam(growth_rate: 0.01, fluid_rate: 0.05, pressure: 1e6, packing_fraction: 0.6),
        Dynamics(duration: 0.5),
    ],
    log: Log(path: "jam.mcap", stats_every: 10, frames_every: 20),
)"#
            .into(),
        );
        scenes.push(format!(
            r#"Scene(
    seed: 4,
    box: (8.0, 8.0, 8.0),
    start: Resume("{}"),
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 24),
        Species(name: "cube", shape: Cuboid(a: 0.4, b: 0.4, c: 0.4), count: 8),
    ],
    stages: [MonteCarlo(ensemble: Nvt, sweeps: 20)],
    log: Log(path: "resumed.mcap", stats_every: 10, frames_every: 10),
)"#,
            reference_log_path(2).display()
        ));
        scenes
    })
}

/// Values that have broken validation before: overflow, underflow,
/// wrap-around, the end of the float range.
const EXTREMES: &[&str] = &[
    "0",
    "-0.0",
    "1e308",
    "1e-320",
    "-1e308",
    "18446744073709551615",
    "9223372036854775808",
    "1000000000",
    "1e-300",
    "1e-12",
    "NaN",
    "inf",
    "4294967296",
    "65536",
    "\"\"",
    "\"/\"",
];

/// One edit of a scene text.
#[derive(Debug, Clone)]
enum Edit {
    /// Replace the k-th number with an extreme value.
    Number(usize, usize),
    /// Delete the byte at a fraction of the length.
    Delete(f64),
    /// Insert a byte there.
    Insert(f64, u8),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (0..200usize, 0..EXTREMES.len()).prop_map(|(k, v)| Edit::Number(k, v)),
        (0.0..1.0f64).prop_map(Edit::Delete),
        (
            0.0..1.0f64,
            prop::sample::select(b"(),:[]{}\"0123456789.-+eE_ \n/*".to_vec())
        )
            .prop_map(|(at, b)| Edit::Insert(at, b)),
    ]
}

fn apply(text: &str, edit: &Edit) -> String {
    let mut bytes = text.as_bytes().to_vec();
    let at = |f: f64, n: usize| ((f * n as f64) as usize).min(n.saturating_sub(1));
    match edit {
        Edit::Number(k, v) => {
            // The k-th run of digits (with its sign, point and exponent).
            let mut runs = Vec::new();
            let mut i = 0;
            while i < bytes.len() {
                if bytes[i].is_ascii_digit() {
                    let start = i;
                    while i < bytes.len()
                        && (bytes[i].is_ascii_alphanumeric() || b".-+".contains(&bytes[i]))
                    {
                        i += 1;
                    }
                    runs.push((start, i));
                } else {
                    i += 1;
                }
            }
            if let Some(&(a, b)) = runs.get(k % runs.len().max(1)) {
                bytes.splice(a..b, EXTREMES[*v].bytes());
            }
        }
        Edit::Delete(f) => {
            if !bytes.is_empty() {
                bytes.remove(at(*f, bytes.len()));
            }
        }
        Edit::Insert(f, b) => {
            let i = at(*f, bytes.len());
            bytes.insert(i, *b);
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(3000), ..ProptestConfig::default() })]

    #[test]
    fn scene_parser_never_panics_and_bounds_what_it_accepts(
        which in 0..256usize,
        edits in prop::collection::vec(edit(), 1..4),
    ) {
        let scenes = shipped_scenes();
        assert!(scenes.len() <= 256, "{} scenes: widen `which`", scenes.len());
        let mut text = scenes[which % scenes.len()].clone();
        for e in &edits {
            text = apply(&text, e);
        }
        let _watched = watch(&text);
        match Scene::parse(&text) {
            Ok(scene) => {
                // Accepted: within the documented bounds, and planned.
                prop_assert!(scene.particle_count() <= MAX_PARTICLES);
                prop_assert!(scene.species.len() <= MAX_SPECIES);
                prop_assert!(!scene.log.path.ends_with('/'));
                let (low, high) = VALUE_RANGE;
                let l = scene.periodic_box().lengths();
                prop_assert!(l.iter().all(|l| (low..=high).contains(l)));
                prop_assert!(scene.species.iter().all(|s| (low..=high).contains(&s.mass)));
                for stage in &scene.stages {
                    if let Stage::Jam { growth_rate, fluid_rate, pressure, .. } = stage {
                        for rate in [growth_rate, fluid_rate].into_iter().flatten() {
                            prop_assert!((MIN_GROWTH_RATE..=0.1).contains(rate), "rate {rate}");
                        }
                        if let Some(p) = pressure {
                            prop_assert!((MIN_JAM_PRESSURE..=1e14).contains(p), "bound {p}");
                        }
                    }
                }
                let _ = Plan::of(&scene);
                // A Resume start is read and checked against the scene
                // (refused or accepted, never a panic).
                if let Start::Resume(_) = scene.start {
                    let _ = hardbody::run::check_start(&scene);
                }
            }
            Err(SceneError::Syntax { line, .. }) => prop_assert!(line >= 1),
            Err(SceneError::Invalid { field, message, .. }) => {
                prop_assert!(!field.is_empty() && !message.is_empty());
            }
        }
    }
}

/// How long one case may run before the watchdog ends the test.
const HANG_LIMIT: std::time::Duration = std::time::Duration::from_secs(60);

/// The case each test thread is running, for the watchdog: its number
/// (cases begun on any thread) and its input.
type Running = HashMap<ThreadId, (u64, String)>;

fn running() -> MutexGuard<'static, Running> {
    static RUNNING: OnceLock<Mutex<Running>> = OnceLock::new();
    let running = RUNNING.get_or_init(|| Mutex::new(HashMap::new()));
    running.lock().unwrap_or_else(|e| e.into_inner())
}

/// A case under the watchdog's eye, until dropped.
struct Watched;

impl Drop for Watched {
    fn drop(&mut self) {
        running().remove(&std::thread::current().id());
    }
}

/// Marks the start of a case on `input`. A hang is a failure of these
/// properties: where one case runs through a whole [`HANG_LIMIT`], the
/// watchdog prints its input and fails the test binary, so that CI
/// reports the input at once instead of running out of time.
fn watch(input: &str) -> Watched {
    static WATCHDOG: OnceLock<()> = OnceLock::new();
    static BEGUN: AtomicU64 = AtomicU64::new(0);
    WATCHDOG.get_or_init(|| {
        std::thread::spawn(|| {
            let mut seen: Vec<u64> = Vec::new();
            loop {
                std::thread::sleep(HANG_LIMIT);
                let running = running();
                if let Some((_, input)) = running.values().find(|(k, _)| seen.contains(k)) {
                    // Straight to the process's stderr: the test
                    // harness captures `eprintln!` of the threads it starts.
                    let _ = writeln!(
                        std::io::stderr(),
                        "a fuzz case ran for over {HANG_LIMIT:?} on this input:\n{input}"
                    );
                    std::process::exit(101);
                }
                seen = running.values().map(|(k, _)| *k).collect();
            }
        });
    });
    let case = BEGUN.fetch_add(1, Ordering::Relaxed);
    running().insert(std::thread::current().id(), (case, input.to_string()));
    Watched
}

/// The scene of the reference logs, with `seed`.
fn reference_scene(seed: u64) -> String {
    format!(
        r#"Scene(
            seed: {seed},
            box: (8.0, 8.0, 8.0),
            species: [
                Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 24),
                Species(name: "cube", shape: Cuboid(a: 0.4, b: 0.4, c: 0.4), count: 8),
            ],
            stages: [
                Compress(packing_fraction: 0.2),
                MonteCarlo(ensemble: Npt(pressure: 1.0), sweeps: 60),
                Dynamics(duration: 0.5, stats_every: 0.1, frames_every: 0.1),
            ],
            log: Log(path: "unused.mcap", stats_every: 10, frames_every: 30),
        )"#
    )
}

/// The log of the reference scene with `seed` (2 or 3), run once.
fn reference_log_path(seed: u64) -> &'static Path {
    static LOGS: [OnceLock<std::path::PathBuf>; 2] = [OnceLock::new(), OnceLock::new()];
    LOGS[(seed - 2) as usize].get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("hardbody-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("reference{seed}.mcap"));
        let text = reference_scene(seed);
        let scene = Scene::parse(&text).unwrap();
        run_scene(&scene, &text, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
        path
    })
}

/// A complete log of a small run (every kind of stage), and what it reads
/// as.
fn reference_log() -> &'static (Vec<u8>, LogContents) {
    static LOG: OnceLock<(Vec<u8>, LogContents)> = OnceLock::new();
    LOG.get_or_init(|| {
        let bytes = std::fs::read(reference_log_path(2)).unwrap();
        let contents = read(&bytes).unwrap();
        assert!(contents.damage.is_none() && !contents.truncated);
        (bytes, contents)
    })
}

fn read(bytes: &[u8]) -> Result<LogContents, String> {
    read_log_bytes(
        bytes,
        Path::new("fuzzed.mcap"),
        ReadOptions {
            all_states: true,
            messages: false,
        },
    )
    .map_err(|e| e.to_string())
}

/// One corruption of a log.
#[derive(Debug, Clone)]
enum Corruption {
    /// Flip bit b of the byte at a fraction of the length.
    Flip(f64, u8),
    /// Write a little-endian u64 there (a length or size field).
    Word(f64, u64),
    /// Cut the file there.
    Cut(f64),
    /// Copy a span over another place.
    Splice(f64, f64, usize),
}

fn corruption() -> impl Strategy<Value = Corruption> {
    let word = prop_oneof![
        Just(u64::MAX),
        Just(1u64 << 62),
        Just(1u64 << 32),
        Just(0u64),
        any::<u64>(),
        0..100_000u64,
    ];
    prop_oneof![
        (0.0..1.0f64, 0..8u8).prop_map(|(f, b)| Corruption::Flip(f, b)),
        (0.0..1.0f64, word).prop_map(|(f, w)| Corruption::Word(f, w)),
        (0.0..1.0f64).prop_map(Corruption::Cut),
        (0.0..1.0f64, 0.0..1.0f64, 1..64usize).prop_map(|(a, b, n)| Corruption::Splice(a, b, n)),
    ]
}

fn corrupt(bytes: &mut Vec<u8>, c: &Corruption) {
    let n = bytes.len();
    let at = |f: f64| ((f * n as f64) as usize).min(n - 1);
    match *c {
        Corruption::Flip(f, b) => bytes[at(f)] ^= 1 << b,
        Corruption::Word(f, w) => {
            let i = at(f).min(n - 8);
            bytes[i..i + 8].copy_from_slice(&w.to_le_bytes());
        }
        Corruption::Cut(f) => bytes.truncate(at(f)),
        Corruption::Splice(a, b, len) => {
            let (from, to) = (at(a), at(b));
            let len = len.min(n - from).min(bytes.len().saturating_sub(to));
            let span = bytes[from..from + len].to_vec();
            bytes[to..to + len].copy_from_slice(&span);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(400), ..ProptestConfig::default() })]

    #[test]
    fn log_reader_never_panics_and_never_reads_damage_as_data(
        corruptions in prop::collection::vec(corruption(), 1..3),
    ) {
        let (good, reference) = reference_log();
        let _watched = watch(&format!("the reference log with {corruptions:?}"));
        let mut bytes = good.clone();
        for c in &corruptions {
            if bytes.len() > 16 {
                corrupt(&mut bytes, c);
            }
        }
        if let Some(why) = misread(&bytes, reference) {
            prop_assert!(false, "{}", why);
        }
    }
}

/// How a damaged log's reading departs from what was written, if it does.
/// It may be refused outright (no magic, no metadata) or read: what is
/// read is a prefix of the frames and stats, each exact, and all of them
/// unless the reader reports damage or a cut.
fn misread(bytes: &[u8], reference: &LogContents) -> Option<String> {
    let Ok(contents) = read(bytes) else {
        return None;
    };
    if contents.states.len() > reference.states.len() {
        return Some(format!(
            "{} frames read of {} written",
            contents.states.len(),
            reference.states.len()
        ));
    }
    for (i, ((ta, a), (tb, b))) in contents.states.iter().zip(&reference.states).enumerate() {
        if ta != tb || a != b {
            return Some(format!(
                "frame {i} was read at {ta} other than written (at {tb})"
            ));
        }
    }
    if let Some(i) = (contents.stats.iter().zip(&reference.stats)).position(|(a, b)| a != b) {
        return Some(format!("stat {i} was read other than written"));
    }
    let complete = contents.states.len() == reference.states.len()
        && contents.stats == reference.stats
        && contents.metadata == reference.metadata;
    if contents.damage.is_none() && !contents.truncated && !complete {
        return Some("records are missing, yet neither damage nor a cut is reported".into());
    }
    None
}

/// The offset and opcode of each record of a log outside the chunks, up
/// to the data end.
fn top_level_records(bytes: &[u8]) -> Vec<(usize, u8)> {
    let mut records = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let opcode = bytes[at];
        records.push((at, opcode));
        if opcode == 0x0f {
            break;
        }
        at += 9 + u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
    }
    records
}

/// A record's opcode damaged turns a chunk or metadata record into one the
/// reader would skip (a message index, a summary record, a footer); in a
/// cut-off log no data-section CRC catches it. Every bit of every opcode,
/// in the whole log and cut after the next record, is read as damage or
/// as exactly what was written.
#[test]
fn a_damaged_opcode_never_skips_records_unread() {
    let (good, reference) = reference_log();
    let records = top_level_records(good);
    assert!(
        records.iter().filter(|r| r.1 == 0x06).count() >= 5,
        "a log of several chunks"
    );
    let mut checked = 0;
    for (k, &(at, _)) in records.iter().enumerate() {
        let cuts = [good.len(), records.get(k + 2).map_or(good.len(), |r| r.0)];
        for bit in 0..8 {
            for &cut in &cuts {
                let mut bytes = good[..cut].to_vec();
                bytes[at] ^= 1 << bit;
                if let Some(why) = misread(&bytes, reference) {
                    panic!("opcode at byte {at} with bit {bit} flipped, cut at {cut}: {why}");
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 500);
    // A whole chunk gone, with its indexes (a copy that lost a block):
    // the messages after it are out of sequence.
    let chunks: Vec<usize> = (0..records.len())
        .filter(|&k| records[k].1 == 0x06)
        .collect();
    let k = chunks[chunks.len() / 2];
    let end = records[k + 1..].iter().find(|r| r.1 != 0x07).unwrap().0;
    let mut bytes = good[..records[k].0].to_vec();
    bytes.extend_from_slice(&good[end..]);
    bytes.truncate(bytes.len() - 100);
    let contents = read(&bytes).unwrap();
    assert!(
        matches!(
            contents.damage.as_ref().map(|d| &d.what),
            Some(Fault::InsideChunk(f)) if matches!(**f, Fault::OutOfSequence { .. })
        ),
        "{:?}",
        contents.damage
    );
    assert_eq!(misread(&bytes, reference), None);
    // The case that found it: a cut, then the second chunk's opcode made a
    // message index.
    let mut bytes = good.clone();
    corrupt(&mut bytes, &Corruption::Cut(0.3537412196002493));
    corrupt(&mut bytes, &Corruption::Flip(0.15264289348311474, 0));
    assert_eq!(misread(&bytes, reference), None);
}

/// A log a replica list may hold: the seed-2 run, a byte copy of it, a
/// cut of it, a corrupted copy, or the seed-3 run; with the run it is of.
fn replica_pool() -> &'static Vec<(&'static str, Option<u64>, LogContents)> {
    static POOL: OnceLock<Vec<(&'static str, Option<u64>, LogContents)>> = OnceLock::new();
    POOL.get_or_init(|| {
        let (bytes, contents) = reference_log();
        let mut cut = bytes.clone();
        cut.truncate(bytes.len() * 2 / 3);
        let mut flipped = bytes.clone();
        let middle = bytes.len() / 2;
        flipped[middle] ^= 0x10;
        let other = read(&std::fs::read(reference_log_path(3)).unwrap()).unwrap();
        let mut pool = vec![
            ("seed 2", Some(2), contents.clone()),
            ("its copy", Some(2), contents.clone()),
            ("seed 3", Some(3), other),
        ];
        for (name, damaged) in [("its cut", cut), ("its flipped copy", flipped)] {
            if let Ok(c) = read(&damaged) {
                pool.push((name, Some(2), c));
            }
        }
        pool
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(200), ..ProptestConfig::default() })]

    #[test]
    fn replicas_are_distinct_runs_or_refused(picks in prop::collection::vec(0..5usize, 1..5)) {
        let pool = replica_pool();
        let chosen: Vec<_> = picks.iter().map(|&k| &pool[k % pool.len()]).collect();
        let logs: Vec<(String, &LogContents)> = chosen
            .iter()
            .enumerate()
            .map(|(k, (name, _, c))| (format!("{k}: {name}"), c))
            .collect();
        let result = hardbody::log::averages::replica_averages(&logs);
        let runs: Vec<u64> = chosen.iter().filter_map(|(_, run, _)| *run).collect();
        let mut distinct = runs.clone();
        distinct.sort();
        distinct.dedup();
        if distinct.len() < runs.len() {
            prop_assert!(result.is_err(), "one run averaged as two replicas: {picks:?}");
        }
    }
}

/// A folder put into a sweep's workspace that is not one of its jobs.
#[derive(Debug, Clone, Copy)]
enum Foreign {
    Empty,
    File,
    BadStatePoint,
    StatePointOnly,
    BadScene,
    CopyOfAJob,
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(48), ..ProptestConfig::default() })]

    #[test]
    fn collect_counts_every_folder_once(
        added in prop::collection::vec(
            prop::sample::select(vec![
                Foreign::Empty,
                Foreign::File,
                Foreign::BadStatePoint,
                Foreign::StatePointOnly,
                Foreign::BadScene,
                Foreign::CopyOfAJob,
            ]),
            0..5,
        ),
        case in any::<u64>(),
    ) {
        use hardbody::sweep::{collect::collect, jobs, parse_sets, write_workspace};
        let dir = std::env::temp_dir().join(format!("hardbody-fuzz-sweep-{}-{case}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let text = reference_scene(2);
        let template = Scene::parse(&text).unwrap();
        let swept = parse_sets(&template, &["stages[1].ensemble.pressure=1,2".into()]).unwrap();
        let real = jobs(&template, &swept, 2).unwrap();
        write_workspace(&dir, &text, &swept, &real, Path::new("hardbody")).unwrap();
        let workspace = dir.join("workspace");
        let a_job = std::fs::read_dir(&workspace).unwrap().next().unwrap().unwrap().path();
        let mut folders = 0;
        for (k, kind) in added.iter().enumerate() {
            let path = workspace.join(format!("foreign{k}"));
            let put = |name: &str, bytes: &[u8]| std::fs::write(path.join(name), bytes).unwrap();
            if let Foreign::File = kind {
                std::fs::write(&path, b"not a folder").unwrap();
                continue;
            }
            std::fs::create_dir_all(&path).unwrap();
            folders += 1;
            let statepoint = std::fs::read(a_job.join("signac_statepoint.json")).unwrap();
            let scene = std::fs::read(a_job.join("scene.ron")).unwrap();
            match kind {
                Foreign::Empty | Foreign::File => {}
                Foreign::BadStatePoint => {
                    put("signac_statepoint.json", b"{not json");
                    put("scene.ron", &scene);
                }
                Foreign::StatePointOnly => put("signac_statepoint.json", &statepoint),
                Foreign::BadScene => {
                    put("signac_statepoint.json", &statepoint);
                    put("scene.ron", b"Scene(");
                }
                Foreign::CopyOfAJob => {
                    put("signac_statepoint.json", &statepoint);
                    put("scene.ron", &scene);
                }
            }
        }
        let collected = collect(&dir, None).unwrap();
        let counted: usize = collected
            .rows
            .iter()
            .map(|r| r.finished + r.foreign + r.partial + r.failed + r.not_started)
            .sum();
        prop_assert!(counted >= real.len(), "a job went uncounted: {added:?}");
        prop_assert_eq!(counted + collected.strays.len(), real.len() + folders, "{:?}", added);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
