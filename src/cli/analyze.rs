//! The commands that read logs: `analyze`, `inspect`, `export`; and
//! `virial`.

use std::path::PathBuf;
use std::process::ExitCode;

use hardbody::analysis::virial::excluded_volume;
use hardbody::bench::plot::PlotError;
use hardbody::geometry::Shape;
use hardbody::log::averages::is_equilibrium_stage;
use hardbody::log::file::{OutputError, check_output};
use hardbody::log::read::read_log;
use hardbody::number::Num;

use super::*;

/// A log's contents for `analyze`: refused with exit 2 if unreadable;
/// damage is said and what precedes it analysed.
pub(super) fn log_to_analyze(
    path: &std::path::Path,
) -> Result<hardbody::log::read::LogContents, ExitCode> {
    let contents = read_log(path, false).map_err(bad_input)?;
    if let Some(d) = &contents.damage {
        esay(&format!(
            "hardbody: {}: {d}; analysing the /stats before it",
            path.display()
        ));
    } else if contents.truncated {
        esay(&format!(
            "hardbody: {}: the log ends before its footer (a killed run, or one still running): analysing the /stats it holds",
            path.display()
        ));
    }
    Ok(contents)
}

pub(super) fn analyze(
    path: &std::path::Path,
    json: bool,
    plot: Option<&std::path::Path>,
) -> ExitCode {
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
            return not_written(OutputError::io(dir, &e));
        }
        for stage in &stages {
            if let Err(e) = plot_stage(dir, &stats, stage, &[path]) {
                return not_written(e);
            }
        }
    }
    if json {
        print_json(&serde_json::json!({
            "log": path.display().to_string(),
            "truncated": contents.truncated,
            "damage": contents.damage.as_ref().map(|d| d.to_string()),
            "stages": stages,
        }));
    } else {
        say(&format!("{}:", path.display()));
        for stage in &stages {
            let unit = if matches!(stage.stage.as_str(), "dynamics" | "jam") {
                "t"
            } else {
                "sweep"
            };
            let [from, to] = stage.span.map(Num);
            let span = if unit == "t" {
                format!("{from:.4}-{to:.4}")
            } else {
                format!("{from}-{to}")
            };
            let verdict = if stage.stage == "compress" {
                "compression (not an equilibrium stage: no averages)".to_string()
            } else if stage.stage == "jam" {
                "growth to a jam (not an equilibrium stage: no averages)".to_string()
            } else if stage.equilibrated {
                "equilibrated".to_string()
            } else {
                format!(
                    "NOT EQUILIBRATED ({}): run it longer",
                    stage.not_equilibrated.join(", ")
                )
            };
            say(&format!(
                "stage {} ({}), {} stats messages, {unit} {span}: {verdict}",
                stage.stage_index, stage.stage, stage.samples,
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
                    format!("{} (constant)", Num(e.mean))
                } else {
                    format!("{:.6} +- {:.6}", Num(e.mean), Num(e.error))
                };
                say(&format!(
                    "  {:<22} {:>26} {:>16} {:>8.2} {:>8.1}{}",
                    name,
                    value,
                    Num(o.equilibrated_from),
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
        .filter(|s| is_equilibrium_stage(&s.stage) && !s.equilibrated)
        .map(|s| s.stage_index.to_string())
        .collect();
    if !never.is_empty() {
        esay(&format!(
            "hardbody: warning: stage {} never equilibrated: its averages are not equilibrium values",
            never.join(", ")
        ));
    }
    // What precedes the damage is printed; the exit says it was not all
    // (a sweep's analyze action must not count the job done).
    if contents.damage.is_some() {
        return ExitCode::from(EXIT_BAD_INPUT);
    }
    ExitCode::SUCCESS
}

/// Averages over replicas: each log analysed as `analyze` does, then
/// every stage's observables averaged over the logs, with an error that
/// is the larger of the runs' errors combined and their spread.
pub(super) fn analyze_replicas(
    paths: &[PathBuf],
    json: bool,
    plot: Option<&std::path::Path>,
) -> ExitCode {
    use hardbody::log::averages::replica_averages;
    let mut contents = Vec::with_capacity(paths.len());
    for path in paths {
        match log_to_analyze(path) {
            Ok(c) => contents.push((path.display().to_string(), c)),
            Err(code) => return code,
        }
    }
    let logs: Vec<(String, &hardbody::log::read::LogContents)> =
        contents.iter().map(|(name, c)| (name.clone(), c)).collect();
    let replicas = match replica_averages(&logs) {
        Ok(r) => r,
        Err(e) => return bad_input(e),
    };
    if let Some(dir) = plot {
        let inputs: Vec<&std::path::Path> = paths.iter().map(PathBuf::as_path).collect();
        for (k, ((_, c), stages)) in contents.iter().zip(&replicas.runs).enumerate() {
            let stats: Vec<_> = c.stats.iter().map(|(_, s)| s.clone()).collect();
            let dir = dir.join(format!("replica{}", k + 1));
            if let Err(e) = std::fs::create_dir_all(&dir) {
                return not_written(OutputError::io(&dir, &e));
            }
            for stage in stages {
                if let Err(e) = plot_stage(&dir, &stats, stage, &inputs) {
                    return not_written(e);
                }
            }
        }
    }
    let combined = replicas.combined;
    if json {
        print_json(&serde_json::json!({
            "logs": paths.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "stages": combined,
        }));
    } else {
        say(&format!("{} replicas:", paths.len()));
        for stage in &combined {
            if !is_equilibrium_stage(&stage.stage) {
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
                    format!("{:.6} +- {:.6}", Num(a.mean), Num(a.error)),
                    Num(a.spread)
                ));
            }
        }
    }
    if combined
        .iter()
        .any(|s| is_equilibrium_stage(&s.stage) && !s.equilibrated)
    {
        esay(
            "hardbody: warning: a stage never equilibrated in some replica: its averages are not equilibrium values",
        );
    }
    ExitCode::SUCCESS
}

/// One SVG per observable of `stage`: the series, the mean of its
/// equilibrated part, and where that part begins.
pub(super) fn plot_stage(
    dir: &std::path::Path,
    stats: &[hardbody::log::Stats],
    stage: &hardbody::log::averages::StageAverages,
    inputs: &[&std::path::Path],
) -> Result<(), PlotError> {
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
                name: format!(
                    "mean {:.5} +- {:.5}",
                    Num(o.estimate.mean),
                    Num(o.estimate.error)
                ),
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
        check_output(&path, false, inputs)?;
        line_plot(&path, &figure, &series)?;
    }
    Ok(())
}

pub(super) fn inspect(path: &std::path::Path) -> ExitCode {
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
            (_, Some(t)) => format!("t = {}", Num(t)),
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

pub(super) fn virial(a: &str, b: &str, samples: u64, seed: u64, json: bool) -> ExitCode {
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
            Num(e.excluded_volume),
            Num(e.excluded_volume_error)
        ));
        say(&format!(
            "B2:              {:.6} ± {:.6}",
            e.b2,
            e.excluded_volume_error / 2.0
        ));
        say(&format!("samples:         {}", e.samples));
        if let Some(strains) = e.overlap_strains.in_words() {
            say(&format!("overlap tests:   {strains}"));
        }
    }
    ExitCode::SUCCESS
}

