//! SVG line plots of benchmark results (plotters): one or more named
//! series of (x, y) points, axes labelled with units, log scales where the
//! quantity spans decades.

use std::path::Path;

use plotters::prelude::*;

use crate::log::StorageFailure;
use crate::log::file::OutputError;

/// Why a plot was not written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The plot could not be drawn (with the file it was for).
    #[error("{0}")]
    Draw(String),
    /// The file could not be written (a link or an input in the way, a
    /// full or read-only file system).
    #[error(transparent)]
    Output(#[from] OutputError),
}

impl StorageFailure for PlotError {
    fn is_storage_failure(&self) -> bool {
        matches!(self, PlotError::Output(e) if e.is_storage_failure())
    }
}

impl From<String> for PlotError {
    fn from(message: String) -> Self {
        PlotError::Draw(message)
    }
}

/// A named series of points.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// (x, y) points, in order of x.
    pub points: Vec<(f64, f64)>,
}

/// How a plot is laid out.
pub struct Figure<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// x-axis label, with units.
    pub x_label: &'a str,
    /// y-axis label, with units.
    pub y_label: &'a str,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
}

/// Ten distinct colours (the "tab10" palette).
const COLOURS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Tick values for a log axis over [lo, hi]: 1, 2 and 5 times the powers
/// of ten inside it (every integer multiple when it spans under a decade),
/// so that a short log axis still carries several labels.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let multiples: &[f64] = if hi / lo < 10.0 {
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    } else {
        &[1.0, 2.0, 5.0]
    };
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        for m in multiples {
            let v = m * decade;
            if v >= lo && v <= hi {
                ticks.push(v);
            }
        }
        decade *= 10.0;
    }
    ticks
}

/// A tick label: plain for 1e-3 ≤ |v| < 1e5 (no trailing zeros), else
/// scientific.
fn tick_label(v: &f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The range of the values, widened a little (by a factor on log axes).
fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else {
        let pad = 0.05 * (hi - lo).max(hi.abs() * 1e-3).max(1e-12);
        (lo - pad, hi + pad)
    }
}

/// Writes `series` as an SVG line plot with points to `path`.
pub fn line_plot(path: &Path, figure: &Figure, series: &[Series]) -> Result<(), PlotError> {
    let mut svg = String::new();
    draw_lines(&mut svg, path, figure, series)?;
    write_svg(path, &svg)
}

/// Writes `svg` to `path` through a temporary file renamed into place,
/// never through a symbolic link.
fn write_svg(path: &Path, svg: &str) -> Result<(), PlotError> {
    Ok(crate::log::file::write_replacing(path, svg.as_bytes())?)
}

fn draw_lines(
    svg: &mut String,
    path: &Path,
    figure: &Figure,
    series: &[Series],
) -> Result<(), PlotError> {
    let (x0, x1) = range(
        series.iter().flat_map(|s| s.points.iter().map(|p| p.0)),
        figure.log_x,
    );
    let (y0, y1) = range(
        series.iter().flat_map(|s| s.points.iter().map(|p| p.1)),
        figure.log_y,
    );
    let root = SVGBackend::with_string(svg, (800, 520)).into_drawing_area();
    let fail = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(figure.title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70);
    // The four axis kinds are four chart types; one body serves them.
    macro_rules! draw {
        ($x:expr, $y:expr) => {{
            let mut chart = builder.build_cartesian_2d($x, $y).map_err(|e| fail(&e))?;
            chart
                .configure_mesh()
                .x_desc(figure.x_label)
                .y_desc(figure.y_label)
                .x_label_formatter(&tick_label)
                .y_label_formatter(&tick_label)
                .draw()
                .map_err(|e| fail(&e))?;
            for (k, s) in series.iter().enumerate() {
                let colour = COLOURS[k % COLOURS.len()];
                chart
                    .draw_series(LineSeries::new(
                        s.points.iter().copied(),
                        colour.stroke_width(2),
                    ))
                    .map_err(|e| fail(&e))?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
                chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(|e| fail(&e))?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(|e| fail(&e))?;
        }};
    }
    let log_x = || (x0..x1).log_scale().with_key_points(log_ticks(x0, x1));
    let log_y = || (y0..y1).log_scale().with_key_points(log_ticks(y0, y1));
    match (figure.log_x, figure.log_y) {
        (false, false) => draw!(x0..x1, y0..y1),
        (true, false) => draw!(log_x(), y0..y1),
        (false, true) => draw!(x0..x1, log_y()),
        (true, true) => draw!(log_x(), log_y()),
    }
    Ok(root.present().map_err(|e| fail(&e))?)
}

/// Writes a horizontal bar chart: one bar per label, of the given value,
/// with a reference line at `reference` (e.g. a ratio of 1).
pub fn bar_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    bars: &[(String, f64)],
    reference: f64,
) -> Result<(), PlotError> {
    let mut svg = String::new();
    draw_bars(&mut svg, path, title, x_label, bars, reference)?;
    write_svg(path, &svg)
}

