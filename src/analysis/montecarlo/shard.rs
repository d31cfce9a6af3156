//! Monte Carlo on a cluster. A shard runs every N-th seed of a campaign and writes one
//! result file per seed; `merge` checks that the files make up one whole campaign, run
//! by one build on one resolved scenario, and summarises them with the single-machine
//! code (`summarise`), so the statistics agree to the bit. File format: docs/report.md.

use super::{check_seeds, run_seeds, summarise, MonteCarlo, MonteCarloError};
use crate::analysis::report::Report;
use crate::sim::estimate::snapshot::fnv1a;
use crate::sim::estimate::Method;
use crate::sim::files::FileError;
use crate::sim::scenario::Scenario;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The `format` of a result file; a reader refuses any other.
pub const FORMAT: &str = "taiji-calib montecarlo run 1";

/// Shard `index` of `count` (`index` 0-based, as Slurm's `--array=0-(N-1)` numbers its
/// tasks): it runs seeds `first_seed + j` for the `j < runs` with `j % count == index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

/// How `--shard I/N` is written.
const FORM: &str = "I/N: shard I of N, I from 0 to N-1";

/// A `--shard` argument that is not `I/N` with `I < N`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardParseError {
    #[error("expected {FORM}, got {0:?}")]
    Form(String),
    /// `what` ("the shard index" or "the shard count") is not a whole number.
    #[error("{what} {value:?} is not a whole number ({FORM})")]
    NotANumber { what: &'static str, value: String },
    #[error("the shard count must be at least 1 ({FORM})")]
    NoShards,
    #[error("shard index {index} is not below the shard count {count} (I is 0-based: 0 to {})", count - 1)]
    IndexTooLarge { index: u64, count: u64 },
}

impl std::str::FromStr for Shard {
    type Err = ShardParseError;
    fn from_str(t: &str) -> Result<Self, ShardParseError> {
        let (i, n) = t
            .split_once('/')
            .ok_or_else(|| ShardParseError::Form(t.into()))?;
        let num = |v: &str, what: &'static str| {
            v.parse::<u64>().map_err(|_| ShardParseError::NotANumber {
                what,
                value: v.into(),
            })
        };
        let (index, count) = (num(i, "the shard index")?, num(n, "the shard count")?);
        if count == 0 {
            return Err(ShardParseError::NoShards);
        }
        if index >= count {
            return Err(ShardParseError::IndexTooLarge { index, count });
        }
        Ok(Shard { index, count })
    }
}

/// A result file's text that does not parse back into a [`RunFile`].
#[derive(Debug, thiserror::Error)]
pub enum RunFileError {
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// The `nonfinite` table is not a map of pointers to names.
    #[error("nonfinite: {0}")]
    Nonfinite(#[source] serde_json::Error),
    #[error("nonfinite: the report has no null at {pointer}")]
    NoNull { pointer: String },
    #[error("nonfinite: a value other than \"NaN\", \"-NaN\", \"inf\", \"-inf\", or a number the report does not have")]
    BadValue,
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// What makes results mergeable: the same resolved scenario, estimator, seeds and build.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Campaign {
    /// The scenario's `name`.
    pub scenario: String,
    /// FNV-1a (64 bit, hex) of the file's `scenario_toml`.
    pub scenario_hash: String,
    pub method: String,
    pub first_seed: u64,
    pub runs: u64,
    /// The program that ran the seed: its version and the FNV-1a of its executable.
    pub build: String,
}

impl Campaign {
    fn line(&self) -> String {
        format!(
            "scenario {:?} (hash {}), {} estimator, {} runs from seed {}, build {}",
            self.scenario, self.scenario_hash, self.method, self.runs, self.first_seed, self.build
        )
    }

    /// The keys in which `self` and `o` differ.
    fn differences(&self, o: &Campaign) -> Vec<&'static str> {
        let mut d = Vec::new();
        for (k, same) in [
            ("scenario", self.scenario == o.scenario),
            ("scenario_hash", self.scenario_hash == o.scenario_hash),
            ("method", self.method == o.method),
            ("first_seed", self.first_seed == o.first_seed),
            ("runs", self.runs == o.runs),
            ("build", self.build == o.build),
        ] {
            if !same {
                d.push(k);
            }
        }
        d
    }
}

/// One seed's result: `DIR/run-<seed>.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFile {
    pub format: String,
    pub campaign: Campaign,
    pub shard: Shard,
    pub seed: u64,
    /// The resolved scenario, planned maneuver included: what every shard must fly.
    pub scenario_toml: String,
    pub report: Report,
}