pub(super) fn export(log: &std::path::Path, out: &std::path::Path) -> ExitCode {
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
    match hardbody::log::gsd::export(&contents, out) {
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
        Err(e) => not_written(e),
    }
}

/// `analyze --packing`: the contact network of one frame of the log.
pub(super) fn analyze_packing(
    path: &std::path::Path,
    frame: Option<usize>,
    gap: Option<f64>,
    json: bool,
    plot: Option<&std::path::Path>,
) -> ExitCode {
    use hardbody::analysis::contact_gap::GapSource;
    use hardbody::log::packing::PackingReport;
    if let Some(gap) = gap
        && !(gap.is_finite() && gap >= 0.0)
    {
        return bad_input(format!("--gap must be a finite number >= 0, got {gap}"));
    }
    let contents = match read_log(path, true) {
        Ok(c) => c,
        Err(e) => return bad_input(e),
    };
    let frames = contents.states.len();
    if let Some(d) = &contents.damage {
        esay(&format!(
            "hardbody: {}: {d}; nothing after it is read: its {frames} intact frames are those before it",
            path.display()
        ));
    }
    let index = frame.unwrap_or(frames.saturating_sub(1));
    let Some(report) = PackingReport::of_log_frame(&contents, index, gap) else {
        return bad_input(format!(
            "{}: --frame {index}: the log holds {frames} frames",
            path.display()
        ));
    };
    let report = match report {
        Ok(r) => r,
        Err(e) => return bad_input(format!("{}: frame {index}: {e}", path.display())),
    };
    let state = &contents.states[index].1;
    let PackingReport {
        gap: choice,
        network,
        rdf,
        structure_factor,
        steinhardt_cutoff: cutoff,
        steinhardt: bond_order,
        nematic,
        cubatic,
    } = &report;
    let (k, s_k) = (&structure_factor.k, &structure_factor.s);
    // The last bin's centre plus half a bin (the first bin's centre).
    let r_max = rdf.r.last().zip(rdf.r.first()).map_or(0.0, |(l, f)| l + f);
    if let Some(dir) = plot
        && let Err(e) = packing_plots(
            dir,
            rdf,
            (k, s_k),
            &network.contact_number_histogram,
            &choice.curve,
            path,
        )
    {
        return not_written(e);
    }
    if json {
        let mut value = serde_json::to_value(&report).expect("a report serialises");
        value["frame"] = index.into();
        value["truncated"] = contents.truncated.into();
        value["damage"] = contents.damage.as_ref().map(|d| d.to_string()).into();
        print_json(&value);
        return ExitCode::SUCCESS;
    }
    let at = match (state.sweep, state.time) {
        (Some(s), _) => format!("sweep {s}"),
        (_, Some(t)) => format!("t = {}", Num(t)),
        _ => "its start".into(),
    };
    say(&format!(
        "{}: frame {index} of {frames} (stage {}, {at}), {} bodies, packing fraction {:.6}",
        path.display(),
        state.stage_index,
        network.bodies,
        Num(network.packing_fraction)
    ));
    let gap = choice.gap;
    say(&match (choice.source, choice.flattest) {
        (GapSource::Given, _) => format!("contact gap: {gap:e} (given by --gap)"),
        (GapSource::Plateau, Some(r)) => format!(
            "contact gap: {gap:.1e}, read from the packing: on the plateau of the contact count from gaps {:.1e} to {:.1e} ({} pairs below, {} more across it)",
            r.from, r.to, r.contacts, r.added
        ),
        _ => format!("contact gap: {gap:e} (no plateau: see the warning)"),
    });
    if let Some(z) = choice.reduced_pressure {
        say(&format!(
            "reduced pressure of the frame: betaPV/N = {z:.3e} (contacts expected near gaps of 1/Z)"
        ));
    }
    say(&format!(
        "contacts: {} (gaps under {gap:.1e} of the smaller body's smallest half-extent){}",
        network.contacts.len(),
        if network.overlaps > 0 {
            format!("; {} pairs OVERLAP by more than that", network.overlaps)
        } else {
            String::new()
        }
    ));
    say(&format!(
        "rattlers: {} ({:.1} %), removed while their contacts could not block their translations",
        network.rattlers.len(),
        100.0 * network.rattlers.len() as f64 / network.bodies.max(1) as f64
    ));
    say(&format!(
        "all bodies: mean contact number {:.4}, mean constraints per body {:.4}",
        network.mean_contact_number, network.mean_constraint_number
    ));
    if network.backbone_contact_number.is_nan() {
        say(
            "backbone: none (every body is a rattler at this gap: the contacts hold no body in place; is --gap below the packing's gaps, or is the packing not jammed?)",
        );
    } else {
        say(&format!(
            "backbone: mean contact number z = {:.4}, isostatic 2 d_f = {:.4}{}",
            network.backbone_contact_number,
            network.isostatic_contact_number,
            if choice.warning.is_some() {
                " (no certificate: see the warning)"
            } else {
                ""
            }
        ));
        if network.backbone_constraint_number != network.backbone_contact_number {
            say(&format!(
                "backbone: mean constraints per body {:.4} (a face on a face counts 3, an edge on a face 2), against 2 d_f",
                network.backbone_constraint_number
            ));
        }
    }
    let histogram: Vec<String> = network
        .contact_number_histogram
        .iter()
        .enumerate()
        .filter(|(_, n)| **n > 0)
        .map(|(z, n)| format!("{z}: {n}"))
        .collect();
    say(&format!(
        "contact numbers (bodies): {}",
        histogram.join(", ")
    ));
    let (peak, height) =
        rdf.r.iter().zip(&rdf.g).fold(
            (f64::NAN, 0.0),
            |best, (&r, &g)| if g > best.1 { (r, g) } else { best },
        );
    let (peak, r_max, cutoff) = (Num(peak), Num(r_max), Num(*cutoff));
    say(&format!(
        "g(r): highest at r = {peak:.3} (g = {height:.2}), 100 bins to r = {r_max:.3} (--json for the curve)"
    ));
    let (k_peak, s_peak) =
        k.iter()
            .zip(s_k.iter())
            .fold((f64::NAN, f64::NEG_INFINITY), |best, (&k, &s)| {
                if s > best.1 { (k, s) } else { best }
            });
    let k_peak = Num(k_peak);
    say(&format!(
        "S(k): highest at k = {k_peak:.3} (S = {s_peak:.2}), from g(r)"
    ));
    for q in bond_order {
        say(&format!(
            "Q{}: mean {:.4}, locally averaged {:.4}, global {:.4} (neighbours within {cutoff:.3})",
            q.l, q.mean, q.mean_local_average, q.global
        ));
    }
    match nematic {
        Some(n) => say(&format!(
            "nematic order S2 = {:.4}, director ({:.4}, {:.4}, {:.4})",
            n.order, n.director[0], n.director[1], n.director[2]
        )),
        None => say("nematic order: none (no body has a molecular axis)"),
    }
    if let Some(order) = cubatic {
        say(&format!(
            "cubatic order of the cuboids: {order:.4} (1 aligned up to the cube's symmetries, 1/N random)"
        ));
    }
    if let Some(warning) = &choice.warning {
        esay(&format!("hardbody: warning: {warning}"));
    }
    ExitCode::SUCCESS
}

