//! The `hardbody` command line.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use std::sync::atomic::{AtomicBool, Ordering};

use clap::{Parser, Subcommand};
use hardbody::analysis::virial::excluded_volume;
use hardbody::bench::ocsi::{OcsiBenchConfig, run as run_ocsi, table as ocsi_table};
use hardbody::geometry::Shape;
use hardbody::log::file::check_output;
use hardbody::log::read::read_log;
use hardbody::run::{Progress, RunError, RunSummary, check_start, resume_run, run_scene};
use hardbody::scene::Scene;
use hardbody::scene::plan::{Plan, Report};

mod progress;

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
        /// bit for bit as if never interrupted. With SCENE, run that scene's
        /// stages from that frame instead. The log goes to --out, else to LOG
        /// (without a .partial suffix).
        #[arg(long, value_name = "LOG")]
        resume: Option<PathBuf>,
    },
    /// Validate a scene and print the plan: stages, pair kernels, effects and why.
    Check {
        /// Scene file (RON).
        scene: PathBuf,
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
        /// directory: the series, its mean and where it equilibrated.
        #[arg(long, value_name = "DIR")]
        plot: Option<PathBuf>,
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

#[derive(Clone, Copy, clap::ValueEnum)]
enum Suite {
    /// Cuboid–sphere overlap: OCSI against Arvo, QRI, QRF, SSE (Tonti & Patti).
    Ocsi,
    /// Monte Carlo trial moves per second by shape at packing fraction 0.5.
    Mc,
    /// Compression from a dilute fluid: seconds and sweeps by shape, and against N.
    Compress,
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            scene,
            out,
            seed,
            resume,
        } => run(scene, out, seed, resume),
        Command::Check { scene } => check(&scene),
        Command::Inspect { log } => inspect(&log),
        Command::Analyze { log, json, plot } => match log.as_slice() {
            [one] => analyze(one, json, plot.as_deref()),
            many => analyze_replicas(many, json, plot.as_deref()),
        },
        Command::Export { log, gsd } => export(&log, &gsd),
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
        } => {
            use hardbody::bench::edmd_speed;
            if let Some(dir) = &plot {
                if !matches!(
                    suite,
                    Suite::Ocsi
                        | Suite::Mc
                        | Suite::EdmdShell
                        | Suite::EdmdDensity
                        | Suite::EdmdElongation
                        | Suite::Superellipsoid
                        | Suite::EdmdTolerance
                        | Suite::Effects
                        | Suite::Compress
                ) {
                    return bad_input(
                        "--plot: this suite has no plots (scene and edmd are tables)",
                    );
                }
                if let Err(e) = std::fs::create_dir_all(dir) {
                    return bad_input(format!("--plot {}: {e}", dir.display()));
                }
            }
            match suite {
                Suite::Ocsi => bench_ocsi(quick, json, plot.as_deref()),
                Suite::Mc => bench_mc(quick, json, plot.as_deref()),
                Suite::Compress => bench_compress(quick, json, plot.as_deref()),
                Suite::Scene => bench_scene(quick, json),
                Suite::Edmd => bench_speed("edmd", edmd_speed::speed(quick), json, None, None),
                Suite::EdmdShell => bench_speed(
                    "edmd-shell",
                    edmd_speed::shell(quick),
                    json,
                    plot.as_deref(),
                    Some(edmd_speed::plot_shell),
                ),
                Suite::EdmdDensity => bench_speed(
                    "edmd-density",
                    edmd_speed::density(quick),
                    json,
                    plot.as_deref(),
                    Some(edmd_speed::plot_density),
                ),
                Suite::EdmdElongation => bench_speed(
                    "edmd-elongation",
                    edmd_speed::elongation(quick),
                    json,
                    plot.as_deref(),
                    Some(edmd_speed::plot_elongation),
                ),
                Suite::Superellipsoid => bench_speed(
                    "superellipsoid",
                    edmd_speed::superellipsoid(quick),
                    json,
                    plot.as_deref(),
                    Some(edmd_speed::plot_superellipsoid),
                ),
                Suite::EdmdTolerance => bench_edmd_tolerance(quick, json, plot.as_deref()),
                Suite::Effects => bench_effects(quick, json, plot.as_deref()),
            }
        }
    }
}

