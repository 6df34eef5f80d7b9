//! `coexistence`: a fluid and a crystal scene, the crossing of their
//! chemical potentials printed and plotted; run here, or written as a
//! signac/row study (`--workspace`) whose parts run apart (`--job`) and
//! are crossed (`--collect`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use hardbody::bench::plot::{Figure, PlotError, Series, line_plot};
use hardbody::free_energy::{Coexistence, PartResult, PathChoices, PhaseScene, scene_coexistence};
use hardbody::scene::ValidScene;
use hardbody::sweep::coexistence::{CoexistenceStudy, collect_parts, run_job, write_study};

use super::*;

/// The fluid's and the crystal's scenes, loaded and checked, with their
/// texts.
fn load_phases(
    fluid_path: &Path,
    solid_path: &Path,
) -> Result<[(ValidScene, String); 2], ExitCode> {
    let mut loaded = Vec::new();
    for path in [fluid_path, solid_path] {
        let (scene, text) = load_scene(path).map_err(bad_input)?;
        preflight(path, &text, &scene, false).map_err(bad_input)?;
        loaded.push((scene, text));
    }
    let phases = <[(ValidScene, String); 2]>::try_from(loaded).expect("two scenes");
    hardbody::free_energy::check_phases(&phases[0].0, &phases[1].0).map_err(bad_input)?;
    Ok(phases)
}

/// `coexistence --fluid F --solid S`: both scenes run, their free
/// energies and branches found, the coexisting pressure and densities
/// printed and the chemical potentials plotted.
pub(super) fn coexistence(
    fluid_path: &Path,
    solid_path: &Path,
    flags: PathChoices,
    json: bool,
    plot: Option<&Path>,
) -> ExitCode {
    let [(fluid, fluid_text), (solid, solid_text)] = match load_phases(fluid_path, solid_path) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let (fluid_log, solid_log) = (
        PathBuf::from(&fluid.log.path),
        PathBuf::from(&solid.log.path),
    );
    if fluid_log == solid_log {
        return bad_input(format!(
            "--fluid and --solid both log to {}: give their scenes different log.path",
            fluid_log.display()
        ));
    }
    let (eos, springs, branches) = flags.coexistence(fluid.seed);
    handle_ctrl_c();
    esay(&format!(
        "hardbody {}: coexistence of {} ({} bodies) and {} ({} bodies): both scenes run, logs {} \
         and {}, then the fluid's equation of state, the crystal's Frenkel–Ladd path and both \
         branches",
        env!("CARGO_PKG_VERSION"),
        fluid_path.display(),
        fluid.particle_count(),
        solid_path.display(),
        solid.particle_count(),
        fluid_log.display(),
        solid_log.display()
    ));
    let mut progress = progress_display();
    let result = scene_coexistence(
        PhaseScene {
            scene: &fluid,
            text: &fluid_text,
            log: &fluid_log,
        },
        PhaseScene {
            scene: &solid,
            text: &solid_text,
            log: &solid_log,
        },
        (&eos, &springs, &branches),
        progress.as_mut(),
        &STOP,
    );
    match result.map_err(refused) {
        Ok(r) => report(&r, json, plot),
        Err(code) => code,
    }
}

/// The result printed (text or JSON) and plotted.
fn report(result: &Coexistence, json: bool, plot: Option<&Path>) -> ExitCode {
    if let Some(dir) = plot
        && let Err(e) = plot_chemical_potentials(dir, result)
    {
        return not_written(e);
    }
    if json {
        print_json(result);
    } else {
        print_block(&coexistence_report(result));
    }
    ExitCode::SUCCESS
}

/// `coexistence --fluid F --solid S --workspace DIR`: the study written,
/// a job per part, nothing run.
pub(super) fn coexistence_workspace(
    fluid_path: &Path,
    solid_path: &Path,
    flags: PathChoices,
    dir: &Path,
) -> ExitCode {
    let [(_, fluid), (_, solid)] = match load_phases(fluid_path, solid_path) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let study = CoexistenceStudy {
        fluid,
        solid,
        choices: flags,
        version: env!("CARGO_PKG_VERSION").into(),
    };
    let exe = std::env::current_exe()
        .and_then(|p| p.canonicalize())
        .unwrap_or_else(|_| "hardbody".into());
    match write_study(dir, &study, &exe) {
        Ok(w) => {
            say(&format!(
                "{}: {} parts ({} new, {} already there): each phase's free energy and each \
                 point of its branch, one job each",
                dir.display(),
                w.made + w.kept,
                w.made,
                w.kept
            ));
            say(&format!(
                "run them: cd {} && row submit --cluster=none   (or on a cluster: row submit)",
                dir.display()
            ));
            say(&format!(
                "then:     hardbody coexistence --collect {}",
                dir.display()
            ));
            ExitCode::SUCCESS
        }
        Err(e) => not_written(e),
    }
}

