//! Positional structure of a configuration's centres: the radial
//! distribution function g(r) and Steinhardt's bond-orientational order
//! Q_l (Steinhardt, Nelson & Ronchetti, PRB 28, 784 (1983)), per particle,
//! locally averaged (Lechner & Dellago, JCP 129, 114707 (2008)) and over
//! the whole system.

use nalgebra::Vector3;
use serde::Serialize;

use crate::space::{PeriodicBox, pairs_within};

type V3 = Vector3<f64>;

/// g(r) of the centres on `bins` equal bins of [0, r_max): the pairs at
/// each distance over those of an ideal gas of the same density, with
/// (N − 1)/V as the density each centre sees.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rdf {
    /// Bin centres.
    pub r: Vec<f64>,
    /// g at each.
    pub g: Vec<f64>,
}

/// The radial distribution function of `centres` in `box_` (minimum
/// image; r_max at most half the box's smallest height).
pub fn radial_distribution(box_: &PeriodicBox, centres: &[V3], bins: usize, r_max: f64) -> Rdf {
    let n = centres.len();
    let width = r_max / bins as f64;
    let mut counts = vec![0u64; bins];
    pairs_within(box_, centres, r_max, |_, _, d| {
        counts[((d.norm() / width) as usize).min(bins - 1)] += 1;
    });
    let density = (n as f64 - 1.0) / box_.volume();
    let shell = |k: usize| {
        let (r1, r2) = (k as f64 * width, (k + 1) as f64 * width);
        4.0 / 3.0 * std::f64::consts::PI * (r2.powi(3) - r1.powi(3))
    };
    Rdf {
        r: (0..bins).map(|k| (k as f64 + 0.5) * width).collect(),
        g: (0..bins)
            .map(|k| 2.0 * counts[k] as f64 / (n as f64 * density * shell(k)))
            .collect(),
    }
}

/// S(k) from g(r) (`density` the number density):
/// S(k) = 1 + 4πρ ∫₀^{r_max} r² (g(r) − 1) sin(kr)/(kr) dr by the midpoint
/// rule on g's bins, at `points` wave numbers up to `k_max`. Cut at r_max,
/// it ripples with period 2π/r_max; the peaks stand.
pub fn structure_factor(
    rdf: &Rdf,
    density: f64,
    k_max: f64,
    points: usize,
) -> (Vec<f64>, Vec<f64>) {
    let width = 2.0 * rdf.r.first().copied().unwrap_or(0.0);
    let k: Vec<f64> = (1..=points)
        .map(|i| k_max * i as f64 / points as f64)
        .collect();
    let s = k
        .iter()
        .map(|&k| {
            let integral: f64 = rdf
                .r
                .iter()
                .zip(&rdf.g)
                .map(|(&r, &g)| r * r * (g - 1.0) * (k * r).sin() / (k * r) * width)
                .sum();
            1.0 + 4.0 * std::f64::consts::PI * density * integral
        })
        .collect();
    (k, s)
}

/// Steinhardt's Q_l of one configuration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Steinhardt {
    /// l.
    pub l: usize,
    /// Q_l of each particle over its neighbours (NaN for a particle
    /// without one).
    pub per_particle: Vec<f64>,
    /// Their mean over the particles with neighbours.
    pub mean: f64,
    /// The mean of the locally averaged Q̄_l (each particle's q_lm
    /// averaged with its neighbours').
    pub mean_local_average: f64,
    /// The system's Q_l: from the q_lm summed over every bond.
    pub global: f64,
}

/// The neighbours of each centre: those closer than `cutoff` (minimum
/// image), with the bond vectors.
pub fn neighbours(box_: &PeriodicBox, centres: &[V3], cutoff: f64) -> Vec<Vec<(usize, V3)>> {
    let mut out = vec![Vec::new(); centres.len()];
    pairs_within(box_, centres, cutoff, |i, j, d| {
        out[i].push((j, d));
        out[j].push((i, -d));
    });
    // In index order, as the neighbours of a centre were found before.
    for list in &mut out {
        list.sort_by_key(|(j, _)| *j);
    }
    out
}

/// Q_l for each l of `ls` over the bonds of `neighbours`.
pub fn steinhardt(neighbours: &[Vec<(usize, V3)>], ls: &[usize]) -> Vec<Steinhardt> {
    ls.iter().map(|&l| steinhardt_l(neighbours, l)).collect()
}

