//! `hardbody bench jam`: jammed packings by event-driven growth
//! ([`crate::edmd::jam`]) on one thread, from the melted dilute lattice of
//! `bench compress`: per system the packing fraction reached, the backbone
//! contact number against the isostatic 2 d_f, the rattlers, the
//! collisions and the seconds. Spheres at several growth rates (slower
//! growth, denser and closer to isostatic), then the bodies of Donev's
//! and Jiao's packings at the default rate. Every end state is checked by
//! the exact pair distance: no overlap.

use std::time::Instant;

use rand::SeedableRng;
use rand_pcg::Pcg64;

use std::path::{Path, PathBuf};

use super::BenchError;
use super::compress::dilute_start;
use super::markdown_table;
use super::plot::{Figure, Series, line_plot};
use crate::edmd::DynamicsOptions;
use crate::edmd::jam::{DEFAULT_GROWTH_RATE, JamEnd, JamOptions, jam};
use crate::geometry::Shape;
use crate::log::file::OutputError;

/// One jamming run.
#[derive(Debug, Clone, serde::Serialize)]
pub struct JamRow {
    /// The shape, in the scene spelling.
    pub shape: String,
    /// Bodies.
    pub n: usize,
    /// γ.
    pub growth_rate: f64,
    /// The rate until βPV/N = 10³.
    pub fluid_rate: f64,
    /// φ at the end.
    pub packing_fraction: f64,
    /// βPV/N of the last chunk.
    pub pressure: f64,
    /// Mean contact number of the backbone (gaps below 10⁻⁹ of the
    /// smallest half-extent).
    pub backbone_contact_number: f64,
    /// Mean constraints per body of the backbone (a face on a face counts
    /// 3, an edge on a face 2: the contact number, for curved bodies),
    /// which is set against 2 d_f.
    pub backbone_constraint_number: f64,
    /// Mean contacts per body over all bodies, rattlers included.
    pub mean_contact_number: f64,
    /// 2 d_f.
    pub isostatic_contact_number: f64,
    /// Rattlers, per cent of the bodies.
    pub rattlers_percent: f64,
    /// Collisions.
    pub collisions: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// How it ended.
    pub end: String,
}

/// The rate the bodies are jammed at: 1000 spheroids 1.5:1 reach
/// φ_J ≈ 0.715 at it in about three minutes on one core.
pub const BODY_GROWTH_RATE: f64 = 1e-2;

/// Flat-faced bodies grow through the fluid at this rate, which keeps
/// them random (at one rate of 10⁻², 1000 cubes pack to φ = 0.773
/// against 0.692).
pub const FLAT_FLUID_RATE: f64 = 0.1;

/// The systems: spheres at three rates, then the bodies at
/// [`BODY_GROWTH_RATE`] (the flat-faced ones through the fluid at
/// [`FLAT_FLUID_RATE`]); `quick`, 64 spheres and 27 spheroids to
/// βPV/N = 10⁶ (for the tests). Each row is told to `done` as it
/// finishes (the whole suite takes an hour and more).
pub fn run(quick: bool, mut done: impl FnMut(&JamRow)) -> Result<Vec<JamRow>, BenchError> {
    let shape = |text: &str| -> Result<Shape, BenchError> { Ok(text.parse()?) };
    let sphere = shape("Sphere(radius: 0.5)")?;
    let cases: Vec<(Shape, usize, JamOptions)> = if quick {
        let ellipsoid = shape("Ellipsoid(a: 0.75, b: 0.5, c: 0.5)")?;
        vec![
            (sphere, 4, growing(1e-2, 1e6)),
            (ellipsoid, 3, growing(1e-2, 1e6)),
        ]
    } else {
        let mut cases: Vec<_> = [1e-2, 3e-3, DEFAULT_GROWTH_RATE]
            .into_iter()
            .map(|rate| (sphere, 10, growing(rate, 1e12)))
            .collect();
        for (text, fluid_rate) in [
            ("Ellipsoid(a: 0.75, b: 0.5, c: 0.5)", None),
            ("Ellipsoid(a: 0.625, b: 0.5, c: 0.4)", None),
            ("Ellipsoid(a: 1.0, b: 0.5, c: 0.5)", None),
            ("Ellipsoid(a: 0.5, b: 0.5, c: 0.25)", None),
            ("Cuboid(a: 0.5, b: 0.5, c: 0.5)", Some(FLAT_FLUID_RATE)),
            (
                "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
                Some(FLAT_FLUID_RATE),
            ),
        ] {
            let options = JamOptions {
                fluid_rate,
                ..growing(BODY_GROWTH_RATE, 1e12)
            };
            cases.push((shape(text)?, 10, options));
        }
        cases
    };
    cases
        .into_iter()
        .map(|(shape, side, options)| {
            let row = timed(shape, side, &options)?;
            done(&row);
            Ok(row)
        })
        .collect()
}

/// The stage's options growing at `growth_rate` (from start to end) until
/// βPV/N passes `pressure`.
fn growing(growth_rate: f64, pressure: f64) -> JamOptions {
    JamOptions {
        growth_rate,
        pressure,
        ..JamOptions::default()
    }
}

