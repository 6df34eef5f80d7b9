//! The `hardbody` command line: the commands and their flags (clap), and
//! how they print and exit.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use hardbody::log::StorageFailure;

mod analyze;
mod bench;
mod coexistence;
mod free_energy;
mod progress;
mod run;
mod sweep;

use analyze::*;
use bench::*;
use coexistence::*;
use free_energy::*;
use hardbody::free_energy::PathChoices;
use run::*;
use sweep::*;

/// Exit code for bad input (flags, shapes, scenes, logs).
const EXIT_BAD_INPUT: u8 = 2;
/// The most worker threads `--threads` may ask (a thread costs its stack
/// before it does any work).
const MAX_THREADS: usize = 1024;

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
    /// Run every stage of a scene (without SCENE: the built-in default scene,
    /// data/scenes/default.ron). Ctrl-C ends the run cleanly with a final frame.
    Run {
        /// Scene file (RON).
        scene: Option<PathBuf>,
        /// Log file to write (overrides the scene's log.path).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Random seed (overrides the scene's).
        #[arg(long)]
        seed: Option<u64>,
        /// Continue the run logged in LOG (stopped, or cut off by a crash)
        /// from its last frame: the rest of its stage and the stages after it,
        /// bit for bit as if never interrupted; the log goes to --out, else
        /// to LOG (without a .partial suffix). With SCENE, run that scene's
        /// stages from that frame instead, logged to --out, else to the
        /// scene's log.path (never over LOG).
        #[arg(long, value_name = "LOG")]
        resume: Option<PathBuf>,
        /// With --out: if OUT.partial holds a frame (a killed or stopped
        /// run), resume it; if OUT is complete, there is nothing to do;
        /// otherwise run from the start (what a job of a sweep runs).
        #[arg(long = "continue", requires = "out", conflicts_with = "resume")]
        continue_: bool,
        /// Threads for the parallel Monte Carlo sweeps (default: every
        /// core).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
    },
    /// Validate a scene and print the plan: stages, pair kernels, effects and why.
    Check {
        /// Scene file (RON).
        scene: PathBuf,
        /// Print the plan as JSON: what each stage's driver will be built
        /// with, as the run then records it in the log's metadata.
        #[arg(long)]
        json: bool,
    },
    /// Run a scene, then find the free energy of the state it ends in:
    /// a crystal's (the scene starts from Crystal) by Frenkel–Ladd
    /// integration, springs to its start lattice, the centre of mass
    /// held; a fluid's by integrating its equation of state from the ideal
    /// gas. βF/N with Λ = 1 length unit, and its error.
    FreeEnergy {
        /// Scene file (RON).
        scene: PathBuf,
        /// Log file of the scene's run (overrides the scene's log.path).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Write the path's integrand (SVG) into this directory.
        #[arg(long, value_name = "DIR")]
        plot: Option<PathBuf>,
        #[command(flatten)]
        path: PathArgs,
    },
    /// Fluid–crystal coexistence: both scenes run, the fluid's free energy
    /// from its equation of state and the crystal's by Frenkel–Ladd, each
    /// phase's equation of state below its state, and the pressure where
    /// their chemical potentials cross, with errors.
    Coexistence {
        /// The fluid's scene (compressed to at or above freezing).
        #[arg(long, required_unless_present_any = ["job", "collect"])]
        fluid: Option<PathBuf>,
        /// The crystal's scene (starting from Crystal, at or above melting).
        #[arg(long, required_unless_present_any = ["job", "collect"])]
        solid: Option<PathBuf>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Write βμ of both branches against βP (SVG) into this directory.
        #[arg(long, value_name = "DIR")]
        plot: Option<PathBuf>,
        /// Write the study as a signac workspace with a row workflow in
        /// DIR instead of running it: one job per part (each phase's free
        /// energy, each point of each branch), to run on a cluster.
        #[arg(long, value_name = "DIR", conflicts_with_all = ["json", "plot", "job", "collect"])]
        workspace: Option<PathBuf>,
        /// Run the one part of a study in this job folder
        /// (DIR/workspace/ID), its result to part.json there (what the
        /// study's row workflow runs).
        #[arg(long, value_name = "FOLDER", conflicts_with_all = [
            "fluid", "solid", "json", "plot", "collect", "points", "sweeps", "spring", "seed",
        ])]
        job: Option<PathBuf>,
        /// Cross the parts of the study in DIR once all are done, printed
        /// (and plotted) as when run here.
        #[arg(long, value_name = "DIR", conflicts_with_all = [
            "fluid", "solid", "points", "sweeps", "spring", "seed", "threads",
        ])]
        collect: Option<PathBuf>,
        /// Threads for the parallel paths (default: every core).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        #[command(flatten)]
        path: PathArgs,
    },
    /// Export a log's frames to another format (GSD for OVITO, freud, HOOMD-blue).
    Export {
        /// MCAP log written by `hardbody run`.
        log: PathBuf,
        /// Write the frames as a GSD file in HOOMD's schema, with particle shapes.
        #[arg(long, value_name = "OUT.gsd")]
        gsd: PathBuf,
    },
    /// Equilibrium averages of a log, stage by stage: for every /stats
    /// observable where it equilibrated, its mean and standard error from
    /// there (correlation included), and whether the stage equilibrated.
    Analyze {
        /// MCAP log written by `hardbody run` (complete or partial); several
        /// logs of one scene run with other seeds are averaged as replicas.
        #[arg(required = true, num_args = 1..)]
        log: Vec<PathBuf>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Write one plot (SVG) per stage and observable into this
        /// directory: the series, its mean and where it equilibrated (with
        /// --packing: g(r), S(k) and the contact-number histogram).
        #[arg(long, value_name = "DIR")]
        plot: Option<PathBuf>,
        /// Analyse a frame's contact network instead: contacts, rattlers,
        /// the backbone's mean contact number against the isostatic one,
        /// the contact-number distribution.
        #[arg(long)]
        packing: bool,
        /// With --packing: the frame (0 the first; default the last).
        #[arg(long, value_name = "K", requires = "packing")]
        frame: Option<usize>,
        /// With --packing: the gap below which two bodies touch, relative
        /// to the smaller one's smallest half-extent (default: read from
        /// the packing, on the plateau of the contact count against the
        /// gap; the report says which it used).
        #[arg(long, value_name = "GAP", requires = "packing")]
        gap: Option<f64>,
    },
    /// Print a log's channels, message counts, stages and last stats.
    Inspect {
        /// MCAP log written by `hardbody run`.
        log: PathBuf,
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
    /// A parameter sweep as a signac workspace run by row: the product of
    /// the values of --set (and --replicas seeds each), one job folder
    /// each, with a workflow.toml to run, resume and analyze them.
    #[command(args_conflicts_with_subcommands = true)]
    Sweep {
        #[command(subcommand)]
        collect: Option<SweepCommand>,
        /// The template scene (RON).
        template: Option<PathBuf>,
        /// KEY=V1,V2,...: a field of the scene by its path
        /// (stages[1].ensemble.pressure, species[0].shape.a, seed) and its
        /// values; repeat for more fields.
        #[arg(long, value_name = "KEY=V1,V2")]
        set: Vec<String>,
        /// Seeds per state point: the template's seed and the next ones.
        #[arg(long, default_value_t = 1)]
        replicas: u64,
        /// The folder to write the workspace in (new, empty, or this
        /// sweep's, to which new jobs are added).
        #[arg(long, value_name = "DIR")]
        workspace: Option<PathBuf>,
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
        /// Write the suite's plots (SVG) into this directory
        /// (all but scene and edmd, which are tables).
        #[arg(long, value_name = "DIR")]
        plot: Option<std::path::PathBuf>,
    },
}