fn draw_bars(
    svg: &mut String,
    path: &Path,
    title: &str,
    x_label: &str,
    bars: &[(String, f64)],
    reference: f64,
) -> Result<(), PlotError> {
    let fail = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let top = bars.iter().map(|b| b.1).fold(reference, f64::max) * 1.15;
    let height = 120 + 40 * bars.len() as u32;
    let root = SVGBackend::with_string(svg, (900, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let n = bars.len() as f64;
    // Bar i spans y in [i + 0.15, i + 0.85]; its label sits at i + 0.5.
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(380)
        .build_cartesian_2d(0.0..top, 0.0..n)
        .map_err(|e| fail(&e))?;
    // Ticks every half unit; the names go on the bar centres only.
    let label = |y: &f64| {
        if (y.fract() - 0.5).abs() < 1e-6 {
            bars.get(y.floor() as usize)
                .map(|b| b.0.clone())
                .unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc(x_label)
        .x_label_formatter(&tick_label)
        .y_labels(2 * bars.len() + 1)
        .y_label_formatter(&label)
        .draw()
        .map_err(|e| fail(&e))?;
    chart
        .draw_series(bars.iter().enumerate().map(|(i, b)| {
            let y = i as f64;
            Rectangle::new([(0.0, y + 0.15), (b.1, y + 0.85)], COLOURS[0].filled())
        }))
        .map_err(|e| fail(&e))?;
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![(reference, 0.0), (reference, n)],
            BLACK.stroke_width(2),
        )))
        .map_err(|e| fail(&e))?;
    Ok(root.present().map_err(|e| fail(&e))?)
}

/// A measured point with an error in x.
pub struct ErrorPoint {
    /// The measured value (a packing fraction).
    pub x: f64,
    /// Its standard error.
    pub x_error: f64,
    /// The imposed value (a pressure).
    pub y: f64,
}

/// An equation of state as SVG: measured packing fractions with error
/// bars against the imposed βP, and a reference curve through
/// `reference` (Carnahan–Starling's packing fraction at each pressure)
/// where given.
pub fn eos_plot(
    path: &Path,
    points: &[ErrorPoint],
    reference: &[(f64, f64)],
) -> Result<(), PlotError> {
    let mut svg = String::new();
    draw_eos(&mut svg, path, points, reference)?;
    write_svg(path, &svg)
}

fn draw_eos(
    svg: &mut String,
    path: &Path,
    points: &[ErrorPoint],
    reference: &[(f64, f64)],
) -> Result<(), PlotError> {
    let (x0, x1) = range(
        points
            .iter()
            .flat_map(|p| [p.x - p.x_error, p.x + p.x_error])
            .chain(reference.iter().map(|r| r.0)),
        false,
    );
    let (y0, y1) = range(
        points
            .iter()
            .map(|p| p.y)
            .chain(reference.iter().map(|r| r.1)),
        false,
    );
    let root = SVGBackend::with_string(svg, (800, 520)).into_drawing_area();
    let fail = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption("equation of state", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| fail(&e))?;
    chart
        .configure_mesh()
        .x_desc("packing fraction")
        .y_desc("βP (1/length³)")
        .draw()
        .map_err(|e| fail(&e))?;
    if !reference.is_empty() {
        let mut curve = reference.to_vec();
        curve.sort_by(|a, b| a.1.total_cmp(&b.1));
        let grey = COLOURS[7];
        chart
            .draw_series(LineSeries::new(curve, grey.stroke_width(2)))
            .map_err(|e| fail(&e))?
            .label("Carnahan–Starling")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
    }
    let blue = COLOURS[0];
    chart
        .draw_series(points.iter().map(|p| {
            ErrorBar::new_horizontal(p.y, p.x - p.x_error, p.x, p.x + p.x_error, blue.filled(), 8)
        }))
        .map_err(|e| fail(&e))?;
    chart
        .draw_series(
            points
                .iter()
                .map(|p| Circle::new((p.x, p.y), 4, blue.filled())),
        )
        .map_err(|e| fail(&e))?
        .label("measured (mean ± error over replicas)")
        .legend(move |(x, y)| Circle::new((x + 10, y), 4, blue.filled()));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| fail(&e))?;
    Ok(root.present().map_err(|e| fail(&e))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_log_axes_get_several_ticks() {
        assert_eq!(log_ticks(150.0, 1700.0), vec![200.0, 500.0, 1000.0]);
        assert_eq!(
            log_ticks(150.0, 900.0),
            vec![200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0, 900.0]
        );
        assert_eq!(
            log_ticks(0.01, 1.0),
            vec![0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
        );
        assert_eq!(tick_label(&1000.0), "1000");
        assert_eq!(tick_label(&0.25), "0.25");
        assert_eq!(tick_label(&1e-9), "1e-9");
    }

    #[test]
    fn writes_a_labelled_bar_chart() {
        let dir = std::env::temp_dir().join(format!("hardbody-bars-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("b.svg");
        let bars = [("rotation".to_string(), 3.2), ("walls".to_string(), 1.0)];
        bar_plot(&path, "cost of effects", "on / off", &bars, 1.0).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        for text in ["cost of effects", "on / off", "rotation", "walls"] {
            assert!(svg.contains(text), "{text} missing");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A plot is written, with the title, labels and legend in it.
    #[test]
    fn writes_a_labelled_svg() {
        let dir = std::env::temp_dir().join(format!("hardbody-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.svg");
        let series = [
            Series {
                name: "cells".into(),
                points: vec![(0.3, 10.0), (0.4, 20.0), (0.5, 80.0)],
            },
            Series {
                name: "lists".into(),
                points: vec![(0.3, 8.0), (0.4, 15.0), (0.5, 50.0)],
            },
        ];
        let figure = Figure {
            title: "time per collision",
            x_label: "packing fraction",
            y_label: "time per collision (us)",
            log_x: false,
            log_y: true,
        };
        line_plot(&path, &figure, &series).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        for text in [
            "time per collision",
            "packing fraction",
            "cells",
            "lists",
            "<svg",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
