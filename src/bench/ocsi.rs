//! The OCSI benchmark, after Tonti & Patti Sec. 3: cuboids of thickness 1
//! with L*, W* in [1, 20], spheres of radius R* ∈ {0.05, 0.5, 5}, sphere
//! centres uniform in the spherocuboid (cuboid ⊕ ball) sized so that 40% of
//! the configurations do not overlap, the frame randomly rotated for every
//! configuration; each algorithm times the same configurations.

use std::hint::black_box;
use std::time::Instant;

use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

use crate::analysis::virial::random_rotation;
use crate::geometry::ocsi::{Spheres, arvo, ocsi, ocsi_batch, point_box_distance, qrf, qri, sse};

/// Parameters of a run.
#[derive(Debug, Clone)]
pub struct OcsiBenchConfig {
    /// Values of L* and of W* (the grid is their product).
    pub lengths: Vec<f64>,
    /// Sphere radii R*.
    pub radii: Vec<f64>,
    /// Configurations per set (the paper: 2×10⁶).
    pub configurations: usize,
    /// Independent sets per cuboid (the paper: 3).
    pub sets: usize,
    /// Fraction of configurations without overlap (the paper: 0.4).
    pub non_overlap_ratio: f64,
    /// Seed of the configuration generator.
    pub seed: u64,
}

impl OcsiBenchConfig {
    /// The paper's protocol on a 5 × 5 grid of L*, W* spanning [1, 20].
    pub fn paper() -> Self {
        Self {
            lengths: vec![1.0, 5.75, 10.5, 15.25, 20.0],
            radii: vec![0.05, 0.5, 5.0],
            configurations: 2_000_000,
            sets: 3,
            non_overlap_ratio: 0.4,
            seed: 2021,
        }
    }

    /// A smoke run for CI: 2 × 2 grid, 2×10⁵ configurations, one set.
    pub fn quick() -> Self {
        Self {
            lengths: vec![1.0, 20.0],
            configurations: 200_000,
            sets: 1,
            ..Self::paper()
        }
    }
}

/// The algorithms compared, in table order. `ocsi_batch` streams the
/// configurations from memory, as the scalar tests do; `ocsi_batch_in_cache`
/// times each block of 1024 spheres on a second pass, once it is in cache
/// (the situation of a cuboid and its neighbour list in a simulation).
pub const ALGORITHMS: [&str; 7] = [
    "ocsi_batch_in_cache",
    "ocsi_batch",
    "ocsi",
    "sse",
    "qrf",
    "qri",
    "arvo",
];

/// One row of the result: an algorithm at one radius, averaged over the grid.
#[derive(Debug, Clone, serde::Serialize)]
pub struct OcsiRow {
    /// Algorithm name.
    pub algorithm: &'static str,
    /// Sphere radius R*.
    pub radius: f64,
    /// Median over grid points and sets of the time per test.
    pub ns_per_test: f64,
    /// The same, as milliseconds per 2×10⁶ tests (the paper's unit).
    pub ms_per_2e6_tests: f64,
    /// Fraction of configurations without overlap (target 0.4).
    pub non_overlap_ratio: f64,
    /// Threads used (the timing loop is serial).
    pub threads: usize,
}

/// One algorithm at one cuboid and radius: the median over the sets.
#[derive(Debug, Clone, serde::Serialize)]
pub struct OcsiPoint {
    /// Algorithm name.
    pub algorithm: &'static str,
    /// Sphere radius R*.
    pub radius: f64,
    /// Cuboid length L* (thickness 1).
    pub length: f64,
    /// Cuboid width W*.
    pub width: f64,
    /// Median over the sets of the time per test.
    pub ns_per_test: f64,
}

/// Volume of the cuboid (full edges `e`) dilated by a ball of radius `r`.
fn spherocuboid_volume(e: &Vector3<f64>, r: f64) -> f64 {
    use std::f64::consts::PI;
    e.product()
        + 2.0 * r * (e.x * e.y + e.y * e.z + e.x * e.z)
        + PI * r * r * e.sum()
        + 4.0 / 3.0 * PI * r.powi(3)
}