/// Pretty JSON on standard output (the `--json` of every command).
fn print_json(value: &impl serde::Serialize) {
    say(&serde_json::to_string_pretty(value).expect("plain numbers serialise"));
}

fn bad_input(message: impl std::fmt::Display) -> ExitCode {
    esay(&format!("hardbody: {message}"));
    ExitCode::from(EXIT_BAD_INPUT)
}

/// Exit code of a run stopped by Ctrl-C (its log is complete up to there).
const EXIT_INTERRUPTED: u8 = 130;

/// The built-in default scene.
const DEFAULT_SCENE: &str = include_str!("../data/scenes/default.ron");

/// Reads and validates a scene file; the error names the file, the line
/// and the field.
fn load_scene(path: &std::path::Path) -> Result<(Scene, String), String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read scene {}: {e}", path.display()))?;
    let scene = Scene::parse(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((scene, text))
}

fn run(
    scene_path: Option<PathBuf>,
    out: Option<PathBuf>,
    seed: Option<u64>,
    resume: Option<PathBuf>,
) -> ExitCode {
    if let (Some(log), None) = (&resume, &scene_path) {
        return resume_log(log, out, seed);
    }
    let (mut scene, text) = match &scene_path {
        Some(p) => match load_scene(p) {
            Ok(s) => s,
            Err(e) => return bad_input(e),
        },
        None => (
            Scene::parse(DEFAULT_SCENE).expect("the default scene is valid"),
            DEFAULT_SCENE.to_string(),
        ),
    };
    if let Some(seed) = seed {
        scene.seed = seed;
    }
    if let Some(log) = &resume {
        scene.start = hardbody::scene::Start::Resume(log.display().to_string());
    }
    if let Some(p) = &scene_path
        && let Err(e) = preflight(p, &text, &scene, out.is_some())
    {
        return bad_input(e);
    }
    let log_path = out.unwrap_or_else(|| PathBuf::from(&scene.log.path));
    let inputs: Vec<&std::path::Path> = scene_path
        .iter()
        .chain(&resume)
        .map(|p| p.as_path())
        .collect();
    if let Err(e) = check_output(&log_path, true, &inputs) {
        return bad_input(e);
    }
    handle_ctrl_c();
    let name = scene_path
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|| "the default scene".into());
    esay(&format!(
        "hardbody {}: running {name} ({} particles, {} stages, seed {}), log {}",
        env!("CARGO_PKG_VERSION"),
        scene.particle_count(),
        scene.stages.len(),
        scene.seed,
        log_path.display()
    ));
    let mut progress = progress_display();
    finish_run(run_scene(
        &scene,
        &text,
        &log_path,
        progress.as_mut(),
        &STOP,
    ))
}

static STOP: AtomicBool = AtomicBool::new(false);

/// A first Ctrl-C ends the run cleanly at the next sweep or output event;
/// a second one exits at once.
fn handle_ctrl_c() {
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            std::process::exit(EXIT_INTERRUPTED as i32);
        }
    });
}

fn progress_display() -> Box<dyn Progress> {
    if std::io::stderr().is_terminal() {
        Box::new(progress::Bars::default())
    } else {
        Box::new(progress::Lines::default())
    }
}

fn resume_log(log: &std::path::Path, out: Option<PathBuf>, seed: Option<u64>) -> ExitCode {
    if seed.is_some() {
        return bad_input("--seed: a resumed run keeps the seed of the run it continues");
    }
    let out = out.unwrap_or_else(|| {
        let text = log.display().to_string();
        PathBuf::from(text.strip_suffix(".partial").unwrap_or(&text))
    });
    // The log resumed from may be the output's partial log: it is
    // replaced only once the new log holds as much.
    if let Err(e) = check_output(&out, true, &[]) {
        return bad_input(e);
    }
    handle_ctrl_c();
    esay(&format!(
        "hardbody {}: resuming {} from its last frame, log {}",
        env!("CARGO_PKG_VERSION"),
        log.display(),
        out.display()
    ));
    let mut progress = progress_display();
    finish_run(resume_run(log, &out, progress.as_mut(), &STOP))
}