/// What a shard did: the seeds it ran, and those whose results it found already written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardDone {
    pub ran: Vec<u64>,
    pub kept: Vec<u64>,
}

/// This program: its version and the FNV-1a of its executable (~0.1 s to read), so
/// the results of two builds, which may differ in the last bit, are never merged.
pub fn build_id() -> Result<String, MonteCarloError> {
    let exe = std::env::current_exe()
        .and_then(std::fs::read)
        .map_err(MonteCarloError::BuildId)?;
    Ok(format!(
        "{} exe {:016x}",
        env!("CARGO_PKG_VERSION"),
        fnv1a(&exe)
    ))
}

fn hash(text: &str) -> String {
    format!("{:016x}", fnv1a(text.as_bytes()))
}

/// `run-<seed>.json`.
pub fn file_name(seed: u64) -> String {
    format!("run-{seed}.json")
}

/// Run `shard`'s seeds of the campaign and write `dir/run-<seed>.json` for each as it
/// ends. A seed whose file already holds this campaign's result is kept, not run again
/// (a re-run shard resumes); a file of another campaign is an error.
pub fn run_shard(
    s: &Scenario,
    first_seed: u64,
    runs: u64,
    method: Method,
    shard: Shard,
    build: &str,
    dir: &Path,
) -> Result<ShardDone, MonteCarloError> {
    check_seeds(first_seed, runs)?;
    if shard.count > runs {
        return Err(MonteCarloError::MoreShardsThanRuns { shard, runs });
    }
    let bound = super::campaign_bounds(s)?;
    let scenario_toml = toml::to_string(s).map_err(MonteCarloError::ScenarioToml)?;
    let campaign = Campaign {
        scenario: s.name.clone(),
        scenario_hash: hash(&scenario_toml),
        method: method.name().into(),
        first_seed,
        runs,
        build: build.into(),
    };
    let (mut todo, mut kept) = (Vec::new(), Vec::new());
    let mut j = shard.index;
    while j < runs {
        let seed = first_seed + j;
        let path = dir.join(file_name(seed));
        if path.exists() {
            let f = read_run_file(&path)?;
            let diff = f.campaign.differences(&campaign);
            if !diff.is_empty() {
                return Err(MonteCarloError::OtherCampaign {
                    path,
                    differences: diff,
                });
            }
            kept.push(seed);
        } else {
            todo.push(seed);
        }
        j = match j.checked_add(shard.count) {
            Some(v) => v,
            None => break,
        };
    }
    run_seeds(s, &todo, method, &bound, |report| {
        write_run_file(
            dir,
            &RunFile {
                format: FORMAT.into(),
                campaign: campaign.clone(),
                shard,
                seed: report.seed,
                scenario_toml: scenario_toml.clone(),
                report: report.clone(),
            },
        )
    })?;
    Ok(ShardDone { ran: todo, kept })
}

/// Write `f` as `dir/run-<seed>.json`, whole or not at all: to a hidden temporary
/// name, synced, then renamed, so a job killed mid-write leaves no result behind.
pub fn write_run_file(dir: &Path, f: &RunFile) -> Result<(), MonteCarloError> {
    use std::io::Write;
    let text = to_text(f).map_err(MonteCarloError::Json)?;
    // The file must give back exactly this report, every bit of every float; a float
    // field `floats` does not know holding NaN would not (JSON writes it as null).
    let back = parse(&text).ok().and_then(|b| to_text(&b).ok());
    if back.as_deref() != Some(text.as_str()) {
        return Err(MonteCarloError::NotExact { seed: f.seed });
    }
    let path = dir.join(file_name(f.seed));
    let tmp = dir.join(format!(".run-{}.json.{}.tmp", f.seed, std::process::id()));
    let written = std::fs::File::create(&tmp).and_then(|mut o| {
        o.write_all(text.as_bytes())?;
        o.sync_all()
    });
    written
        .and_then(|()| std::fs::rename(&tmp, &path))
        .map_err(|source| {
            let _ = std::fs::remove_file(&tmp);
            MonteCarloError::from(FileError::write(path, source))
        })
}

