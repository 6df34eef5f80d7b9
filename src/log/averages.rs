//! Equilibrium averages of a log's `/stats`, stage by stage: for every
//! observable of every Monte Carlo and dynamics stage, where it
//! equilibrated, its mean from there on with an error that accounts for
//! correlation, and whether the stage equilibrated at all
//! (`hardbody analyze`).

use std::collections::BTreeMap;

use serde::Serialize;

use super::Stats;
use super::read::LogContents;
use crate::analysis::series::{Estimate, detect_equilibration};
use crate::scene::Scene;

/// Candidate equilibration starts tried per series.
const CANDIDATE_STARTS: usize = 200;

/// One observable of one stage.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Observable {
    /// The estimate from the equilibrated part.
    #[serde(flatten)]
    pub estimate: Estimate,
    /// The sweep (Monte Carlo) or time (dynamics) of the first sample
    /// counted.
    pub equilibrated_from: f64,
    /// Whether every sample has the same value to within 1e-9 of it (an
    /// imposed pressure, the temperature of dynamics): then it is
    /// reported, not estimated.
    pub constant: bool,
}

/// One stage of a log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageAverages {
    /// Index of the stage in the scene.
    pub stage_index: usize,
    /// `monte_carlo` or `dynamics` (compression stages are not at
    /// equilibrium and are listed without averages).
    pub stage: String,
    /// `/stats` messages of the stage.
    pub samples: usize,
    /// Sweeps (Monte Carlo) or simulated time (dynamics) the samples span.
    pub span: [f64; 2],
    /// Per observable (the `/stats` field names).
    pub observables: BTreeMap<String, Observable>,
    /// Whether every observable that is not an acceptance rate
    /// equilibrated (the acceptances follow the move sizes, not the
    /// physics).
    pub equilibrated: bool,
    /// The observables that did not equilibrate.
    pub not_equilibrated: Vec<String>,
    /// The collision searches' counts over the stage (dynamics).
    pub solver: Option<crate::edmd::SolverWork>,
}

/// The observables of a `/stats` message that averages are taken of
/// (not the box, which follows φ, nor MSD and C₂, which are functions of
/// time, not stationary values).
fn observables(s: &Stats) -> [(&'static str, Option<f64>); 14] {
    let tensor = |k: usize| s.pressure_tensor.map(|t| t[k]);
    [
        ("packing_fraction", Some(s.packing_fraction)),
        ("pressure", s.pressure),
        ("pressure_xx", tensor(0)),
        ("pressure_xy", tensor(1)),
        ("pressure_xz", tensor(2)),
        ("pressure_yy", tensor(3)),
        ("pressure_yz", tensor(4)),
        ("pressure_zz", tensor(5)),
        ("temperature", s.temperature),
        ("nematic_order", s.nematic_order),
        ("acceptance_translate", s.acceptance_translate),
        ("acceptance_rotate", s.acceptance_rotate),
        ("acceptance_volume", s.acceptance_volume),
        ("acceptance_swap", s.acceptance_swap),
    ]
}

/// Averages of every stage in `stats` (a log's `/stats`, in order).
pub fn stage_averages(stats: &[Stats]) -> Vec<StageAverages> {
    let mut stages: Vec<Vec<&Stats>> = Vec::new();
    for s in stats {
        match stages.last_mut() {
            Some(run) if run[0].stage_index == s.stage_index => run.push(s),
            _ => stages.push(vec![s]),
        }
    }
    stages.iter().map(|run| one_stage(run)).collect()
}

fn progress(s: &Stats) -> f64 {
    s.sweep.map(|w| w as f64).or(s.time).unwrap_or(f64::NAN)
}

/// Whether a stage of this kind samples an equilibrium ensemble: a
/// compression drives the density and a jam grows the bodies, so neither
/// has averages.
pub fn is_equilibrium_stage(kind: &str) -> bool {
    !matches!(kind, "compress" | "jam")
}

fn one_stage(run: &[&Stats]) -> StageAverages {
    let first = run[0];
    let span = [progress(first), progress(run[run.len() - 1])];
    let mut observables_of = BTreeMap::new();
    let mut not_equilibrated = Vec::new();
    if is_equilibrium_stage(&first.stage) {
        for (k, (name, _)) in observables(first).iter().enumerate() {
            // The samples where the stage measures it (all or none).
            let (at, x): (Vec<f64>, Vec<f64>) = run
                .iter()
                .filter_map(|s| observables(s)[k].1.map(|v| (progress(s), v)))
                .unzip();
            if x.is_empty() || !x.iter().all(|v| v.is_finite()) {
                continue;
            }
            // Constant to rounding (an imposed pressure; the temperature of
            // dynamics, which conserves energy).
            let (lo, hi) = x
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            let constant = hi - lo <= 1e-9 * hi.abs().max(lo.abs());
            let estimate = if constant {
                Estimate {
                    error: 0.0,
                    statistical_inefficiency: 1.0,
                    effective_samples: x.len() as f64,
                    equilibrated: true,
                    ..crate::analysis::series::estimate_from(&x, 0)
                }
            } else {
                detect_equilibration(&x, CANDIDATE_STARTS)
            };
            if !estimate.equilibrated && !name.starts_with("acceptance") {
                not_equilibrated.push(name.to_string());
            }
            observables_of.insert(
                name.to_string(),
                Observable {
                    equilibrated_from: at[estimate.start.min(at.len() - 1)],
                    estimate,
                    constant,
                },
            );
        }
    }
    StageAverages {
        stage_index: first.stage_index,
        stage: first.stage.clone(),
        samples: run.len(),
        span,
        equilibrated: is_equilibrium_stage(&first.stage) && not_equilibrated.is_empty(),
        observables: observables_of,
        not_equilibrated,
        solver: run[run.len() - 1].solver,
    }
}

/// One observable averaged over independent replicas (runs of one scene
/// with other seeds).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReplicaAverage {
    /// Mean of the replicas' means.
    pub mean: f64,
    /// Its error: the larger of the replicas' errors combined,
    /// √(Σ eᵢ²)/R, and their spread over √R (which does not trust any
    /// one run's error).
    pub error: f64,
    /// Standard deviation of the replicas' means.
    pub spread: f64,
    /// Replicas averaged.
    pub replicas: usize,
    /// Whether it equilibrated in every replica.
    pub equilibrated: bool,
}