fn finish_run(result: Result<RunSummary, RunError>) -> ExitCode {
    match result {
        Ok(summary) => {
            for note in &summary.notes {
                esay(&format!("hardbody: {note}"));
            }
            for line in &summary.stages {
                say(line);
            }
            say(&format!("log written: {}", summary.log.display()));
            if summary.interrupted {
                esay("hardbody: interrupted; the log is complete up to the last frame");
                ExitCode::from(EXIT_INTERRUPTED)
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) if e.is_bad_input() => bad_input(e),
        Err(e) => {
            esay(&format!("hardbody: {e}"));
            ExitCode::from(EXIT_FAILED)
        }
    }
}

/// Prints a line on standard output, ignoring a closed pipe (`| head`).
fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout(), "{line}");
}

/// A refusal of the scene file `path` (text `text`) at `field`, with the
/// line the field is on.
fn scene_refusal(
    path: &std::path::Path,
    text: &str,
    field: &str,
    e: impl std::fmt::Display,
) -> String {
    let line = hardbody::scene::outline::Outline::of(text)
        .line_of(field)
        .map(|l| format!("line {l}: "))
        .unwrap_or_default();
    format!("{}: {line}{field}: {e}", path.display())
}

/// What a scene file needs besides parsing to run: a start that can be
/// made (a `Resume` log that holds a state of these species) and, unless
/// `--out` replaces it, a log path that may be written. `run` and `check`
/// refuse the same scenes.
fn preflight(
    path: &std::path::Path,
    text: &str,
    scene: &Scene,
    out_given: bool,
) -> Result<(), String> {
    if let Err(e) = check_start(scene) {
        return Err(scene_refusal(path, text, "start", e));
    }
    if !out_given && let Err(e) = check_output(std::path::Path::new(&scene.log.path), true, &[path])
    {
        return Err(scene_refusal(path, text, "log.path", e));
    }
    Ok(())
}

fn check(path: &std::path::Path) -> ExitCode {
    let (scene, text) = match load_scene(path) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    if let Err(e) = preflight(path, &text, &scene, false) {
        return bad_input(e);
    }
    let plan = Plan::of(&scene);
    say(&format!("{}: valid", path.display()));
    say(&Report {
        scene: &scene,
        plan: &plan,
    }
    .to_string());
    ExitCode::SUCCESS
}

/// A log's contents for `analyze`: refused with exit 2 if unreadable;
/// damage is said and what precedes it analysed.
fn log_to_analyze(path: &std::path::Path) -> Result<hardbody::log::read::LogContents, ExitCode> {
    let contents = read_log(path, false).map_err(bad_input)?;
    if let Some(d) = &contents.damage {
        esay(&format!(
            "hardbody: {}: {d}; analysing the /stats before it",
            path.display()
        ));
    }
    Ok(contents)
}