/// What may be chosen of a free-energy path (`free-energy`,
/// `coexistence`).
#[derive(clap::Args)]
struct PathArgs {
    /// Gauss–Legendre points: along ln(βλ + c) for a crystal (default 12),
    /// in density for a fluid's equation of state (default 8).
    #[arg(long)]
    points: Option<usize>,
    /// Sweeps sampled at each point (default 40000 on a crystal's path,
    /// 20000 on a fluid's and on coexistence's branches; a tenth more are
    /// run first).
    #[arg(long)]
    sweeps: Option<u64>,
    /// The crystal's strongest springs βλ_max, in 1/length² (default:
    /// chosen from the crystal, the weakest whose Einstein crystal is
    /// overlap-free in 90 % of samples).
    #[arg(long)]
    spring: Option<f64>,
    /// Random seed of the paths (default the scene's).
    #[arg(long)]
    seed: Option<u64>,
}

impl PathArgs {
    fn choices(&self) -> PathChoices {
        PathChoices {
            points: self.points,
            sweeps: self.sweeps,
            spring: self.spring,
            seed: self.seed,
        }
    }
}

#[derive(Subcommand)]
enum SweepCommand {
    /// One row per state point: its values, its jobs finished, partial or
    /// failed, and per observable of the measured stage the mean over the
    /// finished replicas with its error.
    Collect {
        /// The sweep's folder (its --workspace).
        dir: PathBuf,
        /// The stage to average (default: the last that is not a
        /// compression).
        #[arg(long)]
        stage: Option<usize>,
        /// Print JSON instead of the table.
        #[arg(long)]
        json: bool,
        /// Write the equation of state (pressure against packing
        /// fraction, with errors) here as SVG, when the sweep varies a
        /// pressure.
        #[arg(long, value_name = "DIR")]
        plot: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Suite {
    /// Cuboid–sphere overlap: OCSI against Arvo, QRI, QRF, SSE (Tonti & Patti).
    Ocsi,
    /// Monte Carlo trial moves per second by shape at packing fraction 0.5.
    Mc,
    /// Compression from a dilute fluid: seconds and sweeps by shape, and against N.
    Compress,
    /// Jammed packings by event-driven growth: phi_J, contacts and seconds by shape and rate.
    Jam,
    /// 1000 spheres jammed at four growth rates: phi_J and z against the rate.
    JamRate,
    /// Hard-sphere dynamics through the full scene path against the library directly.
    Scene,
    /// Event-driven dynamics: time per collision for spheres, ellipsoids and cubes.
    Edmd,
    /// Time per collision against the neighbour shell; the fastest shell against phi.
    EdmdShell,
    /// Time per collision against phi for ellipsoids of aspect 2 and 0.5, cells and lists.
    EdmdDensity,
    /// Time per collision against aspect ratio 0.1-10 at phi 0.3, 0.4, 0.5, cells and lists.
    EdmdElongation,
    /// Time per collision and Newton iterations against the superellipsoid exponent p from 2 to 10.
    Superellipsoid,
    /// The cost of each optional effect (rotation, walls, lists, observables), on and off.
    Effects,
    /// What the grazing threshold and the Newton tolerance buy and cost (ellipsoids, aspect 2 and 5).
    EdmdTolerance,
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            scene,
            out,
            seed,
            resume,
            continue_,
            threads,
        } => {
            if let Err(code) = use_threads(threads) {
                return code;
            }
            if continue_ {
                continue_run(scene, out, seed)
            } else {
                run(scene, out, seed, resume)
            }
        }
        Command::Sweep {
            collect:
                Some(SweepCommand::Collect {
                    dir,
                    stage,
                    json,
                    plot,
                }),
            ..
        } => sweep_collect(&dir, stage, json, plot.as_deref()),
        Command::Sweep {
            collect: None,
            template,
            set,
            replicas,
            workspace,
        } => match (template, workspace) {
            (Some(t), Some(w)) => sweep(&t, &set, replicas, &w),
            (None, _) => bad_input("sweep: give a TEMPLATE scene (or: sweep collect DIR)"),
            (_, None) => bad_input("sweep: give --workspace DIR"),
        },
        Command::Check { scene, json } => check(&scene, json),
        Command::Inspect { log } => inspect(&log),
        Command::Analyze {
            log,
            json,
            plot,
            packing,
            frame,
            gap,
        } => match (log.as_slice(), packing) {
            ([one], true) => analyze_packing(one, frame, gap, json, plot.as_deref()),
            (_, true) => bad_input("--packing: one log at a time"),
            ([one], false) => analyze(one, json, plot.as_deref()),
            (many, false) => analyze_replicas(many, json, plot.as_deref()),
        },
        Command::Export { log, gsd } => export(&log, &gsd),
        Command::Coexistence {
            fluid,
            solid,
            json,
            plot,
            workspace,
            job,
            collect,
            threads,
            path,
        } => {
            if let Err(code) = use_threads(threads) {
                return code;
            }
            match (fluid, solid, workspace, job, collect) {
                (_, _, _, Some(job), _) => coexistence_job(&job),
                (_, _, _, _, Some(dir)) => coexistence_collect(&dir, json, plot.as_deref()),
                (Some(fluid), Some(solid), Some(dir), _, _) => {
                    coexistence_workspace(&fluid, &solid, path.choices(), &dir)
                }
                (Some(fluid), Some(solid), None, _, _) => {
                    coexistence(&fluid, &solid, path.choices(), json, plot.as_deref())
                }
                _ => bad_input("coexistence: give --fluid and --solid, --job or --collect"),
            }
        }
        Command::FreeEnergy {
            scene,
            out,
            json,
            plot,
            path,
        } => free_energy(&scene, out, path.choices(), json, plot.as_deref()),
        Command::Virial {
            shape_a,
            shape_b,
            samples,
            seed,
            json,
        } => virial(&shape_a, &shape_b, samples, seed, json),
        Command::Bench {
            suite,
            quick,
            json,
            plot,
        } => bench(suite, quick, json, plot.as_deref()),
    }
}

