//! `bench SUITE`: runs a suite and prints its rows as a table or JSON,
//! its plots written where asked. Each suite's rows, table and plots are
//! its own (`src/bench/`); this file only chooses and prints.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use hardbody::bench::{compress, edmd, edmd_speed, effects, jam, mc, ocsi, scene, speed_plots};

use super::{EXIT_FAILED, Suite, bad_input, esay, print_block, print_json, say};

/// A suite's plots of its rows into a directory.
type Plotter<'a, R> =
    &'a dyn Fn(&[R], &Path) -> Result<Vec<PathBuf>, hardbody::bench::plot::PlotError>;

/// Runs `suite`: `--json` prints its rows, else its table; `--plot DIR`
/// writes its plots (refused for the suites that have none).
pub(super) fn bench(suite: Suite, quick: bool, json: bool, plot: Option<&Path>) -> ExitCode {
    if let Some(dir) = plot {
        if matches!(suite, Suite::Scene | Suite::Edmd) {
            return bad_input("--plot: this suite has no plots (scene and edmd are tables)");
        }
        if let Err(e) = std::fs::create_dir_all(dir) {
            return bad_input(format!("--plot {}: {e}", dir.display()));
        }
    }
    let out = Output { json, plot };
    match suite {
        Suite::Ocsi => bench_ocsi(quick, out),
        Suite::Mc => bench_mc(quick, out),
        Suite::Compress => out.report(
            "compression",
            compress::run(quick),
            compress::table,
            Some(&|rows, dir| compress::plot(rows, dir)),
        ),
        Suite::Scene => out.report("scene", scene::run(quick), scene::table, None),
        Suite::Jam => out.report(
            "jam",
            jam::run(quick, |row| {
                esay(&format!(
                    "{} at {:e} (fluid {:e}): phi_J {:.4}, z {:.3}, {:.1} s",
                    row.shape,
                    row.growth_rate,
                    row.fluid_rate,
                    row.packing_fraction,
                    row.backbone_contact_number,
                    row.seconds
                ))
            }),
            jam::table,
            Some(&|rows, dir| jam::plot(rows, dir)),
        ),
        Suite::JamRate => out.report(
            "jam-rate",
            jam::rates(quick),
            jam::table,
            Some(&|rows, dir| jam::plot(rows, dir)),
        ),
        Suite::Edmd => out.report("edmd", edmd_speed::speed(quick), edmd_speed::table, None),
        Suite::EdmdShell => out.report(
            "edmd-shell",
            edmd_speed::shell(quick),
            edmd_speed::table,
            Some(&speed_plots::plot_shell),
        ),
        Suite::EdmdDensity => out.report(
            "edmd-density",
            edmd_speed::density(quick),
            edmd_speed::table,
            Some(&speed_plots::plot_density),
        ),
        Suite::EdmdElongation => out.report(
            "edmd-elongation",
            edmd_speed::elongation(quick),
            edmd_speed::table,
            Some(&speed_plots::plot_elongation),
        ),
        Suite::Superellipsoid => out.report(
            "superellipsoid",
            edmd_speed::superellipsoid(quick),
            edmd_speed::table,
            Some(&speed_plots::plot_superellipsoid),
        ),
        Suite::EdmdTolerance => out.report(
            "edmd-tolerance",
            edmd::tolerance(quick),
            edmd::tolerance_table,
            Some(&|rows, dir| edmd::plot(rows, dir)),
        ),
        Suite::Effects => out.report(
            "effects",
            effects::run(quick),
            effects::table,
            Some(&|rows, dir| effects::plot(rows, dir)),
        ),
    }
}

/// How the rows are to be shown.
#[derive(Clone, Copy)]
struct Output<'a> {
    json: bool,
    plot: Option<&'a Path>,
}

impl Output<'_> {
    /// Prints the rows of suite `name` (or why it failed) and writes its
    /// plots.
    fn report<R: serde::Serialize, E: std::fmt::Display>(
        self,
        name: &str,
        rows: Result<Vec<R>, E>,
        table: fn(&[R]) -> String,
        plotter: Option<Plotter<R>>,
    ) -> ExitCode {
        let rows = match rows {
            Ok(rows) => rows,
            Err(e) => {
                esay(&format!("hardbody: {name} benchmark failed: {e}"));
                return ExitCode::from(EXIT_FAILED);
            }
        };
        if self.json {
            print_json(&rows);
        } else {
            print_block(&table(&rows));
        }
        match (self.plot, plotter) {
            (Some(dir), Some(plotter)) => report_plots(name, plotter(&rows, dir)),
            _ => ExitCode::SUCCESS,
        }
    }
}

fn bench_ocsi(quick: bool, out: Output) -> ExitCode {
    let cfg = if quick {
        ocsi::OcsiBenchConfig::quick()
    } else {
        ocsi::OcsiBenchConfig::paper()
    };
    let terminal = std::io::stderr().is_terminal();
    let points = cfg.lengths.len() * cfg.lengths.len() * cfg.radii.len();
    let mut done = 0;
    let result = ocsi::run(&cfg, |l, w, r| {
        done += 1;
        if terminal {
            eprint!("\rocsi: {done}/{points} (L*={l}, W*={w}, R*={r})      ");
        }
    });
    if terminal {
        esay("");
    }
    let (rows, points) = match result {
        Ok(found) => found,
        Err(e) => {
            esay(&format!("hardbody: OCSI benchmark failed: {e}"));
            return ExitCode::from(EXIT_FAILED);
        }
    };
    if !out.json {
        say(&format!(
            "OCSI benchmark: {} configurations x {} sets per cuboid, L*, W* in {:?}, non-overlap target {}",
            cfg.configurations, cfg.sets, cfg.lengths, cfg.non_overlap_ratio
        ));
    }
    let plotter = |_: &[ocsi::OcsiRow], dir: &Path| ocsi::plot(&points, dir);
    out.report("OCSI", Ok::<_, String>(rows), ocsi::table, Some(&plotter))
}

fn bench_mc(quick: bool, out: Output) -> ExitCode {
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
    if out.json {
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
        print_block(&mc::table(&moves, &density, &sizes));
    }
    match out.plot {
        Some(dir) => report_plots("MC", mc::plot(&density, &sizes, dir)),
        None => ExitCode::SUCCESS,
    }
}

/// Says which plots a suite wrote, or why it could not (then the run
/// fails: the user asked for them).
fn report_plots<E: std::fmt::Display>(suite: &str, written: Result<Vec<PathBuf>, E>) -> ExitCode {
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
