//! `free-energy`: a scene run, then the free energy of its final state
//! (a crystal's by Frenkel–Ladd, a fluid's from its equation of state)
//! printed as text or JSON, and its path plotted.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use hardbody::bench::plot::{Figure, PlotError, Series, line_plot};
use hardbody::free_energy::{
    CrystalFreeEnergy, FluidFreeEnergy, FreeEnergy, PathChoices, scene_free_energy,
};
use hardbody::log::file::check_output;

use super::*;

pub(super) fn free_energy(
    scene_path: &Path,
    out: Option<PathBuf>,
    flags: PathChoices,
    json: bool,
    plot: Option<&Path>,
) -> ExitCode {
    let (scene, text) = match load_scene(scene_path) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    if let Err(e) = preflight(scene_path, &text, &scene, out.is_some()) {
        return bad_input(e);
    }
    let log_path = out.unwrap_or_else(|| PathBuf::from(&scene.log.path));
    if let Err(e) = check_output(&log_path, true, &[scene_path]) {
        return bad_input(e);
    }
    let crystal = matches!(scene.start, hardbody::scene::Start::Crystal { .. });
    if flags.spring.is_some() && !crystal {
        return bad_input(
            "--spring: springs tether a crystal, and this scene does not start from one \
             (its free energy is a fluid's, from its equation of state)",
        );
    }
    let solid = flags.frenkel_ladd(scene.seed);
    let fluid = flags.equation_of_state(scene.seed);
    handle_ctrl_c();
    esay(&format!(
        "hardbody {}: running {} ({} particles, {} stages), log {}, then {}",
        env!("CARGO_PKG_VERSION"),
        scene_path.display(),
        scene.particle_count(),
        scene.stages.len(),
        log_path.display(),
        match crystal {
            true => "its Frenkel–Ladd path",
            false => "its equation of state from the ideal gas",
        }
    ));
    let mut progress = progress_display();
    let result = scene_free_energy(
        &scene,
        &text,
        &log_path,
        &solid,
        &fluid,
        progress.as_mut(),
        &STOP,
    );
    let result = match result.map_err(refused) {
        Ok(r) => r,
        Err(code) => return code,
    };
    let plotted = match (plot, &result) {
        (Some(dir), FreeEnergy::FrenkelLadd(r)) => plot_path(dir, r),
        (Some(dir), FreeEnergy::EquationOfState(r)) => plot_eos(dir, r),
        (None, _) => Ok(()),
    };
    if let Err(e) = plotted {
        return not_written(e);
    }
    if json {
        print_json(&result);
    } else {
        print_block(&match &result {
            FreeEnergy::FrenkelLadd(r) => crystal_report(r),
            FreeEnergy::EquationOfState(r) => fluid_report(r),
        });
    }
    ExitCode::SUCCESS
}

/// The exit of a free energy that failed: bad input (2) or a failed
/// computation (1), the message on standard error.
pub(super) fn refused(e: hardbody::free_energy::FreeEnergyError) -> ExitCode {
    if e.is_bad_input() {
        return bad_input(e);
    }
    esay(&format!("hardbody: {e}"));
    ExitCode::from(EXIT_FAILED)
}

/// A fluid's result as text: the free energy, the state's pressure and
/// chemical potential, the equation of state point by point.
fn fluid_report(r: &FluidFreeEnergy) -> String {
    let mut text = format!(
        "βF/N = {:.5} ± {:.5}  (fluid; Λ = 1 length unit; N = {}, φ = {:.5}, ρ = {:.5})\n\
         excess over the ideal gas, ∫₀^ρ (Z − 1)/ρ′ dρ′ = {:.5}\n\
         βP = {:.5} ± {:.5}, βμ = βF/N + βP/ρ = {:.5} ± {:.5}\n\
         equation of state at {} Gauss–Legendre densities:\n     φ          βP        ±        Z       Q₆\n",
        r.free_energy_per_particle,
        r.error,
        r.n,
        r.packing_fraction,
        r.number_density,
        r.excess_free_energy_per_particle,
        r.pressure.0,
        r.pressure.1,
        r.chemical_potential.0,
        r.chemical_potential.1,
        r.path.len(),
    );
    for p in &r.path {
        text += &format!(
            "{:9.5} {:11.5} {:9.5} {:9.5} {:7.3}\n",
            p.packing_fraction,
            p.pressure.mean,
            p.pressure.error,
            p.pressure.mean / p.density,
            p.q6
        );
    }
    text
}