/// The average over replicas of one observable's estimates (at least two).
pub fn over_replicas(estimates: &[Estimate]) -> ReplicaAverage {
    let r = estimates.len() as f64;
    let mean = estimates.iter().map(|e| e.mean).sum::<f64>() / r;
    let combined = estimates
        .iter()
        .map(|e| e.error * e.error)
        .sum::<f64>()
        .sqrt()
        / r;
    let spread = (estimates
        .iter()
        .map(|e| (e.mean - mean).powi(2))
        .sum::<f64>()
        / (r - 1.0).max(1.0))
    .sqrt();
    ReplicaAverage {
        mean,
        error: combined.max(spread / r.sqrt()),
        spread,
        replicas: estimates.len(),
        equilibrated: estimates.iter().all(|e| e.equilibrated),
    }
}

/// One stage over replicas.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplicaStage {
    /// Index of the stage in the scene.
    pub stage_index: usize,
    /// Its kind.
    pub stage: String,
    /// Per observable measured in every replica (constants included, their
    /// spread telling whether they agree).
    pub observables: BTreeMap<String, ReplicaAverage>,
    /// Whether every replica's stage equilibrated.
    pub equilibrated: bool,
}

/// Why logs are not replicas of one scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReplicaError {
    /// No log was given.
    #[error("no runs to average")]
    None,
    /// A log holds no scene to compare.
    #[error("{0}: no readable scene in its metadata")]
    NoScene(String),
    /// Two logs of one scene and one seed: one run (a copy, or two cuts).
    #[error("{log}: the same run as {other} (seed {seed}); replicas need different seeds")]
    SameRun {
        /// The log refused.
        log: String,
        /// The log it repeats.
        other: String,
        /// Their seed.
        seed: u64,
    },
    /// A log of another scene.
    #[error("{log}: its scene differs from that of {first} other than in the seed: not a replica")]
    OtherScene {
        /// The log refused.
        log: String,
        /// The first log.
        first: String,
    },
    /// A run whose stages differ from the first run's.
    #[error("run {run} has stages {stages:?}, run 1 {first:?}: not replicas of one scene")]
    OtherStages {
        /// The run (from 1).
        run: usize,
        /// Its stages (index, kind).
        stages: Vec<(usize, String)>,
        /// The first run's.
        first: Vec<(usize, String)>,
    },
}