fn analyze(path: &std::path::Path, json: bool, plot: Option<&std::path::Path>) -> ExitCode {
    use hardbody::analysis::series::FEW_EFFECTIVE_SAMPLES;
    use hardbody::log::averages::stage_averages;
    let contents = match log_to_analyze(path) {
        Ok(c) => c,
        Err(code) => return code,
    };
    let stats: Vec<_> = contents.stats.iter().map(|(_, s)| s.clone()).collect();
    let stages = stage_averages(&stats);
    if let Some(dir) = plot {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return bad_input(format!("--plot {}: {e}", dir.display()));
        }
        for stage in &stages {
            if let Err(e) = plot_stage(dir, &stats, stage) {
                return bad_input(e);
            }
        }
    }
    if json {
        print_json(&serde_json::json!({
            "log": path.display().to_string(),
            "stages": stages,
        }));
    } else {
        say(&format!("{}:", path.display()));
        for stage in &stages {
            let unit = if stage.stage == "dynamics" {
                "t"
            } else {
                "sweep"
            };
            let verdict = if stage.stage == "compress" {
                "compression (not an equilibrium stage: no averages)".to_string()
            } else if stage.equilibrated {
                "equilibrated".to_string()
            } else {
                format!(
                    "NOT EQUILIBRATED ({}): run it longer",
                    stage.not_equilibrated.join(", ")
                )
            };
            say(&format!(
                "stage {} ({}), {} stats messages, {unit} {}-{}: {verdict}",
                stage.stage_index, stage.stage, stage.samples, stage.span[0], stage.span[1]
            ));
            if let Some(strains) = stage.solver.and_then(|w| w.strains_in_words()) {
                say(&format!("  solver strains: {strains}"));
            }
            if stage.observables.is_empty() {
                continue;
            }
            say(&format!(
                "  {:<22} {:>26} {:>16} {:>8} {:>8}",
                "observable",
                "mean +- error",
                format!("from {unit}"),
                "g",
                "N_eff"
            ));
            for (name, o) in &stage.observables {
                let e = &o.estimate;
                let value = if o.constant {
                    format!("{} (constant)", e.mean)
                } else {
                    format!("{:.6} +- {:.6}", e.mean, e.error)
                };
                say(&format!(
                    "  {:<22} {:>26} {:>16} {:>8.2} {:>8.1}{}",
                    name,
                    value,
                    o.equilibrated_from,
                    e.statistical_inefficiency,
                    e.effective_samples,
                    if !e.equilibrated {
                        "  not equilibrated"
                    } else if e.effective_samples < FEW_EFFECTIVE_SAMPLES && !o.constant {
                        "  few effective samples: the error is uncertain"
                    } else {
                        ""
                    }
                ));
            }
        }
    }
    let never: Vec<String> = stages
        .iter()
        .filter(|s| s.stage != "compress" && !s.equilibrated)
        .map(|s| s.stage_index.to_string())
        .collect();
    if !never.is_empty() {
        esay(&format!(
            "hardbody: warning: stage {} never equilibrated: its averages are not equilibrium values",
            never.join(", ")
        ));
    }
    ExitCode::SUCCESS
}

/// Averages over replicas: each log analysed as `analyze` does, then
/// every stage's observables averaged over the logs, with an error that
/// is the larger of the runs' errors combined and their spread.
fn analyze_replicas(paths: &[PathBuf], json: bool, plot: Option<&std::path::Path>) -> ExitCode {
    use hardbody::log::averages::{stage_averages, stages_over_replicas};
    let mut runs = Vec::new();
    let mut first_scene: Option<Scene> = None;
    for (k, path) in paths.iter().enumerate() {
        let contents = match log_to_analyze(path) {
            Ok(c) => c,
            Err(code) => return code,
        };
        // Replicas: the same scene but for the seed and the log's path.
        let scene = contents
            .metadata
            .get("scene_resolved")
            .and_then(|t| Scene::parse(t).ok())
            .map(|s| Scene {
                seed: 0,
                log: Default::default(),
                ..s
            });
        match (&first_scene, scene) {
            (_, None) => {
                return bad_input(format!(
                    "{}: no readable scene in its metadata",
                    path.display()
                ));
            }
            (None, Some(s)) => first_scene = Some(s),
            (Some(f), Some(s)) if *f != s => {
                return bad_input(format!(
                    "{}: its scene differs from that of {} other than in the seed: not a replica",
                    path.display(),
                    paths[0].display()
                ));
            }
            _ => {}
        }
        let stats: Vec<_> = contents.stats.iter().map(|(_, s)| s.clone()).collect();
        let stages = stage_averages(&stats);
        if let Some(dir) = plot {
            let dir = dir.join(format!("replica{}", k + 1));
            if let Err(e) = std::fs::create_dir_all(&dir) {
                return bad_input(format!("--plot {}: {e}", dir.display()));
            }
            for stage in &stages {
                if let Err(e) = plot_stage(&dir, &stats, stage) {
                    return bad_input(e);
                }
            }
        }
        runs.push(stages);
    }
    let combined = match stages_over_replicas(&runs) {
        Ok(c) => c,
        Err(e) => return bad_input(e),
    };
    if json {
        print_json(&serde_json::json!({
            "logs": paths.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "stages": combined,
        }));
    } else {
        say(&format!("{} replicas:", paths.len()));
        for stage in &combined {
            if stage.stage == "compress" {
                continue;
            }
            say(&format!(
                "stage {} ({}): {}",
                stage.stage_index,
                stage.stage,
                if stage.equilibrated {
                    "equilibrated in every replica"
                } else {
                    "NOT EQUILIBRATED in some replica: run it longer"
                }
            ));
            say(&format!(
                "  {:<22} {:>26} {:>12}",
                "observable", "mean +- error", "spread"
            ));
            for (name, a) in &stage.observables {
                say(&format!(
                    "  {:<22} {:>26} {:>12.6}",
                    name,
                    format!("{:.6} +- {:.6}", a.mean, a.error),
                    a.spread
                ));
            }
        }
    }
    if combined
        .iter()
        .any(|s| s.stage != "compress" && !s.equilibrated)
    {
        esay(
            "hardbody: warning: a stage never equilibrated in some replica: its averages are not equilibrium values",
        );
    }
    ExitCode::SUCCESS
}