/// The fluid's βP/ρ against φ, with its error band, as SVG.
fn plot_eos(dir: &Path, r: &FluidFreeEnergy) -> Result<(), PlotError> {
    let points: Vec<_> = (r.path.iter())
        .map(|p| {
            let z = p.pressure.mean / p.density;
            (p.packing_fraction, z, p.pressure.error / p.density)
        })
        .collect();
    band_plot(
        &dir.join("equation_of_state.svg"),
        &Figure {
            title: "equation of state integrated from the ideal gas",
            x_label: "packing fraction φ",
            y_label: "Z = βP/ρ",
            log_x: false,
            log_y: false,
        },
        "Z",
        &points,
    )
}

/// (x, y, error) points as a line with lines one standard error above
/// and below, as SVG at `path` (its folder made).
fn band_plot(
    path: &Path,
    figure: &Figure,
    name: &str,
    points: &[(f64, f64, f64)],
) -> Result<(), PlotError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let band = |sign: f64| -> Vec<(f64, f64)> {
        points.iter().map(|&(x, y, e)| (x, y + sign * e)).collect()
    };
    let series = [
        (name, 0.0),
        ("+ standard error", 1.0),
        ("− standard error", -1.0),
    ];
    let series: Vec<Series> = (series.iter())
        .map(|&(name, sign)| Series {
            name: name.into(),
            points: band(sign),
        })
        .collect();
    line_plot(path, figure, &series)
}

/// A crystal's result as text: the free energy, its terms, the path.
fn crystal_report(r: &CrystalFreeEnergy) -> String {
    let mut text = format!(
        "βF/N = {:.5} ± {:.5}  (Λ = 1 length unit; N = {}, φ = {:.5}, ρ = {:.5})\n\
         excess over the ideal gas, βF/N − (ln ρ − 1) = {:.5}\n\
         terms per body: −ln(V/N_c) with N_c = {} lattice translations; Einstein crystal \
         {:.5} at βλ_max = {:.1} (its orientations {:.5}, κ = {:.5}); overlaps {:.6} \
         (P₀ = {:.4}); integral {:.5} ± {:.5}\n\
         path over ln(βλ + c), c = {:.2}:\n         βλ   (λ+c)⟨Σ|u−ū|²⟩/N     ±     settled  accepted\n",
        r.free_energy_per_particle,
        r.error,
        r.n,
        r.packing_fraction,
        r.number_density,
        r.excess_free_energy_per_particle,
        r.lattice_translations,
        r.einstein,
        r.spring_max,
        r.einstein_orientations,
        r.twist,
        r.overlap_term.0,
        r.overlap_free,
        r.integral_term.0,
        r.integral_term.1,
        r.spring_shift,
    );
    for p in &r.path {
        text += &format!(
            "{:12.3} {:14.5} {:10.5} {:>8} {:9.2}\n",
            p.spring,
            p.integrand,
            p.integrand_error,
            if p.spread.equilibrated { "yes" } else { "no" },
            p.acceptance
        );
    }
    text
}

/// The integrand against ln(βλ + c), with its error band, as SVG.
fn plot_path(dir: &Path, r: &CrystalFreeEnergy) -> Result<(), PlotError> {
    let points: Vec<_> = (r.path.iter())
        .map(|p| {
            (
                (p.spring + r.spring_shift).ln(),
                p.integrand,
                p.integrand_error,
            )
        })
        .collect();
    band_plot(
        &dir.join("frenkel_ladd_path.svg"),
        &Figure {
            title: "Frenkel–Ladd path",
            x_label: "ln(βλ + c)  (λ in 1/length²)",
            y_label: "(βλ + c) ⟨Σ|u − ū|²⟩ / N",
            log_x: false,
            log_y: false,
        },
        "integrand",
        &points,
    )
}