fn steinhardt_l(neighbours: &[Vec<(usize, V3)>], l: usize) -> Steinhardt {
    let n = neighbours.len();
    // q_lm for m = 0..=l (m < 0 follow: q_{l,−m} = (−1)^m q_lm*).
    let mut q = vec![vec![(0.0, 0.0); l + 1]; n];
    let mut global = vec![(0.0, 0.0); l + 1];
    let mut bonds = 0usize;
    for (i, list) in neighbours.iter().enumerate() {
        for (_, d) in list {
            let y = harmonics(l, d);
            for m in 0..=l {
                q[i][m].0 += y[m].0;
                q[i][m].1 += y[m].1;
                global[m].0 += y[m].0;
                global[m].1 += y[m].1;
            }
            bonds += 1;
        }
        if !list.is_empty() {
            for qm in &mut q[i] {
                qm.0 /= list.len() as f64;
                qm.1 /= list.len() as f64;
            }
        }
    }
    let invariant = |qm: &[(f64, f64)]| {
        let sum: f64 = qm
            .iter()
            .enumerate()
            .map(|(m, (re, im))| (if m == 0 { 1.0 } else { 2.0 }) * (re * re + im * im))
            .sum();
        (4.0 * std::f64::consts::PI / (2 * l + 1) as f64 * sum).sqrt()
    };
    let per_particle: Vec<f64> = (0..n)
        .map(|i| {
            if neighbours[i].is_empty() {
                f64::NAN
            } else {
                invariant(&q[i])
            }
        })
        .collect();
    let local: Vec<f64> = (0..n)
        .filter(|&i| !neighbours[i].is_empty())
        .map(|i| {
            let mut avg = q[i].clone();
            for (j, _) in &neighbours[i] {
                for m in 0..=l {
                    avg[m].0 += q[*j][m].0;
                    avg[m].1 += q[*j][m].1;
                }
            }
            let count = (neighbours[i].len() + 1) as f64;
            for a in &mut avg {
                a.0 /= count;
                a.1 /= count;
            }
            invariant(&avg)
        })
        .collect();
    let with: Vec<f64> = per_particle
        .iter()
        .copied()
        .filter(|x| !x.is_nan())
        .collect();
    let mean = |x: &[f64]| {
        if x.is_empty() {
            f64::NAN
        } else {
            x.iter().sum::<f64>() / x.len() as f64
        }
    };
    for g in &mut global {
        g.0 /= bonds.max(1) as f64;
        g.1 /= bonds.max(1) as f64;
    }
    Steinhardt {
        l,
        mean: mean(&with),
        mean_local_average: mean(&local),
        global: if bonds == 0 {
            f64::NAN
        } else {
            invariant(&global)
        },
        per_particle,
    }
}

/// Y_lm(r̂) for m = 0..=l (Condon–Shortley phase), as (re, im).
fn harmonics(l: usize, d: &V3) -> Vec<(f64, f64)> {
    let r = d.norm();
    let cos_theta = (d.z / r).clamp(-1.0, 1.0);
    let phi = d.y.atan2(d.x);
    (0..=l)
        .map(|m| {
            let norm = ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI)
                * factorial_ratio(l - m, l + m))
            .sqrt();
            let p = associated_legendre(l, m, cos_theta);
            let (sin, cos) = (m as f64 * phi).sin_cos();
            (norm * p * cos, norm * p * sin)
        })
        .collect()
}

/// (a)! / (b)! for a ≤ b.
fn factorial_ratio(a: usize, b: usize) -> f64 {
    ((a + 1)..=b).map(|k| 1.0 / k as f64).product()
}