/// One SVG per observable of `stage`: the series, the mean of its
/// equilibrated part, and where that part begins.
fn plot_stage(
    dir: &std::path::Path,
    stats: &[hardbody::log::Stats],
    stage: &hardbody::log::averages::StageAverages,
) -> Result<(), String> {
    use hardbody::bench::plot::{Figure, Series, line_plot};
    let dynamics = stage.stage == "dynamics";
    for (name, o) in &stage.observables {
        if o.constant {
            continue;
        }
        let points: Vec<(f64, f64)> = stats
            .iter()
            .filter(|s| s.stage_index == stage.stage_index)
            .filter_map(|s| {
                let x = s.sweep.map(|w| w as f64).or(s.time)?;
                let v = serde_json::to_value(s).ok()?.get(name)?.as_f64()?;
                Some((x, v))
            })
            .collect();
        let (lo, hi) = points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        let from = o.equilibrated_from;
        let end = points.last().map_or(from, |p| p.0);
        let series = [
            Series {
                name: name.clone(),
                points,
            },
            Series {
                name: format!("mean {:.5} +- {:.5}", o.estimate.mean, o.estimate.error),
                points: vec![(from, o.estimate.mean), (end, o.estimate.mean)],
            },
            Series {
                name: "equilibrated from here".into(),
                points: vec![(from, lo), (from, hi)],
            },
        ];
        let title = format!("stage {} ({}): {name}", stage.stage_index, stage.stage);
        let figure = Figure {
            title: &title,
            x_label: if dynamics { "time" } else { "sweeps" },
            y_label: name,
            log_x: false,
            log_y: false,
        };
        let path = dir.join(format!("stage{}-{name}.svg", stage.stage_index));
        line_plot(&path, &figure, &series)?;
    }
    Ok(())
}

fn inspect(path: &std::path::Path) -> ExitCode {
    let contents = match read_log(path, false) {
        Ok(c) => c,
        Err(e) => return bad_input(e),
    };
    say(&format!(
        "{}: hardbody {} log{}",
        path.display(),
        contents
            .metadata
            .get("version")
            .map(String::as_str)
            .unwrap_or("?"),
        if contents.truncated {
            " (cut off: read up to its last complete record)"
        } else {
            ""
        }
    ));
    say("channels:");
    for (topic, count) in &contents.counts {
        say(&format!("  {topic}: {count} messages"));
    }
    say("stages:");
    let mut stages: Vec<(usize, String, usize, String)> = Vec::new();
    for (_, s) in &contents.stats {
        let progress = match (s.sweep, s.time) {
            (Some(sweep), _) => format!("sweep {sweep}"),
            (_, Some(t)) => format!("t = {t}"),
            _ => String::new(),
        };
        match stages.last_mut() {
            Some(last) if last.0 == s.stage_index => {
                last.2 += 1;
                last.3 = progress;
            }
            _ => stages.push((s.stage_index, s.stage.clone(), 1, progress)),
        }
    }
    for (index, kind, count, progress) in &stages {
        say(&format!(
            "  {index} {kind}: {count} stats messages, last at {progress}"
        ));
    }
    if let Some((_, last)) = contents.stats.last() {
        say("last stats:");
        say(&serde_json::to_string_pretty(last).expect("stats serialise"));
    }
    if let Some((_, failure)) = &contents.failure {
        say(&format!(
            "failed in stage {}: {}{}",
            failure.stage_index,
            failure.message,
            if failure.dump.is_some() {
                " (the dynamics' stored state at the failure is in /failure)"
            } else {
                ""
            }
        ));
    }
    match &contents.damage {
        Some(d) => bad_input(format!(
            "{}: {d}; shown above is what precedes it (`hardbody run --resume` continues from its last intact frame)",
            path.display()
        )),
        None => ExitCode::SUCCESS,
    }
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
        say(&format!("shapes:          {sa} / {sb}"));
        say(&format!(
            "excluded volume: {:.6} ± {:.6}",
            e.excluded_volume, e.excluded_volume_error
        ));
        say(&format!(
            "B2:              {:.6} ± {:.6}",
            e.b2,
            e.excluded_volume_error / 2.0
        ));
        say(&format!("samples:         {}", e.samples));
    }
    ExitCode::SUCCESS
}

