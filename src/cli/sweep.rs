//! `sweep` and `sweep collect`: a parameter sweep written as a signac
//! workspace with a row workflow, and its results gathered.

use std::path::Path;
use std::process::ExitCode;

use hardbody::bench::plot::PlotError;
use hardbody::log::file::OutputError;
use hardbody::sweep::collect::{StatePointRow, collect};
use hardbody::sweep::{jobs, parse_sets, write_workspace};

use super::*;

pub(super) fn sweep(template: &Path, sets: &[String], replicas: u64, dir: &Path) -> ExitCode {
    let (scene, text) = match load_scene(template) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let swept = match parse_sets(&scene, sets) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let jobs = match jobs(&scene, &swept, replicas) {
        Ok(j) => j,
        Err(e) => return bad_input(e),
    };
    let exe = std::env::current_exe()
        .and_then(|p| p.canonicalize())
        .unwrap_or_else(|_| "hardbody".into());
    match write_workspace(dir, &text, &swept, &jobs, &exe) {
        Ok(w) => {
            let names: Vec<String> = swept
                .iter()
                .map(|s| format!("{} ({})", s.name, s.key))
                .collect();
            say(&format!(
                "{}: {} jobs ({} new, {} already there): {} state points x {} replicas; swept: {}",
                dir.display(),
                jobs.len(),
                w.made,
                w.kept,
                jobs.len() as u64 / replicas,
                replicas,
                if names.is_empty() {
                    "nothing".to_string()
                } else {
                    names.join(", ")
                }
            ));
            say(&format!(
                "run them: cd {} && row submit --cluster=none   (or on a cluster: row submit)",
                dir.display()
            ));
            say(&format!(
                "then:     hardbody sweep collect {}",
                dir.display()
            ));
            ExitCode::SUCCESS
        }
        Err(e) => not_written(e),
    }
}

pub(super) fn sweep_collect(
    dir: &Path,
    stage: Option<usize>,
    json: bool,
    plot: Option<&Path>,
) -> ExitCode {
    let (rows, strays) = match collect(dir, stage) {
        Ok(c) => (c.rows, c.strays),
        Err(e) => return bad_input(e),
    };
    for (folder, why) in strays {
        esay(&format!(
            "hardbody: warning: {}: not a job of this sweep ({why}); left out",
            folder.display()
        ));
    }
    if let Some(plot_dir) = plot
        && let Err(e) = eos_plot(plot_dir, &rows)
    {
        return match e {
            PlotError::Draw(why) => bad_input(format!("--plot {}: {why}", plot_dir.display())),
            e => not_written(e),
        };
    }
    if json {
        print_json(&rows);
        return ExitCode::SUCCESS;
    }
    print_block(&table(&rows));
    let unfinished: usize = rows
        .iter()
        .map(|r| r.partial + r.failed + r.not_started)
        .sum();
    if unfinished > 0 {
        esay(&format!(
            "hardbody: {unfinished} jobs have not finished: submitting again resumes the partial ones"
        ));
    }
    let foreign: usize = rows.iter().map(|r| r.foreign).sum();
    if foreign > 0 {
        esay(&format!(
            "hardbody: warning: {foreign} jobs hold a log of another scene than their own (a regenerated state point, or a copied log): not averaged; move those logs away and submit again"
        ));
    }
    if rows.iter().any(|r| r.finished > 0 && !r.equilibrated) {
        esay(
            "hardbody: warning: the measured stage never equilibrated in some job: its averages are not equilibrium values",
        );
    }
    ExitCode::SUCCESS
}

/// The rows as a text table: the swept values, the jobs, then per
/// observable its mean +- error.
fn table(rows: &[StatePointRow]) -> String {
    let Some(first) = rows.first() else {
        return "no jobs\n".into();
    };
    let names: Vec<&String> = first.parameters.keys().collect();
    let observables: Vec<&String> = {
        let mut all: Vec<&String> = rows.iter().flat_map(|r| r.observables.keys()).collect();
        all.sort();
        all.dedup();
        all
    };
    let mut header: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    header.push("done/partial/failed/new".into());
    header.push("equilibrated".into());
    header.extend(observables.iter().map(|o| o.to_string()));
    let with_cs = rows.iter().any(|r| r.carnahan_starling.is_some());
    if with_cs {
        header.push("phi Carnahan-Starling".into());
    }
    let mut lines = vec![header];
    for row in rows {
        let mut line: Vec<String> = names
            .iter()
            .map(|n| {
                row.parameters
                    .get(*n)
                    .map(|v| v.to_string())
                    .unwrap_or_default()
            })
            .collect();
        line.push(format!(
            "{}/{}/{}/{}",
            row.finished, row.partial, row.failed, row.not_started
        ));
        line.push(match (row.finished, row.equilibrated) {
            (0, _) => "-".into(),
            (_, true) => "yes".into(),
            (_, false) => "NO".into(),
        });
        for o in &observables {
            line.push(match row.observables.get(*o) {
                Some(a) => format!("{:.6} +- {:.6}", a.mean, a.error),
                None => "-".into(),
            });
        }
        if with_cs {
            line.push(
                row.carnahan_starling
                    .map(|p| format!("{p:.6}"))
                    .unwrap_or_else(|| "-".into()),
            );
        }
        lines.push(line);
    }
    let widths: Vec<usize> = (0..lines[0].len())
        .map(|c| lines.iter().map(|l| l[c].len()).max().unwrap_or(0))
        .collect();
    let mut out = format!("stage {} of every job:\n", first.stage_index);
    for line in lines {
        let cells: Vec<String> = line
            .iter()
            .zip(&widths)
            .map(|(cell, w)| format!("{cell:>w$}"))
            .collect();
        out.push_str(&cells.join("  "));
        out.push('\n');
    }
    out
}

/// The equation of state of a sweep that varies a pressure: the imposed
/// βP against the measured packing fraction, with its error, and
/// Carnahan–Starling where the system is hard spheres.
fn eos_plot(dir: &Path, rows: &[StatePointRow]) -> Result<(), PlotError> {
    use hardbody::bench::plot::{ErrorPoint, eos_plot as draw};
    let pressure_key = rows
        .first()
        .and_then(|r| {
            r.parameters
                .keys()
                .find(|k| k.ends_with("pressure"))
                .cloned()
        })
        .ok_or_else(|| {
            PlotError::Draw("the sweep varies no pressure: no equation of state to draw".into())
        })?;
    let points: Vec<ErrorPoint> = rows
        .iter()
        .filter_map(|r| {
            let p = r.parameters.get(&pressure_key)?.as_f64()?;
            let phi = r.observables.get("packing_fraction")?;
            Some(ErrorPoint {
                x: phi.mean,
                x_error: phi.error,
                y: p,
            })
        })
        .collect();
    if points.is_empty() {
        return Err(PlotError::Draw("no finished job to draw".into()));
    }
    let reference: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            Some((
                r.carnahan_starling?,
                r.parameters.get(&pressure_key)?.as_f64()?,
            ))
        })
        .collect();
    std::fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, &e))?;
    let path = dir.join("equation-of-state.svg");
    draw(&path, &points, &reference)?;
    esay(&format!("plot written: {}", path.display()));
    Ok(())
}
