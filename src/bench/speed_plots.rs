//! The plots of the time-per-collision suites: time against the shell,
//! φ, the aspect ratio and the superellipsoid exponent.

use super::edmd_speed::SpeedRow;

/// Plots of the shell suite: time per collision against Δ (one line per
/// system, cells as Δ = 0 left out), and the best Δ against φ for spheres.
pub fn plot_shell(
    rows: &[SpeedRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let mut keys: Vec<(String, f64)> = Vec::new();
    for r in rows {
        if !keys
            .iter()
            .any(|k| k.0 == r.system && k.1 == r.packing_fraction)
        {
            keys.push((r.system.clone(), r.packing_fraction));
        }
    }
    let series: Vec<Series> = keys
        .iter()
        .map(|(system, phi)| Series {
            name: format!("{system}, phi {phi}"),
            points: rows
                .iter()
                .filter(|r| &r.system == system && r.packing_fraction == *phi)
                .filter_map(|r| r.shell.map(|s| (s, r.median_us_per_collision)))
                .collect(),
        })
        .collect();
    let time = dir.join("edmd-shell-time.svg");
    line_plot(
        &time,
        &Figure {
            title: "Time per collision against the neighbour shell (one core, medians)",
            x_label: "neighbour shell Delta (length units; sphere diameter 1)",
            y_label: "time per collision (us)",
            log_x: true,
            log_y: true,
        },
        &series,
    )?;
    let best: Vec<(f64, f64)> = keys
        .iter()
        .filter(|(system, _)| system == "hard spheres")
        .filter_map(|(system, phi)| {
            rows.iter()
                .filter(|r| &r.system == system && r.packing_fraction == *phi && r.shell.is_some())
                .min_by(|a, b| {
                    a.median_us_per_collision
                        .total_cmp(&b.median_us_per_collision)
                })
                .and_then(|r| r.shell.map(|s| (*phi, s)))
        })
        .collect();
    let optimum = dir.join("edmd-shell-optimum.svg");
    line_plot(
        &optimum,
        &Figure {
            title: "Fastest neighbour shell against packing fraction, hard spheres",
            x_label: "packing fraction phi",
            y_label: "fastest shell Delta* (sphere diameters)",
            log_x: false,
            log_y: false,
        },
        &[Series {
            name: "hard spheres".into(),
            points: best,
        }],
    )?;
    Ok(vec![time, optimum])
}

/// Plot of the density suite: time per collision against φ, one line per
/// shape and neighbour structure.
pub fn plot_density(
    rows: &[SpeedRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let mut keys: Vec<(String, bool)> = Vec::new();
    for r in rows {
        let key = (r.system.clone(), r.shell.is_some());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let series: Vec<Series> = keys
        .iter()
        .map(|(system, lists)| Series {
            name: format!(
                "{system}, {}",
                if *lists { "neighbour lists" } else { "cells" }
            ),
            points: rows
                .iter()
                .filter(|r| &r.system == system && r.shell.is_some() == *lists)
                .map(|r| (r.packing_fraction, r.median_us_per_collision))
                .collect(),
        })
        .collect();
    let path = dir.join("edmd-density.svg");
    line_plot(
        &path,
        &Figure {
            title: "Time per collision against packing fraction, ellipsoids N = 256 (one core, medians)",
            x_label: "packing fraction phi",
            y_label: "time per collision (us)",
            log_x: false,
            log_y: true,
        },
        &series,
    )?;
    Ok(vec![path])
}

/// Plots of the elongation suite: time per collision against the aspect
/// ratio (cells and lists per φ), and the ratio cells/lists.
pub fn plot_elongation(
    rows: &[SpeedRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let mut phis: Vec<f64> = Vec::new();
    for r in rows {
        if !phis.contains(&r.packing_fraction) {
            phis.push(r.packing_fraction);
        }
    }
    let points = |phi: f64, lists: bool| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.packing_fraction == phi && r.shell.is_some() == lists)
            .filter_map(|r| r.aspect.map(|x| (x, r.median_us_per_collision)))
            .collect()
    };
    let mut series = Vec::new();
    for &phi in &phis {
        for lists in [false, true] {
            series.push(Series {
                name: format!(
                    "phi {phi}, {}",
                    if lists { "oriented-box lists" } else { "cells" }
                ),
                points: points(phi, lists),
            });
        }
    }
    let time = dir.join("edmd-elongation-time.svg");
    line_plot(
        &time,
        &Figure {
            title: "Time per collision against aspect ratio, ellipsoids of revolution (one core, medians)",
            x_label: "aspect ratio X = a/b",
            y_label: "time per collision (us)",
            log_x: true,
            log_y: true,
        },
        &series,
    )?;
    let ratios: Vec<Series> = phis
        .iter()
        .map(|&phi| Series {
            name: format!("phi {phi}"),
            points: points(phi, false)
                .iter()
                .zip(points(phi, true))
                .map(|(&(x, cells), (_, lists))| (x, cells / lists))
                .collect(),
        })
        .collect();
    let ratio = dir.join("edmd-elongation-ratio.svg");
    line_plot(
        &ratio,
        &Figure {
            title: "Cells over oriented-box lists, time per collision",
            x_label: "aspect ratio X = a/b",
            y_label: "time with cells / time with lists",
            log_x: true,
            log_y: false,
        },
        &ratios,
    )?;
    Ok(vec![time, ratio])
}

/// Plots of the superellipsoid suite: time per collision, and solver
/// iterations per distance evaluation, against the exponent p.
pub fn plot_superellipsoid(
    rows: &[SpeedRow],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let mut keys: Vec<(f64, bool)> = Vec::new();
    for r in rows {
        let key = (r.aspect.unwrap_or(f64::NAN), r.shell.is_some());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let series = |value: fn(&SpeedRow) -> f64| -> Vec<Series> {
        keys.iter()
            .map(|&(x0, lists)| Series {
                name: format!(
                    "X0 = {x0}, {}",
                    if lists { "oriented-box lists" } else { "cells" }
                ),
                points: rows
                    .iter()
                    .filter(|r| r.aspect == Some(x0) && r.shell.is_some() == lists)
                    .filter_map(|r| r.exponent.map(|p| (p, value(r))))
                    .collect(),
            })
            .collect()
    };
    let time = dir.join("superellipsoid-time.svg");
    line_plot(
        &time,
        &Figure {
            title: "Time per collision against the exponent p, superellipsoids at phi = 0.256 (one core, medians)",
            x_label: "exponent p of |z/c|^p",
            y_label: "time per collision (us)",
            log_x: false,
            log_y: true,
        },
        &series(|r| r.median_us_per_collision),
    )?;
    let iterations = dir.join("superellipsoid-iterations.svg");
    line_plot(
        &iterations,
        &Figure {
            title: "Solver iterations per distance evaluation against the exponent p",
            x_label: "exponent p of |z/c|^p",
            y_label: "Newton iterations per distance evaluation",
            log_x: false,
            log_y: false,
        },
        &series(|r| r.iterations_per_distance),
    )?;
    Ok(vec![time, iterations])
}