/// g(r), S(k), the contact-number histogram and the contact count
/// against the gap of `analyze --packing --plot DIR`.
fn packing_plots(
    dir: &std::path::Path,
    rdf: &hardbody::analysis::structure::Rdf,
    (k, s): (&[f64], &[f64]),
    histogram: &[usize],
    curve: &[(f64, usize)],
    input: &std::path::Path,
) -> Result<(), PlotError> {
    use hardbody::bench::plot::{Figure, Series, bar_plot, line_plot};
    std::fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, &e))?;
    let rdf_path = dir.join("rdf.svg");
    let sk_path = dir.join("structure-factor.svg");
    let histogram_path = dir.join("contact-numbers.svg");
    let curve_path = dir.join("contacts-against-gap.svg");
    for p in [&rdf_path, &sk_path, &histogram_path, &curve_path] {
        check_output(p, false, &[input])?;
    }
    let figure = |title, x_label, y_label| Figure {
        title,
        x_label,
        y_label,
        log_x: false,
        log_y: false,
    };
    let series = |name: &str, x: &[f64], y: &[f64]| Series {
        name: name.into(),
        points: x.iter().copied().zip(y.iter().copied()).collect(),
    };
    line_plot(
        &rdf_path,
        &figure("radial distribution of the centres", "r", "g(r)"),
        &[series("g(r)", &rdf.r, &rdf.g)],
    )?;
    line_plot(
        &sk_path,
        &figure("structure factor from g(r)", "k", "S(k)"),
        &[series("S(k)", k, s)],
    )?;
    let bars: Vec<(String, f64)> = histogram
        .iter()
        .enumerate()
        .map(|(z, &n)| (z.to_string(), n as f64))
        .collect();
    bar_plot(
        &histogram_path,
        "bodies by contact number",
        "contacts",
        &bars,
        0.0,
    )?;
    line_plot(
        &curve_path,
        &Figure {
            log_x: true,
            ..figure(
                "pairs closer than the gap (a plateau: the contacts)",
                "gap (of the smaller body's smallest half-extent)",
                "pairs",
            )
        },
        &[Series {
            name: "pairs".into(),
            points: curve.iter().map(|&(g, n)| (g, n as f64)).collect(),
        }],
    )?;
    for p in [rdf_path, sk_path, histogram_path, curve_path] {
        esay(&format!("plot written: {}", p.display()));
    }
    Ok(())
}
