//! Logs and inputs that survive faults: one regression test per way a run
//! or a reader was seen to lose data, corrupt a log or crash (issue 25),
//! named after it. docs/RELIABILITY.md lists the promises they check.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

mod common;

use common::cut_after_frames;
use hardbody::log::read::{Fault, ReadOptions, read_log, read_log_bytes, read_log_with};
use hardbody::log::{LogWriter, StateRecord, partial_path};
use hardbody::run::{Silent, resume_run, run_scene};
use hardbody::scene::Scene;
use rand::{Rng, SeedableRng};

const EXE: &str = env!("CARGO_BIN_EXE_hardbody");

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hardbody-rel-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// 48 rods and 16 balls through every kind of stage, a frame every 0.25
/// of the dynamics: a log of a dozen frames in a fraction of a second.
fn small(duration: f64) -> String {
    format!(
        r#"Scene(
    seed: 5,
    box: (9.0, 9.0, 9.0),
    species: [
        Species(name: "rod", shape: Ellipsoid(a: 0.8, b: 0.4, c: 0.4), count: 48),
        Species(name: "ball", shape: Sphere(radius: 0.4), count: 16),
    ],
    stages: [
        Compress(packing_fraction: 0.30),
        MonteCarlo(ensemble: Nvt, sweeps: 100),
        Dynamics(duration: {duration:?}, stats_every: 0.1, frames_every: 0.25),
    ],
    log: Log(path: "unused.mcap", stats_every: 20, frames_every: 50),
)"#
    )
}