/// `hardbody bench jam-rate`: 1000 spheres jammed at four growth rates
/// (slower, denser); `quick`, 64 spheres at two rates to βPV/N = 10⁶.
/// Each at its one rate, without settling rounds: what the rate itself
/// leaves (a stage settles where the contacts do not certify the jam).
pub fn rates(quick: bool) -> Result<Vec<JamRow>, BenchError> {
    let sphere: Shape = "Sphere(radius: 0.5)".parse()?;
    let (side, rates, pressure): (usize, &[f64], f64) = if quick {
        (4, &[1e-2, 3e-3], 1e6)
    } else {
        (10, &[1e-2, 3e-3, 1e-3, 3e-4], 1e12)
    };
    rates
        .iter()
        .map(|&rate| {
            let options = JamOptions {
                settle_rounds: 0,
                ..growing(rate, pressure)
            };
            timed(sphere, side, &options)
        })
        .collect()
}

/// Jams `side`³ bodies of `shape` with `options` and times it.
fn timed(shape: Shape, side: usize, options: &JamOptions) -> Result<JamRow, BenchError> {
    let start = dilute_start(&[shape], side, 3)?;
    let mut rng = Pcg64::seed_from_u64(4);
    let clock = Instant::now();
    let out = jam(
        &start,
        options,
        &DynamicsOptions::default(),
        &mut rng,
        |_| true,
    )
    .map_err(|e| BenchError::Wrong {
        system: shape.to_string(),
        what: e.to_string(),
    })?;
    let seconds = clock.elapsed().as_secs_f64();
    let system = &out.system;
    let network = system.contact_network(1e-9);
    if network.overlaps > 0 {
        return Err(BenchError::Wrong {
            system: shape.to_string(),
            what: format!("{} overlapping pairs", network.overlaps),
        });
    }
    let last = out.last.ok_or_else(|| BenchError::Wrong {
        system: shape.to_string(),
        what: "no chunk finished".into(),
    })?;
    Ok(JamRow {
        shape: shape.to_string(),
        n: system.len(),
        growth_rate: options.growth_rate,
        fluid_rate: options.fluid_rate(),
        packing_fraction: system.packing_fraction(),
        pressure: last.pressure,
        backbone_contact_number: network.backbone_contact_number,
        backbone_constraint_number: network.backbone_constraint_number,
        mean_contact_number: network.mean_contact_number,
        isostatic_contact_number: network.isostatic_contact_number,
        rattlers_percent: 100.0 * network.rattlers.len() as f64 / system.len() as f64,
        collisions: last.collisions,
        seconds,
        end: match out.end {
            JamEnd::Jammed => "jammed".into(),
            other => format!("{other:?} ({})", out.last_failure.unwrap_or_default()),
        },
    })
}

/// `--plot`: the jammed packing fraction and the backbone's contact
/// number against the growth rate, a series per shape (slower growth:
/// denser, and closer to isostatic).
pub fn plot(rows: &[JamRow], dir: &Path) -> Result<Vec<PathBuf>, super::plot::PlotError> {
    std::fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, &e))?;
    let series = |value: &dyn Fn(&JamRow) -> f64| {
        let mut out: Vec<Series> = Vec::new();
        for r in rows {
            let point = (r.growth_rate, value(r));
            match out.iter_mut().find(|s| s.name == r.shape) {
                Some(s) => s.points.push(point),
                None => out.push(Series {
                    name: r.shape.clone(),
                    points: vec![point],
                }),
            }
        }
        for s in &mut out {
            s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        out
    };
    let mut written = Vec::new();
    for (file, title, y_label, value) in [
        (
            "jam-packing-fraction.svg",
            "Jammed packing fraction against the growth rate",
            "packing fraction at the jam",
            &(|r: &JamRow| r.packing_fraction) as &dyn Fn(&JamRow) -> f64,
        ),
        (
            "jam-contact-number.svg",
            "Backbone contact number against the growth rate (isostatic: 6 spheres, 10 spheroids, 12 others)",
            "mean contact number z of the backbone",
            &(|r: &JamRow| r.backbone_contact_number) as &dyn Fn(&JamRow) -> f64,
        ),
    ] {
        let path = dir.join(file);
        line_plot(
            &path,
            &Figure {
                title,
                x_label: "growth rate (per unit time)",
                y_label,
                log_x: true,
                log_y: false,
            },
            &series(value),
        )?;
        written.push(path);
    }
    Ok(written)
}

/// The rows as a Markdown table.
pub fn table(rows: &[JamRow]) -> String {
    let columns = [
        "shape",
        "N",
        "growth rate",
        "fluid rate",
        "phi_J",
        "betaPV/N",
        "z backbone",
        "constraints",
        "z all",
        "2 d_f",
        "rattlers %",
        "collisions",
        "seconds",
        "end",
    ];
    markdown_table(
        &columns,
        rows.iter().map(|r| {
            vec![
                r.shape.clone(),
                r.n.to_string(),
                format!("{:e}", r.growth_rate),
                format!("{:e}", r.fluid_rate),
                format!("{:.4}", r.packing_fraction),
                format!("{:.2e}", r.pressure),
                format!("{:.3}", r.backbone_contact_number),
                format!("{:.3}", r.backbone_constraint_number),
                format!("{:.3}", r.mean_contact_number),
                format!("{}", r.isostatic_contact_number),
                format!("{:.1}", r.rattlers_percent),
                r.collisions.to_string(),
                format!("{:.1}", r.seconds),
                r.end.clone(),
            ]
        }),
    )
}