/// Every float of a report with its JSON pointer within the report.
fn floats(r: &mut Report, f: &mut dyn FnMut(String, &mut f64)) {
    f("/duration_s".into(), &mut r.duration_s);
    for (i, is) in r.inertial_sensors.iter_mut().enumerate() {
        let qs = [
            ("beta", &mut is.beta),
            ("k", &mut is.k),
            ("com_offset", &mut is.com_offset),
        ];
        for (name, q) in qs {
            let vs = [
                ("truth", &mut q.truth),
                ("estimate", &mut q.estimate),
                ("sigma", &mut q.sigma),
                ("crlb", &mut q.crlb),
            ];
            for (field, v) in vs {
                for (a, x) in v.iter_mut().enumerate() {
                    f(format!("/inertial_sensors/{i}/{name}/{field}/{a}"), x);
                }
            }
        }
    }
    let req = &mut r.requirements;
    f(
        "/requirements/scale_factor_rel".into(),
        &mut req.scale_factor_rel,
    );
    f("/requirements/com_offset_m".into(), &mut req.com_offset_m);
    if let Some(s) = &mut r.estimator_status {
        for (k, x) in s.chi2_per_dof.iter_mut() {
            let k = k.replace('~', "~0").replace('/', "~1");
            f(format!("/estimator_status/chi2_per_dof/{k}"), x);
        }
        f(
            "/estimator_status/sigma_inflation".into(),
            &mut s.sigma_inflation,
        );
    }
    if let Some(w) = &mut r.wall_time_s {
        f("/wall_time_s".into(), w);
    }
    if let Some(m) = &mut r.maneuver {
        for (a, x) in m.frequencies_hz.iter_mut().enumerate() {
            f(format!("/maneuver/frequencies_hz/{a}"), x);
        }
        for (a, x) in m.torque_amplitude_nm.iter_mut().enumerate() {
            f(format!("/maneuver/torque_amplitude_nm/{a}"), x);
        }
        for (k, x) in [
            ("start_phase", &mut m.start_phase),
            ("start_s", &mut m.start_s),
            ("peak_acceleration_m_s2", &mut m.peak_acceleration_m_s2),
            ("peak_attitude_rad", &mut m.peak_attitude_rad),
            ("peak_rate_rad_s", &mut m.peak_rate_rad_s),
            ("predicted_worst_ratio", &mut m.predicted_worst_ratio),
        ] {
            f(format!("/maneuver/{k}"), x);
        }
    }
}

/// `f` as the file's text: the report's NaN and infinities, which JSON writes as null,
/// are named in `nonfinite` (pointer → `"NaN"`, `"-NaN"`, `"inf"`, `"-inf"`).
fn to_text(f: &RunFile) -> Result<String, serde_json::Error> {
    #[derive(Serialize)]
    struct Text<'a> {
        #[serde(flatten)]
        f: &'a RunFile,
        #[serde(skip_serializing_if = "BTreeMap::is_empty")]
        nonfinite: BTreeMap<String, &'static str>,
    }
    let mut nonfinite = BTreeMap::new();
    floats(&mut f.report.clone(), &mut |p, x| {
        if !x.is_finite() {
            let v = match *x {
                x if x.is_nan() && x.is_sign_negative() => "-NaN",
                x if x.is_nan() => "NaN",
                x if x > 0.0 => "inf",
                _ => "-inf",
            };
            nonfinite.insert(p, v);
        }
    });
    serde_json::to_string_pretty(&Text { f, nonfinite })
}

/// The inverse of `to_text`.
fn parse(text: &str) -> Result<RunFile, RunFileError> {
    let mut v: serde_json::Value = serde_json::from_str(text)?;
    let nonfinite: BTreeMap<String, String> =
        match v.as_object_mut().and_then(|o| o.remove("nonfinite")) {
            Some(n) => serde_json::from_value(n).map_err(RunFileError::Nonfinite)?,
            None => BTreeMap::new(),
        };
    for p in nonfinite.keys() {
        match v.get_mut("report").and_then(|r| r.pointer_mut(p)) {
            Some(x) if x.is_null() => *x = 0.0.into(),
            _ => return Err(RunFileError::NoNull { pointer: p.clone() }),
        }
    }
    let mut f: RunFile = serde_json::from_value(v)?;
    let mut restored = 0;
    floats(&mut f.report, &mut |p, x| {
        if let Some(s) = nonfinite.get(&p) {
            *x = match s.as_str() {
                "NaN" => f64::NAN,
                "-NaN" => -f64::NAN,
                "inf" => f64::INFINITY,
                "-inf" => f64::NEG_INFINITY,
                _ => return,
            };
            restored += 1;
        }
    });
    if restored != nonfinite.len() {
        return Err(RunFileError::BadValue);
    }
    Ok(f)
}