fn bench_ocsi(quick: bool, json: bool, plot: Option<&std::path::Path>) -> ExitCode {
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
        esay("");
    }
    match result {
        Ok((rows, points)) => {
            if json {
                print_json(&rows);
            } else {
                say(&format!(
                    "OCSI benchmark: {} configurations x {} sets per cuboid, L*, W* in {:?}, non-overlap target {}",
                    cfg.configurations, cfg.sets, cfg.lengths, cfg.non_overlap_ratio
                ));
                print_block(&ocsi_table(&rows));
            }
            match plot {
                Some(dir) => report_plots("OCSI", hardbody::bench::ocsi::plot(&points, dir)),
                None => ExitCode::SUCCESS,
            }
        }
        Err(e) => {
            esay(&format!("hardbody: OCSI benchmark failed: {e}"));
            ExitCode::from(EXIT_FAILED)
        }
    }
}

fn bench_mc(quick: bool, json: bool, plot: Option<&std::path::Path>) -> ExitCode {
    use hardbody::bench::mc;
    let failed = |what: &str, e: &dyn std::fmt::Display| {
        esay(&format!("hardbody: MC {what} benchmark failed: {e}"));
        ExitCode::from(EXIT_FAILED)
    };
    let moves = match mc::run(quick) {
        Ok(rows) => rows,
        Err(e) => return failed("speed", &e),
    };
    let density = match mc::by_density(quick) {
        Ok(rows) => rows,
        Err(e) => return failed("density", &e),
    };
    let sizes = match mc::by_move_size(quick) {
        Ok(rows) => rows,
        Err(e) => return failed("move-size", &e),
    };
    if json {
        let mut all: Vec<serde_json::Value> = Vec::new();
        let mut add = |v: serde_json::Value, table: &str| {
            if let serde_json::Value::Array(rows) = v {
                for mut r in rows {
                    r["table"] = table.into();
                    all.push(r);
                }
            }
        };
        let value = |x: Result<serde_json::Value, serde_json::Error>| x.expect("plain numbers");
        add(value(serde_json::to_value(&moves)), "speed");
        add(value(serde_json::to_value(&density)), "density");
        add(value(serde_json::to_value(&sizes)), "move size");
        print_json(&all);
    } else {
        say(
            "| shape | N | phi | threads | sweep | trial moves/s (median) | translate acceptance |",
        );
        say("|---|---|---|---|---|---|---|");
        for r in moves.iter().chain(&density) {
            say(&format!(
                "| {} | {} | {:.3} | {} | {} | {:.3e} | {:.2} |",
                r.shape,
                r.n,
                r.packing_fraction,
                r.threads,
                r.sweep,
                r.trial_moves_per_s,
                r.acceptance_translate
            ));
        }
        say("");
        say(
            "| shape | phi | translation (thicknesses) | rotation (rad) | translate acceptance | rotate acceptance | trial moves/s |",
        );
        say("|---|---|---|---|---|---|---|");
        for r in &sizes {
            say(&format!(
                "| {} | {:.3} | {} | {} | {:.3} | {:.3} | {:.3e} |",
                r.shape,
                r.packing_fraction,
                r.translate,
                r.rotate,
                r.acceptance_translate,
                r.acceptance_rotate,
                r.trial_moves_per_s
            ));
        }
    }
    match plot {
        Some(dir) => report_plots("MC", mc::plot(&density, &sizes, dir)),
        None => ExitCode::SUCCESS,
    }
}