/// P_l^m(x), 0 ≤ m ≤ l, |x| ≤ 1, with the Condon–Shortley phase, by the
/// standard upward recurrence in l.
fn associated_legendre(l: usize, m: usize, x: f64) -> f64 {
    let mut pmm = 1.0;
    if m > 0 {
        let s = ((1.0 - x) * (1.0 + x)).sqrt();
        let mut f = 1.0;
        for _ in 0..m {
            pmm *= -f * s;
            f += 2.0;
        }
    }
    if l == m {
        return pmm;
    }
    let mut pm1 = x * (2 * m + 1) as f64 * pmm;
    if l == m + 1 {
        return pm1;
    }
    let mut result = 0.0;
    for ll in (m + 2)..=l {
        result = (x * (2 * ll - 1) as f64 * pm1 - (ll + m - 1) as f64 * pmm) / (ll - m) as f64;
        pmm = pm1;
        pm1 = result;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(kind: &str, cells: usize) -> (PeriodicBox, Vec<V3>) {
        let basis: Vec<[f64; 3]> = match kind {
            "sc" => vec![[0.0; 3]],
            "bcc" => vec![[0.0; 3], [0.5; 3]],
            _ => vec![[0.0; 3], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]],
        };
        let side = cells as f64;
        let box_ = PeriodicBox::new(V3::repeat(side)).unwrap();
        let mut centres = Vec::new();
        for i in 0..cells {
            for j in 0..cells {
                for k in 0..cells {
                    for b in &basis {
                        let p = V3::new(i as f64, j as f64, k as f64) + V3::from(*b);
                        centres.push(box_.minimum_image(&(p - V3::repeat(side / 2.0))));
                    }
                }
            }
        }
        (box_, centres)
    }

    /// The values every reference gives for perfect lattices (first
    /// shells: sc 6, bcc 8, fcc 12 neighbours).
    #[test]
    fn perfect_lattices_give_the_textbook_q4_and_q6() {
        for (kind, cutoff, q4, q6) in [
            ("sc", 1.1, 0.76376, 0.35355),
            ("bcc", 0.9, 0.50918, 0.62854),
            ("fcc", 0.8, 0.19094, 0.57452),
        ] {
            let (box_, centres) = lattice(kind, 4);
            let list = neighbours(&box_, &centres, cutoff);
            let q = steinhardt(&list, &[4, 6]);
            for (s, want) in q.iter().zip([q4, q6]) {
                for got in [s.mean, s.mean_local_average, s.global] {
                    assert!(
                        (got - want).abs() < 1e-5,
                        "{kind} Q{}: {got} vs {want}",
                        s.l
                    );
                }
            }
        }
    }

    /// An ideal gas has g(r) = 1 within noise; no pair inside the contact
    /// distance of a lattice, and its first shell where it should be.
    #[test]
    fn rdf_of_a_gas_is_flat_and_of_a_lattice_peaked() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let box_ = PeriodicBox::new(V3::repeat(10.0)).unwrap();
        let gas: Vec<V3> = (0..2000)
            .map(|_| V3::new(rng.r#gen(), rng.r#gen(), rng.r#gen()) * 10.0 - V3::repeat(5.0))
            .collect();
        let rdf = radial_distribution(&box_, &gas, 20, 5.0);
        let far: Vec<f64> = rdf.g[4..].to_vec();
        let mean = far.iter().sum::<f64>() / far.len() as f64;
        assert!((mean - 1.0).abs() < 0.01, "{mean}");
        let (box_, fcc) = lattice("fcc", 4);
        let rdf = radial_distribution(&box_, &fcc, 40, 2.0);
        // The first shell, at 1/√2, lies in bin 14 of width 0.05.
        let first = (0.5f64.sqrt() / 0.05) as usize;
        assert!(rdf.g[..first].iter().all(|&g| g == 0.0));
        assert!(rdf.g[first] > 5.0, "{}", rdf.g[first]);
    }

    /// S(k) of a dense fluid peaks near 2π/σ and of an ideal gas stays
    /// near 1.
    #[test]
    fn structure_factor_of_gas_and_of_dense_spheres() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let box_ = PeriodicBox::new(V3::repeat(10.0)).unwrap();
        let gas: Vec<V3> = (0..2000)
            .map(|_| V3::new(rng.r#gen(), rng.r#gen(), rng.r#gen()) * 10.0 - V3::repeat(5.0))
            .collect();
        let rdf = radial_distribution(&box_, &gas, 100, 4.9);
        let (_, s) = structure_factor(&rdf, 2.0, 20.0, 40);
        assert!(s[10..].iter().all(|&x| (x - 1.0).abs() < 0.1), "{s:?}");
        // Hard spheres at the fcc close packing: the first peak of S(k) near
        // 2π/σ times √(3/2) (the (111) reflection at 2π√3/a, a = √2 σ).
        let (box_, fcc) = lattice("fcc", 5);
        let centres: Vec<V3> = fcc.iter().map(|c| c * 2f64.sqrt()).collect();
        let box_ = PeriodicBox::new(box_.lengths() * 2f64.sqrt()).unwrap();
        let rdf = radial_distribution(&box_, &centres, 400, 3.5);
        let density = centres.len() as f64 / box_.volume();
        let (k, s) = structure_factor(&rdf, density, 12.0, 240);
        let peak = (0..k.len()).max_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap();
        let expected = 2.0 * std::f64::consts::PI * 3f64.sqrt() / 2f64.sqrt();
        assert!(
            (k[peak] - expected).abs() < 0.4,
            "peak at {} not {expected}",
            k[peak]
        );
    }

    #[test]
    fn legendre_matches_closed_forms() {
        for x in [-0.9f64, -0.3, 0.0, 0.4, 0.95] {
            let s: f64 = (1.0 - x * x).sqrt();
            assert!((associated_legendre(2, 0, x) - 0.5 * (3.0 * x * x - 1.0)).abs() < 1e-14);
            assert!((associated_legendre(2, 1, x) + 3.0 * x * s).abs() < 1e-14);
            assert!((associated_legendre(3, 3, x) + 15.0 * s * s * s).abs() < 1e-13);
            let p40 = (35.0 * x.powi(4) - 30.0 * x * x + 3.0) / 8.0;
            assert!((associated_legendre(4, 0, x) - p40).abs() < 1e-14);
        }
    }
}