/// The dilation radius of the sampling spherocuboid for which a fraction
/// `ratio` of uniform points lie outside cuboid ⊕ ball(R), by bisection.
pub fn sampling_radius(edges: &Vector3<f64>, radius: f64, ratio: f64) -> f64 {
    let target = spherocuboid_volume(edges, radius) / (1.0 - ratio);
    let (mut lo, mut hi) = (radius, radius + edges.max() + 10.0 * radius + 1.0);
    while spherocuboid_volume(edges, hi) < target {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if spherocuboid_volume(edges, mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// One set of configurations for one cuboid and radius: per configuration
/// the sphere centre relative to the cuboid and the cuboid axes, both in a
/// randomly rotated frame; plus the same centres in one common rotated frame
/// for the batched kernel.
struct Set {
    r_sc: Vec<Vector3<f64>>,
    axes: Vec<Matrix3<f64>>,
    batch_axes: Matrix3<f64>,
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    radii: Vec<f64>,
}

fn generate(half: &Vector3<f64>, radius: f64, cfg: &OcsiBenchConfig, seed: u64) -> Set {
    let dilation = sampling_radius(&(half * 2.0), radius, cfg.non_overlap_ratio);
    let reach = half.add_scalar(dilation);
    let per_chunk = 1 << 14;
    let chunks = cfg.configurations.div_ceil(per_chunk);
    type Piece = (Vec<Vector3<f64>>, Vec<Matrix3<f64>>, Vec<Vector3<f64>>);
    let pieces: Vec<Piece> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut rng =
                Pcg64::seed_from_u64(seed ^ (c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            let n = per_chunk.min(cfg.configurations - c * per_chunk);
            let (mut rs, mut ax, mut local) = (
                Vec::with_capacity(n),
                Vec::with_capacity(n),
                Vec::with_capacity(n),
            );
            while rs.len() < n {
                let p = Vector3::new(
                    reach.x * (2.0 * rng.r#gen::<f64>() - 1.0),
                    reach.y * (2.0 * rng.r#gen::<f64>() - 1.0),
                    reach.z * (2.0 * rng.r#gen::<f64>() - 1.0),
                );
                if point_box_distance(&p, half).0 > dilation {
                    continue;
                }
                let rot = random_rotation(&mut rng).to_rotation_matrix().into_inner();
                rs.push(rot * p);
                ax.push(rot);
                local.push(p);
            }
            (rs, ax, local)
        })
        .collect();
    let mut rng = Pcg64::seed_from_u64(seed ^ 0xB47C);
    let batch_axes = random_rotation(&mut rng).to_rotation_matrix().into_inner();
    let mut set = Set {
        r_sc: Vec::with_capacity(cfg.configurations),
        axes: Vec::with_capacity(cfg.configurations),
        batch_axes,
        xs: Vec::with_capacity(cfg.configurations),
        ys: Vec::with_capacity(cfg.configurations),
        zs: Vec::with_capacity(cfg.configurations),
        radii: vec![radius; cfg.configurations],
    };
    for (rs, ax, local) in pieces {
        set.r_sc.extend(rs);
        set.axes.extend(ax);
        for p in local {
            let q = batch_axes * p;
            set.xs.push(q.x);
            set.ys.push(q.y);
            set.zs.push(q.z);
        }
    }
    set
}

type Scalar = fn(&Vector3<f64>, f64, &Matrix3<f64>, &Vector3<f64>) -> bool;

/// Times one scalar algorithm over the set: (seconds, overlaps found).
fn time_scalar(f: Scalar, set: &Set, radius: f64, half: &Vector3<f64>) -> (f64, usize) {
    let start = Instant::now();
    let mut hits = 0usize;
    for (r, ax) in set.r_sc.iter().zip(&set.axes) {
        hits += f(black_box(r), radius, ax, half) as usize;
    }
    (start.elapsed().as_secs_f64(), black_box(hits))
}

/// Times the batch on blocks of 1024 spheres already in cache (each block
/// tested once untimed, then timed).
fn time_batch_in_cache(set: &Set, half: &Vector3<f64>, out: &mut [bool]) -> (f64, usize) {
    const BLOCK: usize = 1024;
    let mut elapsed = 0.0;
    let mut hits = 0;
    for start in (0..set.xs.len()).step_by(BLOCK) {
        let end = (start + BLOCK).min(set.xs.len());
        let spheres = Spheres {
            x: &set.xs[start..end],
            y: &set.ys[start..end],
            z: &set.zs[start..end],
            radius: &set.radii[start..end],
        };
        let block = &mut out[start..end];
        ocsi_batch(&Vector3::zeros(), &set.batch_axes, half, &spheres, block);
        let t = Instant::now();
        ocsi_batch(
            &Vector3::zeros(),
            &set.batch_axes,
            half,
            black_box(&spheres),
            block,
        );
        elapsed += t.elapsed().as_secs_f64();
        hits += black_box(&*block).iter().filter(|&&o| o).count();
    }
    (elapsed, hits)
}

fn time_batch(set: &Set, half: &Vector3<f64>, out: &mut [bool]) -> (f64, usize) {
    let spheres = Spheres {
        x: &set.xs,
        y: &set.ys,
        z: &set.zs,
        radius: &set.radii,
    };
    let start = Instant::now();
    ocsi_batch(
        &Vector3::zeros(),
        &set.batch_axes,
        half,
        black_box(&spheres),
        out,
    );
    let elapsed = start.elapsed().as_secs_f64();
    (elapsed, black_box(out).iter().filter(|&&o| o).count())
}

/// A disagreement between algorithms on the same configurations.
#[derive(Debug, thiserror::Error)]
#[error(
    "{algorithm} found {found} overlaps where OCSI found {expected} (L*={l}, W*={w}, R*={radius})"
)]
pub struct Disagreement {
    algorithm: &'static str,
    found: usize,
    expected: usize,
    l: f64,
    w: f64,
    radius: f64,
}

/// Runs the benchmark; `progress` is told each finished (L*, W*, R*).
/// Gives the rows (per algorithm and radius, medians over the grid) and
/// the points (per algorithm, radius and cuboid, medians over the sets).
pub fn run(
    cfg: &OcsiBenchConfig,
    mut progress: impl FnMut(f64, f64, f64),
) -> Result<(Vec<OcsiRow>, Vec<OcsiPoint>), Disagreement> {
    let mut rows = Vec::new();
    let mut points = Vec::new();
    let mut out = vec![false; cfg.configurations];
    for &radius in &cfg.radii {
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); ALGORITHMS.len()];
        let mut outside = 0usize;
        let mut total = 0usize;
        for (il, &l) in cfg.lengths.iter().enumerate() {
            for (iw, &w) in cfg.lengths.iter().enumerate() {
                // Thickness T = 1 along x, length along y, width along z.
                let half = Vector3::new(0.5, 0.5 * l, 0.5 * w);
                for s in 0..cfg.sets {
                    let seed =
                        cfg.seed ^ ((il * 1000 + iw * 10 + s) as u64) << 20 ^ radius.to_bits();
                    let set = generate(&half, radius, cfg, seed);
                    let scalars: [Scalar; 5] = [ocsi, sse, qrf, qri, arvo];
                    let (t, cached) = time_batch_in_cache(&set, &half, &mut out);
                    times[0].push(t);
                    let (t, expected) = time_batch(&set, &half, &mut out);
                    times[1].push(t);
                    let mut reference = None;
                    for (k, f) in scalars.into_iter().enumerate() {
                        let (t, hits) = time_scalar(f, &set, radius, &half);
                        times[k + 2].push(t);
                        let r = *reference.get_or_insert(hits);
                        if hits != r {
                            return Err(Disagreement {
                                algorithm: ALGORITHMS[k + 2],
                                found: hits,
                                expected: r,
                                l,
                                w,
                                radius,
                            });
                        }
                    }
                    // The batch sees the centres in another rotated frame:
                    // rounding may flip a configuration within 1e-15 of contact.
                    let r = reference.unwrap_or(expected);
                    for (name, found) in [("ocsi_batch", expected), ("ocsi_batch_in_cache", cached)]
                    {
                        if found.abs_diff(r) > cfg.configurations / 100_000 {
                            return Err(Disagreement {
                                algorithm: name,
                                found,
                                expected: r,
                                l,
                                w,
                                radius,
                            });
                        }
                    }
                    outside += cfg.configurations - r;
                    total += cfg.configurations;
                }
                for (k, t) in times.iter().enumerate() {
                    let mut here = t[t.len() - cfg.sets..].to_vec();
                    points.push(OcsiPoint {
                        algorithm: ALGORITHMS[k],
                        radius,
                        length: l,
                        width: w,
                        ns_per_test: median(&mut here) * 1e9 / cfg.configurations as f64,
                    });
                }
                progress(l, w, radius);
            }
        }
        for (k, t) in times.iter_mut().enumerate() {
            let ns = median(t) * 1e9 / cfg.configurations as f64;
            rows.push(OcsiRow {
                algorithm: ALGORITHMS[k],
                radius,
                ns_per_test: ns,
                ms_per_2e6_tests: ns * 2e6 * 1e-6,
                non_overlap_ratio: outside as f64 / total as f64,
                threads: 1,
            });
        }
    }
    Ok((rows, points))
}

/// Plots in the manner of Tonti & Patti's Figs. 2–3: per sphere radius R*,
/// ns per test against the cuboid length L* (median over the widths W*)
/// and against W* (median over L*), one line per algorithm.
pub fn plot(
    points: &[OcsiPoint],
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, super::plot::PlotError> {
    use super::plot::{Figure, Series, line_plot};
    let mut radii: Vec<f64> = Vec::new();
    for p in points {
        if !radii.contains(&p.radius) {
            radii.push(p.radius);
        }
    }
    let mut paths = Vec::new();
    for radius in radii {
        for (axis, label, along_length) in [
            ("L", "cuboid length L* (thickness 1)", true),
            ("W", "cuboid width W* (thickness 1)", false),
        ] {
            let series: Vec<Series> = ALGORITHMS
                .iter()
                .map(|&algorithm| {
                    let here: Vec<&OcsiPoint> = points
                        .iter()
                        .filter(|p| p.algorithm == algorithm && p.radius == radius)
                        .collect();
                    let mut xs: Vec<f64> = here
                        .iter()
                        .map(|p| if along_length { p.length } else { p.width })
                        .collect();
                    xs.sort_by(f64::total_cmp);
                    xs.dedup();
                    Series {
                        name: algorithm.into(),
                        points: xs
                            .into_iter()
                            .map(|x| {
                                let mut ys: Vec<f64> = here
                                    .iter()
                                    .filter(|p| {
                                        (if along_length { p.length } else { p.width }) == x
                                    })
                                    .map(|p| p.ns_per_test)
                                    .collect();
                                (x, median(&mut ys))
                            })
                            .collect(),
                    }
                })
                .collect();
            let path = dir.join(format!("ocsi-{axis}-R{radius}.svg"));
            let title = format!(
                "Cuboid-sphere overlap tests, R* = {radius}: time against {axis}* (median over the other edge)"
            );
            line_plot(
                &path,
                &Figure {
                    title: &title,
                    x_label: label,
                    y_label: "time per test (ns)",
                    log_x: false,
                    log_y: true,
                },
                &series,
            )?;
            paths.push(path);
        }
    }
    Ok(paths)
}

/// Median of the values (sorted in place).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The paper-style table (Tonti & Patti Table 1): rows R*, columns the
/// algorithms, entries ms per 2×10⁶ tests and ns per test; then the ratio of
/// QRI and QRF to OCSI.
pub fn table(rows: &[OcsiRow]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = write!(s, "| R* |");
    for a in ALGORITHMS {
        let _ = write!(s, " {a} ms/2e6 (ns/test) |");
    }
    let _ = writeln!(s, " non-overlap |");
    let _ = writeln!(s, "|---|{}---|", "---|".repeat(ALGORITHMS.len()));
    let mut radii: Vec<f64> = rows.iter().map(|r| r.radius).collect();
    radii.dedup();
    for radius in &radii {
        let _ = write!(s, "| {radius} |");
        let mut ratio = 0.0;
        for a in ALGORITHMS {
            if let Some(r) = rows
                .iter()
                .find(|r| r.algorithm == a && r.radius == *radius)
            {
                let _ = write!(s, " {:.2} ({:.2}) |", r.ms_per_2e6_tests, r.ns_per_test);
                ratio = r.non_overlap_ratio;
            }
        }
        let _ = writeln!(s, " {ratio:.3} |");
    }
    let _ = writeln!(s);
    for radius in &radii {
        let ns = |a: &str| {
            rows.iter()
                .find(|r| r.algorithm == a && r.radius == *radius)
                .map(|r| r.ns_per_test)
        };
        if let (Some(o), Some(i), Some(f), Some(b)) =
            (ns("ocsi"), ns("qri"), ns("qrf"), ns("ocsi_batch_in_cache"))
        {
            let _ = writeln!(
                s,
                "R* = {radius}: QRI/OCSI = {:.2}, QRF/OCSI = {:.2}, OCSI/OCSI-batch-in-cache = {:.2}",
                i / o,
                f / o,
                o / b
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_radius_gives_the_target_ratio() {
        let edges = Vector3::new(1.0, 4.0, 9.0);
        let r = sampling_radius(&edges, 0.5, 0.4);
        let ratio = 1.0 - spherocuboid_volume(&edges, 0.5) / spherocuboid_volume(&edges, r);
        assert!((ratio - 0.4).abs() < 1e-12);
    }

    #[test]
    fn quick_protocol_hits_the_non_overlap_ratio() {
        let cfg = OcsiBenchConfig {
            lengths: vec![3.0],
            radii: vec![0.5],
            configurations: 100_000,
            sets: 1,
            ..OcsiBenchConfig::paper()
        };
        let (rows, points) = run(&cfg, |_, _, _| {}).unwrap();
        assert_eq!(rows.len(), ALGORITHMS.len());
        // One point per algorithm at the one cuboid, the same as its row.
        assert_eq!(points.len(), ALGORITHMS.len());
        for (p, r) in points.iter().zip(&rows) {
            assert_eq!((p.algorithm, p.length, p.width), (r.algorithm, 3.0, 3.0));
            assert_eq!(p.ns_per_test, r.ns_per_test);
        }
        // 10⁵ samples: standard error of the ratio ≈ 0.0015.
        assert!(
            (rows[0].non_overlap_ratio - 0.4).abs() < 0.006,
            "{}",
            rows[0].non_overlap_ratio
        );
    }
}
