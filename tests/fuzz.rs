//! Fuzzing the two parsers of untrusted input, the scene and the log, with
//! generated mutations of real inputs. Bounded for CI; for a longer run,
//! `PROPTEST_CASES=100000 cargo test --release --test fuzz`.
//!
//! Properties: no panic, abort or hang; a scene is either refused with a
//! line and field or valid within the documented bounds; a mutated log is
//! either reported damaged or cut off, or read exactly as written.

mod common;

use std::path::Path;
use std::sync::OnceLock;
use std::sync::atomic::AtomicBool;

use hardbody::log::read::{LogContents, ReadOptions, read_log_bytes};
use hardbody::run::{Silent, run_scene};
use hardbody::scene::plan::Plan;
use hardbody::scene::{MAX_PARTICLES, Scene, SceneError};
use proptest::prelude::*;

/// `PROPTEST_CASES` if set, else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn shipped_scenes() -> &'static Vec<String> {
    static SCENES: OnceLock<Vec<String>> = OnceLock::new();
    SCENES.get_or_init(|| {
        let files = common::scene_files("data/scenes");
        files
            .iter()
            .map(|p| std::fs::read_to_string(p).unwrap())
            .collect()
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
        which in 0..64usize,
        edits in prop::collection::vec(edit(), 1..4),
    ) {
        let scenes = shipped_scenes();
        let mut text = scenes[which % scenes.len()].clone();
        for e in &edits {
            text = apply(&text, e);
        }
        match Scene::parse(&text) {
            Ok(scene) => {
                // Accepted: within the documented bounds, and planned.
                prop_assert!(scene.particle_count() <= MAX_PARTICLES);
                prop_assert!(!scene.log.path.ends_with('/'));
                let _ = Plan::of(&scene);
            }
            Err(SceneError::Syntax { line, .. }) => prop_assert!(line >= 1),
            Err(SceneError::Invalid { field, message, .. }) => {
                prop_assert!(!field.is_empty() && !message.is_empty());
            }
        }
    }
}

/// A complete log of a small run (every kind of stage), and what it reads
/// as.
fn reference_log() -> &'static (Vec<u8>, LogContents) {
    static LOG: OnceLock<(Vec<u8>, LogContents)> = OnceLock::new();
    LOG.get_or_init(|| {
        let text = r#"Scene(
            seed: 2,
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
        )"#;
        let dir = std::env::temp_dir().join(format!("hardbody-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("reference.mcap");
        let scene = Scene::parse(text).unwrap();
        run_scene(&scene, text, &path, &mut Silent, &AtomicBool::new(false)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
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
        let mut bytes = good.clone();
        for c in &corruptions {
            if bytes.len() > 16 {
                corrupt(&mut bytes, c);
            }
        }
        // Refused outright (no magic, no metadata) or read: never a panic.
        let Ok(contents) = read(&bytes) else { return Ok(()) };
        // What is read is what was written, up to where the reading
        // stopped: a prefix of the frames and stats, each exact.
        prop_assert!(contents.states.len() <= reference.states.len());
        for ((ta, a), (tb, b)) in contents.states.iter().zip(&reference.states) {
            prop_assert_eq!(ta, tb);
            prop_assert!(a == b, "a frame was read other than written");
        }
        for (a, b) in contents.stats.iter().zip(&reference.stats) {
            prop_assert_eq!(a, b);
        }
        // Nothing missing unless the reader says why.
        if contents.damage.is_none() && !contents.truncated {
            prop_assert_eq!(contents.states.len(), reference.states.len());
            prop_assert_eq!(&contents.stats, &reference.stats);
            prop_assert_eq!(&contents.metadata, &reference.metadata);
        }
    }
}