/// Runs `scene_text` in-process to `path`.
fn run_to(scene_text: &str, path: &Path) {
    let scene = Scene::parse(scene_text).unwrap();
    run_scene(
        &scene,
        scene_text,
        path,
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap();
}

/// Runs the command line; (exit code, standard error).
fn cli(args: &[&str]) -> (i32, String) {
    let out = Command::new(EXE)
        .args(args)
        .stdout(Stdio::null())
        .output()
        .unwrap();
    (
        out.status.code().expect("exited, not killed by a signal"),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn bits(s: &StateRecord) -> Vec<u64> {
    s.positions
        .iter()
        .flatten()
        .chain(s.orientations.iter().flatten())
        .chain(s.box_lengths.iter())
        .chain(s.velocities.iter().flatten().flatten())
        .map(|x| x.to_bits())
        .collect()
}

/// Frames of the log at `path`, or 0 if it does not read.
fn frames(path: &Path) -> usize {
    read_log(path, true).map(|l| l.states.len()).unwrap_or(0)
}

#[test]
fn item_01_a_killed_in_place_resume_keeps_the_partial_log() {
    let dir = scratch("inplace");
    let text = small(3.0);
    let whole = dir.join("whole.mcap");
    run_to(&text, &whole);
    let bytes = std::fs::read(&whole).unwrap();
    let total = frames(&whole);
    let kept = total / 2;
    let log = dir.join("run.mcap");
    let partial = partial_path(&log);
    std::fs::write(&partial, &bytes[..cut_after_frames(&bytes, kept)]).unwrap();
    // Kill the resume (the README's recovery command) at many moments,
    // from before it reads to after its first new frames: the partial log
    // (or, once done, the log) never holds fewer frames than it did.
    let mut most = kept;
    for delay_ms in [0, 1, 2, 4, 8, 15, 30, 60, 120] {
        let mut child = Command::new(EXE)
            .args(["run", "--resume", s(&partial)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = child.kill();
        child.wait().unwrap();
        let held = frames(&partial).max(frames(&log));
        assert!(
            held >= most,
            "killed after {delay_ms} ms: {held} frames left of {most}"
        );
        most = held;
        if log.exists() {
            break;
        }
    }
    if !log.exists() {
        let (code, err) = cli(&["run", "--resume", s(&partial)]);
        assert_eq!(code, 0, "{err}");
    }
    assert!(
        !partial.exists(),
        "the completed log supersedes the partial"
    );
    let (a, b) = (
        read_log(&log, true).unwrap(),
        read_log(&whole, true).unwrap(),
    );
    assert_eq!(a.states.len(), b.states.len());
    assert!(bits(&a.states.last().unwrap().1) == bits(&b.states.last().unwrap().1));
}

#[test]
fn item_02_two_runs_on_one_output_path_are_refused() {
    let dir = scratch("two");
    let scene = dir.join("s.ron");
    std::fs::write(&scene, small(200.0)).unwrap();
    let shared = dir.join("shared.mcap");
    let mut first = Command::new(EXE)
        .args(["run", s(&scene), "--seed", "1", "--out", s(&shared)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let clock = Instant::now();
    while frames(&partial_path(&shared)) == 0 {
        assert!(clock.elapsed() < Duration::from_secs(60), "no frame");
        std::thread::sleep(Duration::from_millis(20));
    }
    let (code, err) = cli(&["run", s(&scene), "--seed", "2", "--out", s(&shared)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("another hardbody run is writing"), "{err}");
    // The same scene run twice at once, to its own log path.
    let (code, err) = cli(&["run", s(&scene), "--seed", "1", "--out", s(&shared)]);
    assert_eq!(code, 2, "{err}");
    // Nor is the log resumed from while it is written.
    let (code, err) = cli(&["run", "--resume", s(&partial_path(&shared))]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("another hardbody run is writing"), "{err}");
    first.kill().unwrap();
    first.wait().unwrap();
    // The first run's log is its own: one seed, frames in order.
    let log = read_log(&partial_path(&shared), true).unwrap();
    let resolved = Scene::parse(&log.metadata["scene_resolved"]).unwrap();
    assert_eq!(resolved.seed, 1);
    assert!(log.states.windows(2).all(|w| w[0].0 <= w[1].0));
    assert!(log.damage.is_none());
}

/// A complete log of the small scene, as bytes.
fn small_log(dir: &Path) -> Vec<u8> {
    let path = dir.join("good.mcap");
    run_to(&small(1.0), &path);
    std::fs::read(&path).unwrap()
}

/// Offsets of the chunk records of a log (opcode 0x06), by walking the
/// record framing.
fn chunk_offsets(bytes: &[u8]) -> Vec<usize> {
    let mut at = 8;
    let mut chunks = Vec::new();
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        match bytes[at] {
            0x06 => chunks.push(at),
            0x0F => break,
            _ => {}
        }
        at += 9 + len;
    }
    chunks
}

fn read_all(bytes: &[u8]) -> Result<hardbody::log::read::LogContents, String> {
    read_log_bytes(
        bytes,
        Path::new("mutated.mcap"),
        ReadOptions {
            all_states: true,
            messages: true,
        },
    )
    .map_err(|e| e.to_string())
}

#[test]
fn item_03_a_flipped_bit_never_aborts_or_panics_a_reader() {
    let dir = scratch("flip");
    let good = small_log(&dir);
    // A chunk that claims an uncompressed size of 2^62 bytes, and one
    // whose record length runs past the end of the file.
    let chunk = chunk_offsets(&good)[1];
    let mut huge = good.clone();
    huge[chunk + 9 + 16..chunk + 9 + 24].copy_from_slice(&(1u64 << 62).to_le_bytes());
    let mut long = good.clone();
    long[chunk + 1..chunk + 9].copy_from_slice(&(u64::MAX - 3).to_le_bytes());
    for (name, bytes) in [("huge", &huge), ("long", &long)] {
        let contents = read_all(bytes).unwrap();
        let damage = contents.damage.expect(name);
        assert_eq!(damage.offset, chunk as u64, "{name}: {damage}");
    }
    // The commands: exit 2 naming the byte offset.
    let bad = dir.join("huge.mcap");
    std::fs::write(&bad, &huge).unwrap();
    for args in [
        vec!["inspect", s(&bad)],
        vec!["export", s(&bad), "--gsd", s(&dir.join("x.gsd"))],
    ] {
        let (code, err) = cli(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(&format!("byte {chunk}")), "{args:?}: {err}");
    }
    // Random single-bit flips anywhere: the reader returns, never panics.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
    for _ in 0..3000 {
        let mut bytes = good.clone();
        let at = rng.gen_range(0..bytes.len());
        bytes[at] ^= 1 << rng.gen_range(0..8);
        let _ = read_all(&bytes);
    }
    // And the three commands on some of them: an exit code (never a
    // signal), 2 with the offset wherever the log is damaged.
    for k in 0..6 {
        let mut bytes = good.clone();
        let at = rng.gen_range(good.len() / 2..bytes.len());
        bytes[at] ^= 1 << rng.gen_range(0..8);
        let damaged = read_all(&bytes).map(|c| c.damage.is_some());
        let path = dir.join(format!("flip{k}.mcap"));
        std::fs::write(&path, &bytes).unwrap();
        let gsd = dir.join(format!("flip{k}.gsd"));
        let resumed = dir.join(format!("flip{k}-resumed.mcap"));
        for args in [
            vec!["inspect", s(&path)],
            vec!["export", s(&path), "--gsd", s(&gsd)],
            vec!["run", "--resume", s(&path), "--out", s(&resumed)],
        ] {
            let (code, err) = cli(&args);
            assert!([0, 1, 2].contains(&code), "{args:?}: {code} {err}");
            if damaged == Ok(true) {
                assert!(err.contains("damaged at byte"), "{args:?}: {err}");
                if args[0] != "run" {
                    assert_eq!(code, 2, "{args:?}: {err}");
                }
            }
        }
    }
}

#[test]
fn item_04_a_damaged_chunk_is_never_read_as_data() {
    let dir = scratch("crc");
    let good = small_log(&dir);
    let reference = read_all(&good).unwrap();
    assert!(reference.damage.is_none());
    let chunks = chunk_offsets(&good);
    let last = *chunks.last().unwrap();
    let len = u64::from_le_bytes(good[last + 1..last + 9].try_into().unwrap()) as usize;
    // Every byte of the last chunk (a frame with velocities), one bit
    // flipped at a time: either the damage is reported at that chunk, or
    // what is read is exactly what was written.
    let mut caught = 0;
    for at in (last..last + 9 + len).step_by(7) {
        let mut bytes = good.clone();
        bytes[at] ^= 0x10;
        match read_all(&bytes) {
            Ok(c) => match &c.damage {
                // A flip that leaves the chunk's records as written (in
                // the compressed frame's header): the file's CRC tells.
                Some(d) if matches!(d.what, Fault::DataCrc { .. }) => {
                    assert_eq!(c.states, reference.states, "flip at {at} read as data");
                }
                Some(d) => {
                    assert_eq!(d.offset, last as u64, "flip at {at}: {d}");
                    caught += 1;
                    // Nothing of the damaged chunk was read.
                    assert!(c.states.len() < reference.states.len());
                    for ((_, a), (_, b)) in c.states.iter().zip(&reference.states) {
                        assert!(bits(a) == bits(b));
                    }
                }
                None => {
                    assert_eq!(c.states, reference.states, "flip at {at} read as data");
                    assert_eq!(c.stats, reference.stats, "flip at {at} read as data");
                }
            },
            Err(e) => panic!("flip at {at}: {e}"),
        }
    }
    assert!(caught > len / 14, "{caught} of {} flips caught", len / 7);
    // And the command names the chunk.
    let mut bytes = good.clone();
    bytes[last + 9 + len - 10] ^= 0x10;
    let bad = dir.join("bad.mcap");
    std::fs::write(&bad, &bytes).unwrap();
    let (code, err) = cli(&["inspect", s(&bad)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains(&format!("byte {last}")), "{err}");
}

#[test]
fn item_05_output_that_is_an_input_is_refused() {
    let dir = scratch("overwrite");
    let scene = dir.join("s.ron");
    let text = small(0.5);
    std::fs::write(&scene, &text).unwrap();
    let (code, err) = cli(&["run", s(&scene), "--out", s(&scene)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is the input"), "{err}");
    // A log.path that names the scene file itself.
    let own = dir.join("own.ron");
    let own_text = text.replace("unused.mcap", s(&own));
    std::fs::write(&own, &own_text).unwrap();
    for command in ["run", "check"] {
        let (code, err) = cli(&[command, s(&own)]);
        assert_eq!(code, 2, "{command}: {err}");
        assert!(
            err.contains("log.path") && err.contains("is the input"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read_to_string(&own).unwrap(), own_text);
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), text);
    // export onto its own log.
    let log = dir.join("l.mcap");
    run_to(&text, &log);
    let before = std::fs::read(&log).unwrap();
    let (code, err) = cli(&["export", s(&log), "--gsd", s(&log)]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(std::fs::read(&log).unwrap(), before);
    // A scene resumed from a partial log, writing to that partial log.
    let partial = partial_path(&dir.join("p.mcap"));
    std::fs::copy(&log, &partial).unwrap();
    let (code, err) = cli(&[
        "run",
        s(&scene),
        "--resume",
        s(&partial),
        "--out",
        s(&dir.join("p.mcap")),
    ]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(std::fs::read(&partial).unwrap(), before);
}

#[test]
fn item_06_a_non_regular_output_path_is_refused() {
    let dir = scratch("fifo");
    let scene = dir.join("s.ron");
    std::fs::write(&scene, small(0.5)).unwrap();
    let fifo = dir.join("pipe.mcap");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let partial_fifo = dir.join("other.mcap.partial");
    assert!(
        Command::new("mkfifo")
            .arg(&partial_fifo)
            .status()
            .unwrap()
            .success()
    );
    let is_fifo = |p: &Path| {
        use std::os::unix::fs::FileTypeExt;
        std::fs::symlink_metadata(p).unwrap().file_type().is_fifo()
    };
    for out in [fifo.clone(), dir.join("other.mcap")] {
        let (code, err) = cli(&["run", s(&scene), "--out", s(&out)]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains("not a regular file"), "{err}");
    }
    let (code, err) = cli(&["run", s(&scene), "--out", "/dev/null"]);
    assert_eq!(code, 2, "{err}");
    let log = dir.join("l.mcap");
    run_to(&small(0.5), &log);
    let (code, err) = cli(&["export", s(&log), "--gsd", s(&fifo)]);
    assert_eq!(code, 2, "{err}");
    assert!(is_fifo(&fifo) && is_fifo(&partial_fifo));
}

/// The error `Scene::parse` gives for `text`.
fn refusal(text: &str) -> String {
    match Scene::parse(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn item_07_intervals_that_would_never_end_or_flood_the_disk_are_refused() {
    let base = small(1.0);
    let e = refusal(&base.replace("stats_every: 0.1", "stats_every: 1e-300"));
    assert!(
        e.contains("stages[2].stats_every") && e.contains("at most"),
        "{e}"
    );
    let e = refusal(&base.replace("frames_every: 0.25", "frames_every: 1e-12"));
    assert!(
        e.contains("stages[2].frames_every") && e.contains("at most"),
        "{e}"
    );
    let e = refusal(&base.replace("sweeps: 100", "sweeps: 1000000000000"));
    assert!(
        e.contains("log.stats_every") && e.contains("at most"),
        "{e}"
    );
    // `check` refuses them as `run` does.
    let dir = scratch("intervals");
    let scene = dir.join("s.ron");
    std::fs::write(
        &scene,
        base.replace("stats_every: 0.1", "stats_every: 1e-300"),
    )
    .unwrap();
    for command in ["check", "run"] {
        let (code, err) = cli(&[command, s(&scene)]);
        assert_eq!(code, 2, "{command}: {err}");
        assert!(err.contains("line 11"), "{err}");
    }
}

#[test]
fn item_08_values_that_overflow_are_refused_before_running() {
    let base = small(1.0);
    let e = refusal(&base.replace("stats_every: 0.1,", "stats_every: 0.1, temperature: 1e308,"));
    assert!(e.contains("temperature") && e.contains("1e308"), "{e}");
    let e = refusal(&base.replace("count: 16)", "count: 16, mass: 1e-320)"));
    assert!(e.contains("species[1].mass"), "{e}");
    // 2^64 - 1 + 28 wrapped to 27; two of 2^63 summed to 1 (with 1 more).
    let e = refusal(&base.replace("count: 48", "count: 18446744073709551615"));
    assert!(
        e.contains("species[0].count") && e.contains("at most"),
        "{e}"
    );
    let e = refusal(
        &base
            .replace("count: 48", "count: 9223372036854775808")
            .replace("count: 16", "count: 9223372036854775808"),
    );
    assert!(e.contains("count") && e.contains("at most"), "{e}");
    let e = refusal(&base.replace("count: 48", "count: 1000000000"));
    assert!(
        e.contains("species[0].count") && e.contains("10000000"),
        "{e}"
    );
    // A speed that would take forever: kT 1e90 at unit mass.
    let e = refusal(&base.replace("stats_every: 0.1,", "stats_every: 0.1, temperature: 1e90,"));
    assert!(
        e.contains("stages[2].duration") && e.contains("travel"),
        "{e}"
    );
}

/// `hardbody run` on a file system of `kib` KiB (a tmpfs of its own mount
/// namespace); what it printed and the files left there.
fn run_on_small_disk(dir: &Path, kib: u32) -> Option<(i32, String, String)> {
    let scene = dir.join("s.ron");
    std::fs::write(&scene, small(3.0)).unwrap();
    let mount = dir.join(format!("disk{kib}"));
    std::fs::create_dir_all(&mount).unwrap();
    let script = format!(
        "mount -t tmpfs -o size={kib}k tmpfs {m} || exit 99; {exe} run {scene} --out {m}/out.mcap 2>{m}/../err{kib}; echo $?; ls {m}",
        m = s(&mount),
        exe = EXE,
        scene = s(&scene),
    );
    let out = Command::new("unshare")
        .args(["-m", "sh", "-c", &script])
        .output()
        .ok()?;
    if out.status.code() == Some(99) || !out.status.success() {
        return None;
    }
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let mut lines = stdout.lines();
    let code = lines.next()?.trim().parse().ok()?;
    let files = lines.collect::<Vec<_>>().join(" ");
    let err = std::fs::read_to_string(dir.join(format!("err{kib}"))).unwrap_or_default();
    Some((code, err, files))
}

#[test]
fn item_09_a_full_disk_is_named_and_leaves_no_empty_partial() {
    let dir = scratch("full");
    // (The in-process half, writing to /dev/full, is in the log module's
    // unit tests; this half needs a mount namespace.)
    let Some((code, err, files)) = run_on_small_disk(&dir, 8) else {
        eprintln!("item_09: no mount namespace here (needs root); the unit tests cover the rest");
        return;
    };
    assert_ne!(code, 0);
    assert!(err.contains("no space left on device"), "{err}");
    assert!(err.contains("out.mcap.partial"), "{err}");
    assert!(err.contains("no partial log was kept"), "{err}");
    assert!(!files.contains("out.mcap"), "left behind: {files}");
    // With room for some frames: the partial log is kept, and says so.
    let (code, err, files) = run_on_small_disk(&dir, 160).unwrap();
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("no space left on device"), "{err}");
    assert!(err.contains("the log up to the failure is in"), "{err}");
    assert!(files.contains("out.mcap.partial"), "{files}");
}

#[test]
fn item_10_check_refuses_what_run_refuses() {
    let dir = scratch("check");
    let log = dir.join("l.mcap");
    run_to(&small(0.5), &log);
    let with_start = |start: &str| {
        small(0.5).replace(
            "    stages: [",
            &format!("    start: Resume({start:?}),\n    stages: ["),
        )
    };
    let corrupt = dir.join("corrupt.mcap");
    std::fs::write(&corrupt, b"\x89MCAP0\r\nnot a log").unwrap();
    let cases = [
        ("missing", with_start(s(&dir.join("missing.mcap"))), "start"),
        ("corrupt", with_start(s(&corrupt)), "start"),
        (
            "mismatched",
            with_start(s(&log)).replace("count: 16", "count: 17"),
            "[48, 16] differ from the scene's [48, 17]",
        ),
        (
            "slash",
            small(0.5).replace("unused.mcap", "somewhere/"),
            "log.path",
        ),
    ];
    for (name, text, expect) in cases {
        let scene = dir.join(format!("{name}.ron"));
        std::fs::write(&scene, &text).unwrap();
        for command in ["check", "run"] {
            let (code, err) = cli(&[command, s(&scene)]);
            assert_eq!(code, 2, "{name} {command}: {err}");
            assert!(err.contains(expect), "{name} {command}: {err}");
            assert!(err.contains(&format!("{}: line ", s(&scene))), "{err}");
        }
    }
}

#[test]
fn item_11_stats_after_a_resume_inside_dynamics_match_the_uninterrupted_run() {
    let dir = scratch("stats");
    let text = small(2.0);
    let whole = dir.join("whole.mcap");
    run_to(&text, &whole);
    let bytes = std::fs::read(&whole).unwrap();
    let reference = read_log(&whole, true).unwrap();
    let first_dynamics = reference
        .states
        .iter()
        .position(|(_, s)| s.stage == "dynamics")
        .unwrap();
    for k in first_dynamics + 1..reference.states.len() {
        let cut = dir.join(format!("cut{k}.mcap.partial"));
        std::fs::write(&cut, &bytes[..cut_after_frames(&bytes, k)]).unwrap();
        let out = dir.join(format!("resumed{k}.mcap"));
        resume_run(&cut, &out, &mut Silent, &AtomicBool::new(false)).unwrap();
        let resumed = read_log(&out, false).unwrap();
        assert_eq!(resumed.stats.len(), reference.stats.len(), "frame {k}");
        for (i, (a, b)) in resumed.stats.iter().zip(&reference.stats).enumerate() {
            assert_eq!(a, b, "resumed from frame {k}: /stats message {i} differs");
        }
    }
}

/// The log of `text` run to `name` in `dir`, read with every state and
/// message.
fn whole_log(dir: &Path, text: &str, name: &str) -> (PathBuf, hardbody::log::read::LogContents) {
    let path = dir.join(name);
    run_to(text, &path);
    let options = ReadOptions {
        all_states: true,
        messages: true,
    };
    let contents = read_log_with(&path, options).unwrap();
    (path, contents)
}

/// The log of `text` whose messages are `reference`'s, message `index`
/// rewritten by `rewrite`, written to `path` (its chunks all intact).
fn rewrite_message(
    text: &str,
    reference: &hardbody::log::read::LogContents,
    index: usize,
    path: &Path,
    rewrite: impl Fn(&[u8]) -> Vec<u8>,
) {
    let scene = Scene::parse(text).unwrap();
    let species = hardbody::scene::plan::Plan::of(&scene).mc_species();
    let mut writer =
        LogWriter::create(path, text, &reference.metadata["scene_resolved"], &species).unwrap();
    for (i, (topic, t, data)) in reference.messages.iter().enumerate() {
        if i == index {
            writer.copy(topic, *t, &rewrite(data)).unwrap();
        } else {
            writer.copy(topic, *t, data).unwrap();
        }
    }
    writer.finish().unwrap();
}

/// A frame whose angular velocities do not read as finite numbers (a
/// value out of range of a double, as a tool that writes inf would
/// leave): never taken for a state. `inspect` and `run --resume` name the
/// field, the particle and the place in the message; resumed, the run
/// goes on from the frame before and ends as the whole run did; a log
/// whose every dynamics frame is so is refused.
#[test]
fn a_frame_with_angular_velocities_out_of_range_is_named_and_not_resumed_from() {
    let dir = scratch("badspin");
    let text = small(1.0);
    let (_, reference) = whole_log(&dir, &text, "whole.mcap");
    let states = |log: &hardbody::log::read::LogContents| -> Vec<usize> {
        (0..log.messages.len())
            .filter(|&i| log.messages[i].0 == "/state")
            .collect()
    };
    // The first rod's first component, in the last frame.
    let spin_out_of_range = |data: &[u8]| {
        let json = String::from_utf8(data.to_vec()).unwrap();
        let at = json.find("\"angular_velocities\":[[").unwrap() + 23;
        let end = at + json[at..].find(',').unwrap();
        format!("{}1e999{}", &json[..at], &json[end..]).into_bytes()
    };
    let last = dir.join("last.mcap");
    let index = *states(&reference).last().unwrap();
    rewrite_message(&text, &reference, index, &last, spin_out_of_range);
    let (code, err) = cli(&["inspect", s(&last)]);
    assert_eq!(code, 2, "{err}");
    for named in ["angular_velocities[0][0]", "out of range", "line 1 column"] {
        assert!(err.contains(named), "{named}: {err}");
    }
    let out = dir.join("resumed.mcap");
    let (code, err) = cli(&["run", "--resume", s(&last), "--out", s(&out)]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("angular_velocities[0][0]"), "{err}");
    assert!(err.contains("resumed from the last intact frame"), "{err}");
    let resumed = read_log(&out, true).unwrap();
    assert_eq!(resumed.states.len(), reference.states.len());
    for ((_, a), (_, b)) in resumed.states.iter().zip(&reference.states) {
        assert!(bits(a) == bits(b));
    }
    // A run of dynamics alone, its first frame so: nothing to resume from.
    let text = text.replace(
        "Compress(packing_fraction: 0.30),\n        MonteCarlo(ensemble: Nvt, sweeps: 100),",
        "",
    );
    let (_, reference) = whole_log(&dir, &text, "dynamics.mcap");
    let first = dir.join("first.mcap");
    let index = states(&reference)[0];
    rewrite_message(&text, &reference, index, &first, spin_out_of_range);
    let (code, err) = cli(&[
        "run",
        "--resume",
        s(&first),
        "--out",
        s(&dir.join("no.mcap")),
    ]);
    assert_ne!(code, 0, "{err}");
    assert!(
        err.contains("no complete frame") && err.contains("angular_velocities[0][0]"),
        "{err}"
    );
    assert!(!dir.join("no.mcap").exists());
}

#[test]
fn item_12_one_bad_message_does_not_block_the_log() {
    let dir = scratch("badmessage");
    let text = small(1.0);
    let (_, reference) = whole_log(&dir, &text, "whole.mcap");
    // The same messages, one dynamics /state replaced by bytes that are
    // not a state, in a log whose chunks are all intact.
    let bad_index = reference
        .messages
        .iter()
        .enumerate()
        .filter(|(_, (topic, _, _))| topic == "/state")
        .nth(reference.states.len() - 3)
        .unwrap()
        .0;
    let damaged = dir.join("damaged.mcap");
    rewrite_message(&text, &reference, bad_index, &damaged, |_| {
        b"{\"stage_index\": 2, \"positions\": [[0, 0".to_vec()
    });
    let read = read_log(&damaged, true).unwrap();
    let damage = read.damage.clone().expect("the bad message is reported");
    assert!(
        matches!(&damage.what, Fault::InsideChunk(f)
            if matches!(&**f, Fault::Message { topic, .. } if topic == "/state")),
        "{damage}"
    );
    let intact = reference.states.len() - 3;
    assert_eq!(read.states.len(), intact);
    for ((_, a), (_, b)) in read.states.iter().zip(&reference.states) {
        assert!(bits(a) == bits(b));
    }
    // inspect shows it, with the offset, and exits 2.
    let (code, err) = cli(&["inspect", s(&damaged)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains(&format!("byte {}", damage.offset)), "{err}");
    // Resumed from the last good frame, the run ends as the whole one did.
    let out = dir.join("resumed.mcap");
    let (code, err) = cli(&["run", "--resume", s(&damaged), "--out", s(&out)]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("resumed from the last intact frame"), "{err}");
    let resumed = read_log(&out, true).unwrap();
    assert!(resumed.damage.is_none());
    assert_eq!(resumed.states.len(), reference.states.len());
    for ((_, a), (_, b)) in resumed.states.iter().zip(&reference.states) {
        assert!(bits(a) == bits(b));
    }
}
