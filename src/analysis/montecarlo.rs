//! Monte Carlo over seeds: accuracy, honesty of σ (χ²) and efficiency (ratio to CRLB).

use crate::analysis::campaign::{self, Threads};
use crate::analysis::report::Report;
use crate::sim::estimate::Method;
use crate::sim::files::FileError;
use crate::sim::requirements::{REQ_COM_M, REQ_SCALE_FACTOR_REL};
use crate::sim::scenario::Scenario;
use serde::Serialize;
use std::path::PathBuf;

pub mod shard;

/// A Monte Carlo that could not run, or shards' results that do not make one
/// campaign; the message names the option or the file.
#[derive(Debug, thiserror::Error)]
pub enum MonteCarloError {
    #[error("the Fisher information of this scenario is singular")]
    Singular,
    #[error("--runs must be at least 1")]
    NoRuns,
    #[error(
        "--seed {first_seed} with --runs {runs}: the seeds would run past {}",
        u64::MAX
    )]
    SeedOverflow { first_seed: u64, runs: u64 },
    #[error("--shard {shard} with --runs {runs}: more shards than runs; use at most {runs}")]
    MoreShardsThanRuns { shard: shard::Shard, runs: u64 },
    #[error("cannot read this program's executable to identify the build ({0})")]
    BuildId(#[source] std::io::Error),
    #[error("cannot write the scenario as TOML: {0}")]
    ScenarioToml(#[source] toml::ser::Error),
    /// A result file in the shard's folder belongs to another campaign.
    #[error("{}: the result of another campaign (it differs in {}); give each campaign its own --out folder", path.display(), differences.join(", "))]
    OtherCampaign {
        path: PathBuf,
        differences: Vec<&'static str>,
    },
    /// A report that JSON cannot give back bit for bit.
    #[error("seed {seed}: its report does not read back exactly from JSON (a number that is not finite?), so it could not be merged exactly; run this campaign without --shard")]
    NotExact { seed: u64 },
    #[error("{0}")]
    Json(#[source] serde_json::Error),
    /// A file or folder that could not be read, created or written.
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{}: cannot read ({source})", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// `found`: the file's `format`, as JSON writes it.
    #[error("{}: a result file of format {found}, not {:?}: made by another version", path.display(), shard::FORMAT)]
    OtherFormat { path: PathBuf, found: String },
    #[error("{}: not a Monte Carlo result file ({source})", path.display())]
    NotResultFile {
        path: PathBuf,
        #[source]
        source: shard::RunFileError,
    },
    #[error("{}: holds seed {seed} (its report: seed {report_seed}); a result file is named run-<seed>.json after its seed", path.display())]
    SeedMismatch {
        path: PathBuf,
        seed: u64,
        report_seed: u64,
    },
    #[error("{}: its scenario does not match its scenario_hash: the file was edited", path.display())]
    Edited { path: PathBuf },
    #[error("{}: seed {seed} is not one of shard {shard}'s of {runs} runs from seed {first_seed}", path.display())]
    NotShardSeed {
        path: PathBuf,
        seed: u64,
        shard: shard::Shard,
        runs: u64,
        first_seed: u64,
    },
    #[error("{}: cannot read this folder ({source})", path.display())]
    ReadDir {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: no result files (run-<seed>.json) in this folder", path.display())]
    NoResults { path: PathBuf },
    /// The files are of `campaigns` campaigns; `msg` lists them.
    #[error("{msg}")]
    MixedCampaigns { campaigns: usize, msg: String },
    /// Seeds with no result or with several, one problem per entry.
    #[error("{}", problems.join("\n"))]
    Incomplete { problems: Vec<String> },
    #[error("{}: its report has another number of inertial sensors than the campaign's other results", path.display())]
    SensorCount { path: PathBuf },
}

/// Statistics of one parameter over the runs.
#[derive(Debug, Clone, Serialize)]
pub struct ParamStats {
    pub name: String,
    /// RMS error (relative for β and k, metres for r).
    pub rms_error: f64,
    pub worst_error: f64,
    /// RMS of error/σ; and the mean of (error/σ)².
    pub rms_normalized: f64,
    pub chi2_mean: f64,
    /// RMS error / CRLB.
    pub crlb_ratio: f64,
    pub crlb: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct MonteCarlo {
    pub scenario: String,
    pub runs: u64,
    pub first_seed: u64,
    pub method: String,
    pub runs_meeting_requirements: u64,
    /// Runs whose estimator vouched for its result (status verified).
    pub runs_verified: u64,
    /// Largest |error/σ| of any parameter in any run.
    pub worst_normalized: f64,
    /// Injected / detected / missed faults summed over the runs, by kind (`[faults]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub faults: Option<serde_json::Value>,
    pub params: Vec<ParamStats>,
    /// Mean of (error/σ)² per parameter group: β, k, r.
    pub chi2_by_group: [f64; 3],
    /// Where each group's mean may fall for these seeds alone: the 95 % interval of
    /// the mean over seeds resampled with replacement (bootstrap, `seed_interval`).
    /// An honest σ puts 1 inside; its width says how many seeds a verdict needs (a
    /// seed's six β errors are mostly one common scale error, so β's mean over 30
    /// seeds scatters by about ±0.4).
    pub chi2_interval_by_group: [[f64; 2]; 3],
    pub reports: Vec<Report>,
}

/// Resamples of the seeds behind `seed_interval`.
const BOOTSTRAP_RESAMPLES: usize = 4000;

/// The 95 % interval (2.5 and 97.5 percentiles) of the mean of `per_seed` over
/// `BOOTSTRAP_RESAMPLES` resamples of the seeds with replacement. A seed's parameters
/// are resampled together, so whatever their errors share (β's common scale, IS1's
/// and IS2's alike) widens the interval as it widens the mean's true scatter. Its
/// own fixed random stream: the same seeds give the same interval.
pub fn seed_interval(per_seed: &[f64]) -> [f64; 2] {
    use rand::{Rng as _, SeedableRng};
    let n = per_seed.len();
    if n == 0 {
        return [f64::NAN; 2];
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5eed_b007);
    let mut means: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
        .map(|_| (0..n).map(|_| per_seed[rng.gen_range(0..n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    let at =
        |q: f64| means[((q * BOOTSTRAP_RESAMPLES as f64) as usize).min(BOOTSTRAP_RESAMPLES - 1)];
    [at(0.025), at(0.975)]
}

/// Run seeds `first_seed` … `first_seed + runs − 1` on every core and summarise them.
pub fn run(
    s: &Scenario,
    first_seed: u64,
    runs: u64,
    method: Method,
) -> Result<MonteCarlo, MonteCarloError> {
    let bound = campaign_bounds(s)?;
    check_seeds(first_seed, runs)?;
    let seeds: Vec<u64> = (0..runs).map(|i| first_seed + i).collect();
    let reports = run_seeds(s, &seeds, method, &bound, |_| Ok(()))?;
    Ok(summarise(
        &s.name,
        s.inertial_sensor.len(),
        first_seed,
        runs,
        method.name(),
        reports,
    ))
}

fn check_seeds(first_seed: u64, runs: u64) -> Result<(), MonteCarloError> {
    if runs == 0 {
        return Err(MonteCarloError::NoRuns);
    }
    if first_seed.checked_add(runs - 1).is_none() {
        return Err(MonteCarloError::SeedOverflow { first_seed, runs });
    }
    Ok(())
}

/// The bounds a Monte Carlo campaign shares: the maneuver's, computed once at the
/// file's seed (its priors: ~10⁻⁵ apart from the one `run --seed N` computes at seed
/// N), and the run's where the seed does not matter (`crlb::seed_matters`); where it
/// does, each seed gets its own in `run_seeds`, and `run` here is unused.
pub(crate) fn campaign_bounds(
    s: &Scenario,
) -> Result<crate::analysis::crlb::Bounds, MonteCarloError> {
    if crate::analysis::crlb::seed_matters(s) {
        return Ok(crate::analysis::crlb::Bounds {
            run: crate::analysis::crlb::Crlb::INFINITE,
            maneuver: crate::analysis::plan::maneuver_bound(s),
        });
    }
    crate::analysis::plan::bounds(s).ok_or(MonteCarloError::Singular)
}

/// One in-process campaign per seed, on every core; the reports in the order of
/// `seeds`. `done` sees each report as soon as its campaign ends (on a worker
/// thread); its first error stops the workers taking new seeds and is returned.
pub fn run_seeds(
    s: &Scenario,
    seeds: &[u64],
    method: Method,
    bound: &crate::analysis::crlb::Bounds,
    done: impl Fn(&Report) -> Result<(), MonteCarloError> + Sync,
) -> Result<Vec<Report>, MonteCarloError> {
    let workers = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(seeds.len().max(1));
    let mut reports: Vec<Option<Report>> = vec![None; seeds.len()];
    let bar = crate::analysis::progress::Bar::new(seeds.len() as u64, "montecarlo");
    let failed = std::sync::Mutex::new(None::<MonteCarloError>);
    // One campaign per core at a time, each on one thread; a worker takes the next seed
    // when it is done, so a slow core or a busy machine does not leave the other idle.
    let next = std::sync::atomic::AtomicUsize::new(0);
    std::thread::scope(|sc| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let (bar, next, seeds, done, failed) = (bar.clone(), &next, seeds, &done, &failed);
                sc.spawn(move || {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&seed) = seeds.get(i) else {
                            return mine;
                        };
                        if failed.lock().map_or(true, |f| f.is_some()) {
                            return mine;
                        }
                        let mut sc = s.clone();
                        sc.seed = seed;
                        // Each run has the bound of its own motion and of the ticks it
                        // lost (`crlb`): one more estimator pass a seed over the
                        // noise-free twin of its own simulation (`crlb::run_with_bound`,
                        // the motion simulated once), but where neither torque noise
                        // nor losses make the seed matter. `bound` (`campaign_bounds`):
                        // the maneuver's, the same for every seed, and the run's where
                        // the seed does not matter; a seed whose own bound is singular
                        // has none (infinite).
                        let (r, run) = if crate::analysis::crlb::seed_matters(&sc) {
                            let (r, b) = crate::analysis::crlb::run_with_bound(
                                &sc,
                                seed,
                                method,
                                Threads::One,
                                |_| {},
                                None,
                            )
                            .unwrap_or_else(|e| {
                                unreachable!("a campaign that records nothing cannot fail: {e}")
                            });
                            (r, b.unwrap_or(crate::analysis::crlb::Crlb::INFINITE))
                        } else {
                            let r = campaign::run_on(&sc, seed, method, Threads::One, |_| {});
                            (r, bound.run)
                        };
                        let b = crate::analysis::crlb::Bounds {
                            run,
                            maneuver: bound.maneuver,
                        };
                        let mut rep = Report::with_bounds(
                            &sc,
                            seed,
                            "in-process",
                            method.name(),
                            &r.estimate,
                            &b,
                        );
                        rep.faults = r.faults.map(|f| f.summary());
                        if let Err(e) = done(&rep) {
                            if let Ok(mut f) = failed.lock() {
                                f.get_or_insert(e);
                            }
                            return mine;
                        }
                        mine.push((i, rep));
                        bar.inc(1);
                    }
                })
            })
            .collect();
        for h in handles {
            let mine = h.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
            for (i, rep) in mine {
                reports[i] = Some(rep);
            }
        }
    });
    bar.finish();
    if let Some(e) = failed.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e);
    }
    Ok(reports.into_iter().flatten().collect())
}

/// The statistics of `reports` (in seed order, each with `n_is` sensors): the one
/// summary of a single-machine run and of a merge, so both agree to the bit.
pub fn summarise(
    scenario: &str,
    n_is: usize,
    first_seed: u64,
    runs: u64,
    method: &str,
    reports: Vec<Report>,
) -> MonteCarlo {
    let mut params = Vec::new();
    let mut group = [(0.0, 0usize); 3];
    let axes = ["x", "y", "z"];
    for i in 0..n_is {
        for (g, name) in ["β", "k", "r"].iter().enumerate() {
            for a in 0..3 {
                let (mut se, mut worst, mut sz) = (0.0, 0.0f64, 0.0);
                // The bound's RMS over the runs (each run has the bound of its own
                // motion and losses; without torque noise or losses, one bound).
                let (mut first, mut crlb_ss, mut same) = (None, 0.0, true);
                for r in &reports {
                    let is = &r.inertial_sensors[i];
                    let q = [&is.beta, &is.k, &is.com_offset][g];
                    let scale = if g < 2 { q.truth[a] } else { 1.0 };
                    let e = (q.estimate[a] - q.truth[a]) / scale;
                    let z = (q.estimate[a] - q.truth[a]) / q.sigma[a];
                    se += e * e;
                    worst = worst.max(e.abs());
                    sz += z * z;
                    let c = q.crlb[a] / scale;
                    same &= *first.get_or_insert(c) == c;
                    crlb_ss += c * c;
                }
                let n = reports.len() as f64;
                let crlb_v = match first {
                    Some(c) if same => c,
                    Some(_) => (crlb_ss / n).sqrt(),
                    None => 0.0,
                };
                group[g].0 += sz;
                group[g].1 += reports.len();
                params.push(ParamStats {
                    name: format!("IS{} {}{}", i + 1, name, axes[a]),
                    rms_error: (se / n).sqrt(),
                    worst_error: worst,
                    rms_normalized: (sz / n).sqrt(),
                    chi2_mean: sz / n,
                    crlb_ratio: (se / n).sqrt() / crlb_v,
                    crlb: crlb_v,
                });
            }
        }
    }
    // Each seed's mean (error/σ)² per group, for the mean's interval over seeds.
    let per_seed = |g: usize| -> Vec<f64> {
        reports
            .iter()
            .map(|r| {
                let sum: f64 = r
                    .inertial_sensors
                    .iter()
                    .take(n_is)
                    .flat_map(|x| {
                        let q = [&x.beta, &x.k, &x.com_offset][g];
                        (0..3).map(move |a| ((q.estimate[a] - q.truth[a]) / q.sigma[a]).powi(2))
                    })
                    .sum();
                sum / (3 * n_is) as f64
            })
            .collect()
    };
    let chi2_interval_by_group = std::array::from_fn(|g| seed_interval(&per_seed(g)));
    let met = reports.iter().filter(|r| r.requirements.met).count() as u64;
    let verified = reports.iter().filter(|r| r.requirements.verified).count() as u64;
    let mut worst_z = 0.0f64;
    for r in &reports {
        for row in r.rows() {
            if row.z.is_nan() || row.z.abs() > worst_z {
                worst_z = row.z.abs();
            }
        }
    }
    MonteCarlo {
        runs_verified: verified,
        worst_normalized: worst_z,
        faults: sum_faults(&reports),
        scenario: scenario.into(),
        runs,
        first_seed,
        method: method.into(),
        runs_meeting_requirements: met,
        params,
        chi2_by_group: std::array::from_fn(|g| group[g].0 / group[g].1.max(1) as f64),
        chi2_interval_by_group,
        reports,
    }
}

/// Per-kind fault counts summed over the runs (None without faults).
fn sum_faults(reports: &[Report]) -> Option<serde_json::Value> {
    let mut sum: std::collections::BTreeMap<String, [u64; 5]> = Default::default();
    let keys = [
        "injected",
        "detected",
        "missed",
        "undetected_within_5_sigma",
        "not_delivered",
    ];
    for r in reports {
        let Some(kinds) = r.faults.as_ref().and_then(|f| f["by_kind"].as_object()) else {
            continue;
        };
        for (k, v) in kinds {
            let e = sum.entry(k.clone()).or_default();
            for (j, key) in keys.iter().enumerate() {
                e[j] += v[key].as_u64().unwrap_or(0);
            }
        }
    }
    if sum.is_empty() {
        return None;
    }
    let by_kind: serde_json::Map<String, serde_json::Value> = sum
        .into_iter()
        .map(|(k, v)| {
            let obj: serde_json::Map<String, serde_json::Value> = keys
                .iter()
                .zip(v)
                .map(|(k, n)| (k.to_string(), serde_json::json!(n)))
                .collect();
            (k, serde_json::Value::Object(obj))
        })
        .collect();
    Some(serde_json::json!({ "by_kind": by_kind }))
}

impl MonteCarlo {
    pub fn table(&self) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let _ = writeln!(
            o,
            "Monte Carlo: scenario {:?}, {} runs from seed {}, {} estimator",
            self.scenario, self.runs, self.first_seed, self.method
        );
        let _ = writeln!(
            o,
            "{:<10} {:>12} {:>12} {:>12} {:>10} {:>12} {:>10}",
            "parameter", "RMS error", "worst", "CRLB", "RMS/CRLB", "RMS err/σ", "<(e/σ)²>"
        );
        for p in &self.params {
            let fmt = |v: f64| {
                if p.name.contains('r') && !p.name.contains('β') {
                    format!("{:.3} µm", v * 1e6)
                } else {
                    format!("{:.2e}", v)
                }
            };
            let _ = writeln!(
                o,
                "{:<10} {:>12} {:>12} {:>12} {:>10.2} {:>12.2} {:>10.2}",
                p.name,
                fmt(p.rms_error),
                fmt(p.worst_error),
                fmt(p.crlb),
                p.crlb_ratio,
                p.rms_normalized,
                p.chi2_mean
            );
        }
        let _ = writeln!(
            o,
            "(β, k relative; r absolute. Requirements: {:.0e} relative, {:.0} µm)",
            REQ_SCALE_FACTOR_REL,
            REQ_COM_M * 1e6
        );
        let _ = writeln!(
            o,
            "Mean (error/σ)² by group: β {:.2}, k {:.2}, r {:.2}",
            self.chi2_by_group[0], self.chi2_by_group[1], self.chi2_by_group[2]
        );
        let iv = &self.chi2_interval_by_group;
        let _ = writeln!(
            o,
            "  95 % interval of each mean over these seeds (bootstrap): β {:.2}–{:.2}, k {:.2}–{:.2}, r {:.2}–{:.2} (an honest σ puts 1 inside)",
            iv[0][0], iv[0][1], iv[1][0], iv[1][1], iv[2][0], iv[2][1]
        );
        let _ = writeln!(
            o,
            "Runs meeting every requirement: {} of {}; verified by the estimator: {} of {}; worst |err/σ| {:.2}",
            self.runs_meeting_requirements, self.runs, self.runs_verified, self.runs, self.worst_normalized
        );
        if let Some(f) = &self.faults {
            let _ = writeln!(
                o,
                "Faults over all runs: {}",
                crate::analysis::report::fault_line(f)
            );
        }
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng::{gauss, stream, Stream};

    #[test]
    fn a_seed_interval_of_equal_values_is_that_value() {
        assert_eq!(seed_interval(&[1.5; 7]), [1.5, 1.5]);
        assert!(seed_interval(&[]).iter().all(|x| x.is_nan()));
    }

    #[test]
    fn a_seed_interval_holds_the_mean_and_narrows_as_seeds_are_added() {
        // Honest errors: (err/σ)² of one standard normal per seed.
        let mut rng = stream(7, Stream::Priors);
        let z2: Vec<f64> = (0..1000).map(|_| gauss(&mut rng).powi(2)).collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let few = seed_interval(&z2[..30]);
        let many = seed_interval(&z2);
        for (iv, v) in [(few, &z2[..30]), (many, &z2[..])] {
            assert!(
                iv[0] < mean(v) && mean(v) < iv[1],
                "{iv:?} around {}",
                mean(v)
            );
        }
        // χ²₁'s mean over n seeds has σ √(2/n): a 95 % width of 1.01 at 30 seeds, 0.175 at 1000.
        let (w30, w1000) = (few[1] - few[0], many[1] - many[0]);
        assert!((0.5..1.6).contains(&w30), "{w30}");
        assert!((0.12..0.25).contains(&w1000), "{w1000}");
        assert!(many[0] < 1.0 && 1.0 < many[1], "{many:?}");
        assert_eq!(seed_interval(&z2), many, "its own fixed stream");
    }
}