/// The stages of several runs of one scene averaged stage by stage; the
/// runs must have the same stages (index and kind) in the same order.
pub fn stages_over_replicas(
    runs: &[Vec<StageAverages>],
) -> Result<Vec<ReplicaStage>, ReplicaError> {
    let first = runs.first().ok_or(ReplicaError::None)?;
    for (k, run) in runs.iter().enumerate().skip(1) {
        let kinds = |r: &[StageAverages]| {
            r.iter()
                .map(|s| (s.stage_index, s.stage.clone()))
                .collect::<Vec<_>>()
        };
        if kinds(run) != kinds(first) {
            return Err(ReplicaError::OtherStages {
                run: k + 1,
                stages: kinds(run),
                first: kinds(first),
            });
        }
    }
    Ok(first
        .iter()
        .enumerate()
        .map(|(i, stage)| {
            let observables = stage
                .observables
                .keys()
                .filter_map(|name| {
                    let estimates: Vec<Estimate> = runs
                        .iter()
                        .map(|run| run[i].observables.get(name).map(|o| o.estimate))
                        .collect::<Option<_>>()?;
                    Some((name.clone(), over_replicas(&estimates)))
                })
                .collect();
            ReplicaStage {
                stage_index: stage.stage_index,
                stage: stage.stage.clone(),
                observables,
                equilibrated: runs.iter().all(|run| run[i].equilibrated),
            }
        })
        .collect())
}

/// The stages of every replica and of all together.
#[derive(Debug, Clone, PartialEq)]
pub struct Replicas {
    /// Each replica's stages, in the order given.
    pub runs: Vec<Vec<StageAverages>>,
    /// The stages over all of them.
    pub combined: Vec<ReplicaStage>,
}

/// Averages over the logs of replicas of one scene, `(name, contents)`
/// each: refused (naming the log) where a log holds no readable scene, or
/// a scene that differs from the first's other than in its seed and log.
pub fn replica_averages(logs: &[(String, &LogContents)]) -> Result<Replicas, ReplicaError> {
    let mut first: Option<(&str, Scene)> = None;
    let mut seeds: Vec<(u64, &str)> = Vec::with_capacity(logs.len());
    let mut runs = Vec::with_capacity(logs.len());
    for (name, contents) in logs {
        let resolved = contents
            .metadata
            .get("scene_resolved")
            .and_then(|t| Scene::parse(t).ok());
        // One scene and one seed make one run, bit for bit: a copy of a
        // log, or two cuts of one, is not a second replica.
        if let Some(scene) = &resolved {
            if let Some((seed, other)) = seeds.iter().find(|(s, _)| *s == scene.seed) {
                return Err(ReplicaError::SameRun {
                    log: name.clone(),
                    other: other.to_string(),
                    seed: *seed,
                });
            }
            seeds.push((scene.seed, name));
        }
        let scene = resolved
            .map(|s| Scene {
                seed: 0,
                log: Default::default(),
                ..s.into_scene()
            })
            .ok_or_else(|| ReplicaError::NoScene(name.clone()))?;
        match &first {
            None => first = Some((name, scene)),
            Some((first_name, f)) if *f != scene => {
                return Err(ReplicaError::OtherScene {
                    log: name.clone(),
                    first: first_name.to_string(),
                });
            }
            Some(_) => {}
        }
        let stats: Vec<Stats> = contents.stats.iter().map(|(_, s)| s.clone()).collect();
        runs.push(stage_averages(&stats));
    }
    let combined = stages_over_replicas(&runs)?;
    Ok(Replicas { runs, combined })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::series::estimate_from;

    fn estimate(mean: f64, error: f64) -> Estimate {
        Estimate {
            mean,
            error,
            ..estimate_from(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], 0)
        }
    }

    #[test]
    fn replicas_that_scatter_more_than_their_errors_get_the_scatter() {
        // Agreeing replicas: the combined error.
        let a = over_replicas(&[estimate(1.0, 0.1), estimate(1.0, 0.1)]);
        assert_eq!(a.mean, 1.0);
        assert!((a.error - 0.1 / 2f64.sqrt()).abs() < 1e-12);
        // Replicas 1 apart with errors of 0.1: the spread decides.
        let b = over_replicas(&[estimate(0.0, 0.1), estimate(1.0, 0.1)]);
        assert_eq!(b.mean, 0.5);
        assert!((b.spread - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((b.error - 0.5).abs() < 1e-12);
    }
}