/// Read and check one result file (its format, and that its name, seed and scenario
/// hash agree).
pub fn read_run_file(path: &Path) -> Result<RunFile, MonteCarloError> {
    let text = std::fs::read_to_string(path).map_err(|source| MonteCarloError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let path = path.to_path_buf();
    let f: RunFile = parse(&text).map_err(|source| {
        let format = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v.get("format").cloned());
        match format {
            Some(v) if v != FORMAT => MonteCarloError::OtherFormat {
                path: path.clone(),
                found: v.to_string(),
            },
            _ => MonteCarloError::NotResultFile {
                path: path.clone(),
                source,
            },
        }
    })?;
    if f.format != FORMAT {
        return Err(MonteCarloError::OtherFormat {
            path,
            found: format!("{:?}", f.format),
        });
    }
    let named = path.file_name().and_then(|n| n.to_str()).and_then(|n| {
        n.strip_prefix("run-")?
            .strip_suffix(".json")?
            .parse::<u64>()
            .ok()
    });
    if named != Some(f.seed) || f.report.seed != f.seed {
        return Err(MonteCarloError::SeedMismatch {
            path,
            seed: f.seed,
            report_seed: f.report.seed,
        });
    }
    if hash(&f.scenario_toml) != f.campaign.scenario_hash {
        return Err(MonteCarloError::Edited { path });
    }
    let c = &f.campaign;
    let j = f.seed.checked_sub(c.first_seed).filter(|&j| j < c.runs);
    if j.is_none() || f.shard.count == 0 || j.map(|j| j % f.shard.count) != Some(f.shard.index) {
        return Err(MonteCarloError::NotShardSeed {
            path,
            seed: f.seed,
            shard: f.shard,
            runs: c.runs,
            first_seed: c.first_seed,
        });
    }
    Ok(f)
}

/// `3, 7, 10-12`: sorted seeds as runs of consecutive values (at most 20 shown).
fn ranges(spans: &[(u64, u64)]) -> String {
    let mut parts: Vec<String> = spans
        .iter()
        .take(20)
        .map(|&(a, b)| match b - a {
            0 => a.to_string(),
            1 => format!("{a}, {b}"),
            _ => format!("{a}-{b}"),
        })
        .collect();
    if spans.len() > 20 {
        parts.push(format!("… ({} ranges in all)", spans.len()));
    }
    parts.join(", ")
}

/// Read every `run-<seed>.json` in `dirs`, check that they are one whole campaign —
/// the same campaign, every seed once — and summarise them as a single-machine run.
pub fn merge(dirs: &[PathBuf]) -> Result<MonteCarlo, MonteCarloError> {
    let mut files = read_result_files(dirs)?;
    let c = one_campaign(&files)?;
    every_seed_once(&files, &c)?;
    let n_is = files[0].1.report.inertial_sensors.len();
    if let Some((p, _)) = files
        .iter()
        .find(|(_, f)| f.report.inertial_sensors.len() != n_is || n_is == 0)
    {
        return Err(MonteCarloError::SensorCount { path: p.clone() });
    }
    // Seed order, as a single-machine run sums them.
    files.sort_by_key(|(_, f)| f.seed);
    let reports: Vec<Report> = files.into_iter().map(|(_, f)| f.report).collect();
    Ok(summarise(
        &c.scenario,
        n_is,
        c.first_seed,
        c.runs,
        &c.method,
        reports,
    ))
}

/// Every result file of `dirs`, read and checked, folder by folder in name order; a
/// folder without any is an error.
fn read_result_files(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, RunFile)>, MonteCarloError> {
    let mut files: Vec<(PathBuf, RunFile)> = Vec::new();
    for d in dirs {
        let entries = std::fs::read_dir(d).map_err(|source| MonteCarloError::ReadDir {
            path: d.clone(),
            source,
        })?;
        let mut paths: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("run-") && n.ends_with(".json"))
            })
            .collect();
        if paths.is_empty() {
            return Err(MonteCarloError::NoResults { path: d.clone() });
        }
        paths.sort();
        for p in paths {
            let f = read_run_file(&p)?;
            files.push((p, f));
        }
    }
    Ok(files)
}

