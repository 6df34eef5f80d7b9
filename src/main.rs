//! The `hardbody` command line.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use hardbody::analysis::virial::excluded_volume;
use hardbody::bench::ocsi::{OcsiBenchConfig, run as run_ocsi, table as ocsi_table};
use hardbody::geometry::Shape;

/// Exit code for bad input (flags, shapes, scenes, logs).
const EXIT_BAD_INPUT: u8 = 2;
/// Exit code for a computation that failed.
const EXIT_FAILED: u8 = 1;

#[derive(Parser)]
#[command(
    name = "hardbody",
    version,
    about = "Dense packings and dynamics of hard ellipsoids, superellipsoids, cuboids and spheres"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run every stage of a scene (without SCENE: the built-in default scene).
    Run {
        /// Scene file (RON).
        scene: Option<PathBuf>,
        /// Log file to write.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Random seed (overrides the scene's).
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Orientation-averaged excluded volume and second virial coefficient of two shapes.
    Virial {
        /// First shape, in the scene spelling, e.g. "Cuboid(a: 0.5, b: 1.0, c: 1.5)".
        shape_a: String,
        /// Second shape, in the scene spelling, e.g. "Sphere(radius: 0.5)".
        shape_b: String,
        /// Monte Carlo samples.
        #[arg(long, default_value_t = 1_000_000)]
        samples: u64,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Run a benchmark suite.
    Bench {
        /// Suite to run.
        #[arg(value_enum)]
        suite: Suite,
        /// A short run (CI smoke test).
        #[arg(long)]
        quick: bool,
        /// Print a JSON array of rows instead of the table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Suite {
    /// Cuboid–sphere overlap: OCSI against Arvo, QRI, QRF, SSE (Tonti & Patti).
    Ocsi,
    /// Monte Carlo trial moves per second by shape at packing fraction 0.5.
    Mc,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Run { scene, out, seed } => run(scene, out, seed),
        Command::Virial {
            shape_a,
            shape_b,
            samples,
            seed,
            json,
        } => virial(&shape_a, &shape_b, samples, seed, json),
        Command::Bench { suite, quick, json } => match suite {
            Suite::Ocsi => bench_ocsi(quick, json),
            Suite::Mc => bench_mc(quick, json),
        },
    }
}

/// Pretty JSON on standard output (the `--json` of every command).
fn print_json(value: &impl serde::Serialize) {
    println!(
        "{}",
        serde_json::to_string_pretty(value).expect("plain numbers serialise")
    );
}

fn bad_input(message: impl std::fmt::Display) -> ExitCode {
    eprintln!("hardbody: {message}");
    ExitCode::from(EXIT_BAD_INPUT)
}

/// Scenes and stages do not exist yet: say so, and run what the command
/// line can on the default scene's shape instead of pretending to simulate.
fn run(scene: Option<PathBuf>, out: Option<PathBuf>, seed: Option<u64>) -> ExitCode {
    if let Some(scene) = scene {
        return bad_input(format!(
            "cannot run {}: scenes and stages are not implemented in this version ({}; the Monte Carlo and \
             EDMD drivers exist only as a library); only `virial` and `bench` work",
            scene.display(),
            env!("CARGO_PKG_VERSION")
        ));
    }
    if out.is_some() {
        return bad_input(
            "--out: this version writes no log (scenes and logs are not implemented yet)",
        );
    }
    println!(
        "hardbody {}: scenes and stages are not implemented yet (the Monte Carlo and EDMD drivers exist only as a library), so no scene was simulated \
         and no log was written.",
        env!("CARGO_PKG_VERSION")
    );
    println!(
        "Ran instead: the excluded volume of two of the default scene's ellipsoids (a = 1.0, b = c = 0.5)."
    );
    let shape: Shape = "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)"
        .parse()
        .expect("built-in shape");
    let e = excluded_volume(&shape, &shape, 400_000, seed.unwrap_or(7));
    println!(
        "  excluded volume = {:.4} ± {:.4}, B2 = {:.4} ({} samples)",
        e.excluded_volume, e.excluded_volume_error, e.b2, e.samples
    );
    ExitCode::SUCCESS
}

fn virial(a: &str, b: &str, samples: u64, seed: u64, json: bool) -> ExitCode {
    let (sa, sb) = match (a.parse::<Shape>(), b.parse::<Shape>()) {
        (Ok(x), Ok(y)) => (x, y),
        (Err(e), _) | (_, Err(e)) => return bad_input(e),
    };
    if samples == 0 {
        return bad_input("--samples must be at least 1");
    }
    let e = excluded_volume(&sa, &sb, samples, seed);
    if json {
        print_json(&e);
    } else {
        println!("shapes:          {sa} / {sb}");
        println!(
            "excluded volume: {:.6} ± {:.6}",
            e.excluded_volume, e.excluded_volume_error
        );
        println!(
            "B2:              {:.6} ± {:.6}",
            e.b2,
            e.excluded_volume_error / 2.0
        );
        println!("samples:         {}", e.samples);
    }
    ExitCode::SUCCESS
}

fn bench_ocsi(quick: bool, json: bool) -> ExitCode {
    let cfg = if quick {
        OcsiBenchConfig::quick()
    } else {
        OcsiBenchConfig::paper()
    };
    let terminal = std::io::stderr().is_terminal();
    let points = cfg.lengths.len() * cfg.lengths.len() * cfg.radii.len();
    let mut done = 0;
    let result = run_ocsi(&cfg, |l, w, r| {
        done += 1;
        if terminal {
            eprint!("\rocsi: {done}/{points} (L*={l}, W*={w}, R*={r})      ");
        }
    });
    if terminal {
        eprintln!();
    }
    match result {
        Ok(rows) => {
            if json {
                print_json(&rows);
            } else {
                println!(
                    "OCSI benchmark: {} configurations x {} sets per cuboid, L*, W* in {:?}, non-overlap target {}",
                    cfg.configurations, cfg.sets, cfg.lengths, cfg.non_overlap_ratio
                );
                print!("{}", ocsi_table(&rows));
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("hardbody: OCSI benchmark failed: {e}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

fn bench_mc(quick: bool, json: bool) -> ExitCode {
    let moves = match hardbody::bench::mc::run(quick) {
        Ok(rows) => rows,
        Err(e) => {
            eprintln!("hardbody: MC benchmark failed: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    let compression = match hardbody::bench::mc::compression(quick) {
        Ok(rows) => rows,
        Err(e) => {
            eprintln!("hardbody: MC compression benchmark failed: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if json {
        let mut all: Vec<serde_json::Value> = moves
            .iter()
            .map(|r| serde_json::to_value(r).expect("plain numbers"))
            .collect();
        all.extend(
            compression
                .iter()
                .map(|r| serde_json::to_value(r).expect("plain numbers")),
        );
        print_json(&all);
    } else {
        println!("| shape | N | phi | threads | trial moves/s (median) | translate acceptance |");
        println!("|---|---|---|---|---|---|");
        for r in &moves {
            println!(
                "| {} | {} | {:.3} | {} | {:.3e} | {:.2} |",
                r.shape,
                r.n,
                r.packing_fraction,
                r.threads,
                r.trial_moves_per_s,
                r.acceptance_translate
            );
        }
        println!();
        println!("| compression from a dilute lattice | N | phi reached | sweeps | seconds |");
        println!("|---|---|---|---|---|");
        for r in &compression {
            println!(
                "| {} | {} | {:.3} | {} | {:.1} |",
                r.shape, r.n, r.packing_fraction, r.sweeps, r.seconds
            );
        }
    }
    ExitCode::SUCCESS
}