fn bench_compress(quick: bool, json: bool, plot: Option<&std::path::Path>) -> ExitCode {
    use hardbody::bench::compress;
    let rows = match compress::run(quick) {
        Ok(rows) => rows,
        Err(e) => {
            esay(&format!("hardbody: compression benchmark failed: {e}"));
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if json {
        print_json(&rows);
    } else {
        say("| table | shape | N | phi reached | sweeps | seconds | microseconds per particle |");
        say("|---|---|---|---|---|---|---|");
        for r in &rows {
            say(&format!(
                "| {} | {} | {} | {:.3} | {} | {:.2} | {:.1} |",
                r.table,
                r.shape,
                r.n,
                r.packing_fraction,
                r.sweeps,
                r.seconds,
                r.seconds_per_particle * 1e6
            ));
        }
    }
    match plot {
        Some(dir) => report_plots("compression", compress::plot(&rows, dir)),
        None => ExitCode::SUCCESS,
    }
}

fn bench_effects(quick: bool, json: bool, plot: Option<&std::path::Path>) -> ExitCode {
    let rows = match hardbody::bench::effects::run(quick) {
        Ok(rows) => rows,
        Err(e) => {
            esay(&format!("hardbody: effects benchmark failed: {e}"));
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if json {
        print_json(&rows);
    } else {
        say("| driver | effect | off | on | on / off | unit |");
        say("|---|---|---|---|---|---|");
        for r in &rows {
            say(&format!(
                "| {} | {} | {:.3} | {:.3} | {:.2} | {} |",
                r.driver, r.effect, r.off_us, r.on_us, r.ratio, r.unit
            ));
        }
    }
    match plot {
        Some(dir) => report_plots("effects", hardbody::bench::effects::plot(&rows, dir)),
        None => ExitCode::SUCCESS,
    }
}

/// Says which plots a suite wrote, or why it could not (then the run
/// fails: the user asked for them).
fn report_plots<E: std::fmt::Display>(
    suite: &str,
    written: Result<Vec<std::path::PathBuf>, E>,
) -> ExitCode {
    match written {
        Ok(paths) => {
            for p in paths {
                esay(&format!("plot written: {}", p.display()));
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            esay(&format!("hardbody: {suite} plots failed: {e}"));
            ExitCode::from(EXIT_FAILED)
        }
    }
}

fn bench_scene(quick: bool, json: bool) -> ExitCode {
    let rows = match hardbody::bench::scene::run(quick) {
        Ok(rows) => rows,
        Err(e) => {
            esay(&format!("hardbody: scene benchmark failed: {e}"));
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if json {
        print_json(&rows);
    } else {
        say("| path | shape | N | phi | collisions | us/collision (median) | ratio to direct |");
        say("|---|---|---|---|---|---|---|");
        for r in &rows {
            say(&format!(
                "| {} | {} | {} | {:.2} | {} | {:.3} | {:.3} |",
                r.algorithm,
                r.shape,
                r.n,
                r.packing_fraction,
                r.collisions,
                r.us_per_collision,
                r.ratio_to_direct
            ));
        }
    }
    ExitCode::SUCCESS
}

fn export(log: &std::path::Path, out: &std::path::Path) -> ExitCode {
    let contents = match read_log(log, true) {
        Ok(c) => c,
        Err(e) => return bad_input(e),
    };
    if let Err(e) = check_output(out, true, &[log]) {
        return bad_input(e);
    }
    if let (Some(d), true) = (&contents.damage, contents.states.is_empty()) {
        return bad_input(format!(
            "{}: {d}; no intact frame before it to export",
            log.display()
        ));
    }
    match hardbody::log::gsd::export(&contents.states, out) {
        Ok(frames) => match &contents.damage {
            // The intact frames are exported; the damage is an error.
            Some(d) => bad_input(format!(
                "{}: {d}; the {frames} frames before it were written to {}",
                log.display(),
                out.display()
            )),
            None => {
                say(&format!("{frames} frames written to {}", out.display()));
                ExitCode::SUCCESS
            }
        },
        Err(e) => bad_input(e),
    }
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

/// Plots of a suite's rows into a directory.
type Plotter = fn(
    &[hardbody::bench::edmd_speed::SpeedRow],
    &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, String>;

/// Prints the rows of a time-per-collision suite (and writes its plots).
fn bench_speed(
    name: &str,
    rows: Result<Vec<hardbody::bench::edmd_speed::SpeedRow>, String>,
    json: bool,
    plot: Option<&std::path::Path>,
    plotter: Option<Plotter>,
) -> ExitCode {
    let rows = match rows {
        Ok(rows) => rows,
        Err(e) => {
            esay(&format!("hardbody: {name} benchmark failed: {e}"));
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if json {
        print_json(&rows);
    } else {
        say(
            "| system | N | phi | neighbours | us/collision, median (range) | distances/collision | iterations/distance | target | published |",
        );
        say("|---|---|---|---|---|---|---|---|---|");
        for r in &rows {
            say(&format!(
                "| {} | {} | {} | {} | {:.2} ({:.2}-{:.2}) over {} x {} collisions | {:.1} | {:.2} | {} | {} |",
                r.system,
                r.n,
                r.packing_fraction,
                r.neighbours,
                r.median_us_per_collision,
                r.min_us_per_collision,
                r.max_us_per_collision,
                r.repeats,
                r.collisions_per_repeat,
                r.distances_per_collision,
                r.iterations_per_distance,
                if r.target_us_per_collision.is_finite() {
                    format!("<= {}", r.target_us_per_collision)
                } else {
                    "-".into()
                },
                if r.reference.is_empty() {
                    "-"
                } else {
                    &r.reference
                }
            ));
        }
    }
    match (plot, plotter) {
        (Some(dir), Some(plotter)) => report_plots(name, plotter(&rows, dir)),
        _ => ExitCode::SUCCESS,
    }
}

fn bench_edmd_tolerance(quick: bool, json: bool, plot: Option<&std::path::Path>) -> ExitCode {
    use hardbody::bench::edmd::{loosest_safe_grazing, tolerance};
    let rows = match tolerance(quick) {
        Ok(rows) => rows,
        Err(e) => {
            esay(&format!("hardbody: edmd-tolerance benchmark failed: {e}"));
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if let Some(dir) = plot {
        let code = report_plots("edmd-tolerance", hardbody::bench::edmd::plot(&rows, dir));
        if code != ExitCode::SUCCESS {
            return code;
        }
    }
    if json {
        print_json(&rows);
        return ExitCode::SUCCESS;
    }
    say(
        "| aspect | N | phi | eps_d | Newton tol | collisions | us/collision, median of 10 stretches (range) | energy drift/collision | max contact-time error (first 100) | follows reference for | missed |",
    );
    say("|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        say(&format!(
            "| {} | {} | {} | {:.0e} | {:.0e} | {} | {:.0} ({:.0}-{:.0}) | {:.1e} | {:.1e} | {} | {} |",
            r.aspect,
            r.n,
            r.packing_fraction,
            r.grazing_threshold,
            r.newton_tolerance,
            r.collisions,
            r.us_per_collision,
            r.us_per_collision_range.0,
            r.us_per_collision_range.1,
            r.energy_drift_per_collision,
            r.max_contact_time_error,
            if r.reference {
                "(reference)".to_string()
            } else {
                format!("{} collisions", r.departure_collisions)
            },
            r.missed.as_deref().unwrap_or("none")
        ));
    }
    for (aspect, eps) in loosest_safe_grazing(&rows) {
        say(&format!(
            "aspect {aspect}: loosest eps_d with no missed collision: {}",
            eps.map(|e| format!("{e:.0e}"))
                .unwrap_or_else(|| "none".into())
        ));
    }
    ExitCode::SUCCESS
}