/// The worker threads of the parallel work, if given; made once,
/// before any parallel work.
fn use_threads(threads: Option<usize>) -> Result<(), ExitCode> {
    if let Some(n) = threads {
        if !(1..=MAX_THREADS).contains(&n) {
            return Err(bad_input(format!(
                "--threads must lie in [1, {MAX_THREADS}], got {n}"
            )));
        }
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global();
    }
    Ok(())
}

/// Pretty JSON on standard output (the `--json` of every command).
fn print_json(value: &impl serde::Serialize) {
    say(&serde_json::to_string_pretty(value).expect("plain numbers serialise"));
}

fn bad_input(message: impl std::fmt::Display) -> ExitCode {
    esay(&format!("hardbody: {message}"));
    ExitCode::from(EXIT_BAD_INPUT)
}

/// An output a command could not write: a failure (exit 1) where the
/// file system could not take it (full, over quota, read-only), bad input
/// (exit 2) where the path was at fault.
fn not_written(e: impl StorageFailure + std::fmt::Display) -> ExitCode {
    if e.is_storage_failure() {
        esay(&format!("hardbody: {e}"));
        ExitCode::from(EXIT_FAILED)
    } else {
        bad_input(e)
    }
}

/// Exit code of a run stopped by Ctrl-C (its log is complete up to there).
const EXIT_INTERRUPTED: u8 = 130;

/// Prints a line on standard output, ignoring a closed pipe (`| head`).
fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout(), "{line}");
}

/// Prints text that already ends its lines, ignoring a closed pipe.
fn print_block(text: &str) {
    use std::io::Write;
    let _ = write!(std::io::stdout(), "{text}");
}

/// Prints a line on standard error, ignoring a closed stream.
fn esay(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}