/// `coexistence --job FOLDER`: one part run, its result in the folder's
/// `part.json`.
pub(super) fn coexistence_job(job: &Path) -> ExitCode {
    handle_ctrl_c();
    let mut progress = progress_display();
    match run_job(job, progress.as_mut(), &STOP) {
        Ok((part, result)) => {
            let found = match result {
                PartResult::Anchor { free_energy, .. } => {
                    format!("βF/N = {:.5} ± {:.5}", free_energy.0, free_energy.1)
                }
                PartResult::Point(p) => format!(
                    "βP = {:.5} ± {:.5} at φ = {:.5}",
                    p.pressure.0, p.pressure.1, p.packing_fraction
                ),
            };
            esay(&format!(
                "hardbody: {part}: {found}; written to {}",
                job.join(hardbody::sweep::coexistence::PART_FILE).display()
            ));
            ExitCode::SUCCESS
        }
        Err(e) if e.is_bad_input() => bad_input(e),
        Err(e) => {
            esay(&format!("hardbody: {e}"));
            ExitCode::from(EXIT_FAILED)
        }
    }
}

/// `coexistence --collect DIR`: the parts crossed, printed and plotted
/// as the local command does.
pub(super) fn coexistence_collect(dir: &Path, json: bool, plot: Option<&Path>) -> ExitCode {
    let parts = match collect_parts(dir) {
        Ok(p) => p,
        Err(e) => return bad_input(e),
    };
    match parts.crossed().map_err(refused) {
        Ok(r) => report(&r, json, plot),
        Err(code) => code,
    }
}

/// Coexistence as text: the crossing, then each branch.
fn coexistence_report(c: &Coexistence) -> String {
    let mut text = format!(
        "coexistence: βP = {:.4} ± {:.4}, βμ = {:.4} ± {:.4}\n\
         fluid φ = {:.4} ± {:.4}, crystal φ = {:.4} ± {:.4}\n",
        c.pressure,
        c.pressure_error,
        c.chemical_potential.0,
        c.chemical_potential.1,
        c.fluid_packing_fraction,
        c.fluid_packing_fraction_error,
        c.solid_packing_fraction,
        c.solid_packing_fraction_error,
    );
    for (name, b) in [("fluid", &c.fluid), ("crystal", &c.solid)] {
        text += &format!(
            "{name}: βF/N = {:.5} ± {:.5} at ρ = {:.5}; βP fitted by a quadratic in ρ (χ² {:.2} \
             for {} points)\n     φ          βP        ±      Q₆\n",
            b.anchor_free_energy.0,
            b.anchor_free_energy.1,
            b.anchor_density,
            b.chi_squared,
            b.points.len()
        );
        for p in &b.points {
            text += &format!(
                "{:9.5} {:11.5} {:9.5} {:7.3}\n",
                p.packing_fraction, p.pressure.0, p.pressure.1, p.q6
            );
        }
    }
    text
}

/// βμ of both branches against βP, as SVG.
fn plot_chemical_potentials(dir: &Path, c: &Coexistence) -> Result<(), PlotError> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let branch = |pick: fn(&(f64, f64, f64)) -> f64| -> Vec<(f64, f64)> {
        (c.chemical_potentials.iter())
            .map(|t| (t.0, pick(t)))
            .filter(|p| p.1.is_finite())
            .collect()
    };
    line_plot(
        &dir.join("chemical_potentials.svg"),
        &Figure {
            title: "chemical potentials: coexistence where they cross",
            x_label: "βP (1/length³)",
            y_label: "βμ",
            log_x: false,
            log_y: false,
        },
        &[
            Series {
                name: "fluid".into(),
                points: branch(|t| t.1),
            },
            Series {
                name: "crystal".into(),
                points: branch(|t| t.2),
            },
        ],
    )
}