/// The one campaign every file belongs to; the error lists the campaigns found.
fn one_campaign(files: &[(PathBuf, RunFile)]) -> Result<Campaign, MonteCarloError> {
    let mut campaigns: Vec<(&Campaign, &Path, usize)> = Vec::new();
    for (p, f) in files {
        match campaigns.iter_mut().find(|c| *c.0 == f.campaign) {
            Some(c) => c.2 += 1,
            None => campaigns.push((&f.campaign, p, 1)),
        }
    }
    if campaigns.len() > 1 {
        let mut e = format!(
            "the result files are of {} different campaigns (they differ in {}); merge one campaign at a time:",
            campaigns.len(),
            campaigns[0].0.differences(campaigns[1].0).join(", ")
        );
        for (c, p, n) in &campaigns {
            e += &format!("\n  {n} file(s) such as {}: {}", p.display(), c.line());
        }
        return Err(MonteCarloError::MixedCampaigns {
            campaigns: campaigns.len(),
            msg: e,
        });
    }
    Ok(campaigns[0].0.clone())
}

/// Every seed of campaign `c` has exactly one result; the error names the seeds with
/// several and those with none (files hold only seeds of the campaign).
fn every_seed_once(files: &[(PathBuf, RunFile)], c: &Campaign) -> Result<(), MonteCarloError> {
    let mut by_seed: BTreeMap<u64, Vec<usize>> = BTreeMap::new();
    for (i, (_, f)) in files.iter().enumerate() {
        by_seed.entry(f.seed).or_default().push(i);
    }
    let problems: Vec<String> = [duplicates(files, &by_seed), missing(files, &by_seed, c)]
        .into_iter()
        .flatten()
        .collect();
    if !problems.is_empty() {
        return Err(MonteCarloError::Incomplete { problems });
    }
    Ok(())
}

/// The seeds with more than one result, as the merge reports them.
fn duplicates(files: &[(PathBuf, RunFile)], by_seed: &BTreeMap<u64, Vec<usize>>) -> Option<String> {
    let dups: Vec<(&u64, &Vec<usize>)> = by_seed.iter().filter(|(_, v)| v.len() > 1).collect();
    if dups.is_empty() {
        return None;
    }
    let mut e = format!(
        "{} seed(s) have more than one result (never counted twice; remove the extra copies):",
        dups.len()
    );
    for (seed, v) in dups.iter().take(10) {
        let names: Vec<String> = v
            .iter()
            .map(|&i| files[i].0.display().to_string())
            .collect();
        e += &format!("\n  seed {seed}: {}", names.join(", "));
    }
    if dups.len() > 10 {
        e += &format!("\n  … and {} more seeds", dups.len() - 10);
    }
    Some(e)
}

/// The seeds of `c` with no result, and the shards short of results when every file
/// agrees on the shard count.
fn missing(
    files: &[(PathBuf, RunFile)],
    by_seed: &BTreeMap<u64, Vec<usize>>,
    c: &Campaign,
) -> Option<String> {
    // The gaps between the seeds present.
    let mut gaps = Vec::new();
    let mut next = c.first_seed;
    let last = c.first_seed.saturating_add(c.runs - 1);
    for &seed in by_seed.keys() {
        if seed > next {
            gaps.push((next, seed - 1));
        }
        next = seed.saturating_add(1);
    }
    if by_seed.keys().next_back().is_some_and(|&s| s < last) {
        gaps.push((next, last));
    }
    if gaps.is_empty() {
        return None;
    }
    let missing: u64 = gaps.iter().map(|(a, b)| b - a + 1).sum();
    let mut e = format!(
        "{missing} of {} seeds have no result: {}",
        c.runs,
        ranges(&gaps)
    );
    // Name the shards short of results, when every file agrees on the count.
    let count = files[0].1.shard.count;
    if missing <= 100_000 && files.iter().all(|(_, f)| f.shard.count == count) {
        let mut short: BTreeMap<u64, u64> = BTreeMap::new();
        for &(a, b) in &gaps {
            for seed in a..=b {
                *short.entry((seed - c.first_seed) % count).or_default() += 1;
            }
        }
        let lines: Vec<String> = short
            .iter()
            .map(|(&i, &n)| {
                // Shard i's seeds: the j < runs with j % count == i.
                let of = (c.runs - i).div_ceil(count);
                match n == of {
                    true => format!("shard {i}/{count} wrote none of its {of}"),
                    false => format!("shard {i}/{count} lacks {n} of its {of}"),
                }
            })
            .collect();
        e += &format!(
            "\n  {}: run them again with the same arguments (a re-run keeps the results already written)",
            lines.join("; ")
        );
    }
    Some(e)
}
