//! Growing hard spheres to a packing fraction: hardbody's event-driven
//! growth (`edmd::jam`, the `Jam` stage's engine) against Frank
//! Smallenburg's growth code (github FSmallenburg/EDMD, `Grow`, MIT), one
//! core, side by side in one run, interleaved (ours, theirs, ...).
//!
//! Run with `taskset -c 0 cargo bench --bench grow` from `benches/peers/`
//! (`REPEATS=N`, default 3). His source is read from
//! `../shared/peers/smallenburg-edmd` beside the repository (or
//! `SMALLENBURG_EDMD`), copied under `target/`, set to 1000 equal spheres
//! grown to φ = 0.62 at his default speed (the radius grows linearly from
//! half its final size at 0.1 of the starting radius per unit time, so
//! doubling takes t = 10), and built with its own flags (`-Ofast
//! -march=native`). Nothing of it is copied into this repository.
//!
//! The same task for hardbody: 1000 spheres of half the final radius on
//! a lattice in his box (φ = 0.0775), grown until φ ≥ 0.62 at the rate
//! that doubles them by t = 10 (hardbody's growth is exponential:
//! γ = ln 2 / 10). His thermostat kicks 1 % of the particles every 0.001
//! time units; hardbody rescales every velocity every 100 collisions per
//! body or 1 % growth. Both are timed by the wall clock around the whole
//! run, set-up included (a fraction of a percent here).

use std::path::{Path, PathBuf};
use std::process::Command;

use hardbody_peers::{run, smallenburg_source};
use std::time::Instant;

use hardbody::edmd::DynamicsOptions;
use hardbody::edmd::jam::{JamOptions, jam};
use hardbody::space::PeriodicBox;
use hardbody::state::Species;
use nalgebra::Vector3;
use rand::SeedableRng;

const N: usize = 1000;
const TARGET: f64 = 0.62;
const THEIR_SPEED: f64 = 0.1;

/// His growth code set to this task and built under `target/`; its
/// folder.
fn build_peer() -> PathBuf {
    let source = smallenburg_source().join("Grow");
    assert!(
        source.join("mdgrow.c").exists(),
        "no Grow code at {}",
        source.display()
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/smallenburg-grow");
    let _ = std::fs::remove_dir_all(&dir);
    run(Command::new("cp").arg("-r").arg(&source).arg(&dir));
    let code = std::fs::read_to_string(dir.join("mdgrow.c")).unwrap();
    let set = |code: String, from: &str, to: &str| {
        assert!(code.contains(from), "mdgrow.c has no `{from}`");
        code.replace(from, to)
    };
    let code = set(code, "#define N 100000", &format!("#define N {N}"));
    let code = set(
        code,
        "double targetpackfrac = 0.5;",
        &format!("double targetpackfrac = {TARGET};"),
    );
    let code = set(
        code,
        "double growthspeed = 0.1;",
        &format!("double growthspeed = {THEIR_SPEED};"),
    );
    std::fs::write(dir.join("mdgrow.c"), code).unwrap();
    run(Command::new("make").current_dir(&dir));
    dir
}

/// Wall seconds, collisions and the packing fraction reached by his code.
fn theirs(dir: &Path) -> (f64, u64, f64) {
    let clock = Instant::now();
    let output = run(Command::new("./md").current_dir(dir));
    let seconds = clock.elapsed().as_secs_f64();
    let collisions = output
        .lines()
        .rev()
        .filter_map(|l| l.split("Collisions: ").nth(1))
        .find_map(|rest| rest.split(',').next()?.trim().parse::<u64>().ok())
        .expect("a collision count");
    let phi = output
        .lines()
        .find_map(|l| l.strip_prefix("Packing fraction      : "))
        .and_then(|x| x.trim().parse().ok())
        .expect("the packing fraction");
    (seconds, collisions, phi)
}

/// The same for hardbody.
fn ours(seed: u64) -> (f64, u64, f64) {
    let species = vec![Species {
        name: "ball".into(),
        shape: "Sphere(radius: 0.25)".parse().unwrap(),
        rotation: false,
    }];
    let volume = N as f64 * std::f64::consts::PI / 6.0 / TARGET;
    let box_ = PeriodicBox::new(Vector3::repeat(volume.cbrt())).unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let clock = Instant::now();
    let start = hardbody::state::start::lattice(box_, species, &[N], &mut rng).unwrap();
    let options = JamOptions {
        // γ = ln 2 / t_double, t_double = 1 / (his speed).
        growth_rate: std::f64::consts::LN_2 * THEIR_SPEED,
        packing_fraction: Some(TARGET),
        ..JamOptions::default()
    };
    let out = jam(
        &start,
        &options,
        &DynamicsOptions::default(),
        &mut rng,
        |_| true,
    )
    .unwrap();
    let seconds = clock.elapsed().as_secs_f64();
    let last = out.last.unwrap();
    (seconds, last.collisions, last.packing_fraction)
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

fn main() {
    let repeats: usize = std::env::var("REPEATS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let peer = build_peer();
    println!("{N} spheres grown to phi = {TARGET}, one core, {repeats} interleaved repeats");
    println!(
        "| repeat | hardbody s | peer s | ratio | hardbody us/collision | peer us/collision | collisions (ours, theirs) | phi (ours, theirs) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut ratios = Vec::new();
    for repeat in 0..repeats {
        let (s_ours, c_ours, phi_ours) = ours(repeat as u64 + 1);
        let (s_theirs, c_theirs, phi_theirs) = theirs(&peer);
        ratios.push(s_ours / s_theirs);
        println!(
            "| {repeat} | {s_ours:.2} | {s_theirs:.2} | {:.3} | {:.3} | {:.3} | {c_ours}, {c_theirs} | {phi_ours:.4}, {phi_theirs:.4} |",
            s_ours / s_theirs,
            s_ours / c_ours as f64 * 1e6,
            s_theirs / c_theirs as f64 * 1e6,
        );
    }
    println!(
        "median ratio of seconds, hardbody / peer: {:.3}",
        median(ratios)
    );
}
