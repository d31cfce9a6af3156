//! The repository explains itself: no file points outside it, every key a run writes
//! and every scenario key is documented in `docs/`, and every relative link resolves.

mod support;
mod tmpdir;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
// The crate's paths this file uses, together so a move of modules changes only these.
use taiji::analysis::campaign::Threads;
use taiji::analysis::crlb::{crlb, maneuver_bound_on, Crlb};
use taiji::analysis::montecarlo;
use taiji::analysis::plan::{describe, min_duration, resolve};
use taiji::analysis::report::Report;
use taiji::runtime::process::supervisor::PLANNED_SCENARIO_FILE;
use taiji::sim::capi::{
    taiji_checkpoint_size, taiji_estimator_size, taiji_solve_work_size, TAIJI_ABI_VERSION,
};
use taiji::sim::estimate::Method;
use taiji::sim::scenario::Scenario;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The repository's files: git's list when this is a clone, else every file outside
/// build and output folders.
fn repository_files() -> Vec<PathBuf> {
    let git = Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(root())
        .output();
    if let Some(o) = git
        .ok()
        .filter(|o| o.status.success() && !o.stdout.is_empty())
    {
        return o
            .stdout
            .split(|b| *b == 0)
            .filter(|p| !p.is_empty())
            .map(|p| root().join(String::from_utf8_lossy(p).as_ref()))
            .filter(|p| p.is_file())
            .collect();
    }
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let p = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if p.is_dir() {
                if !(name == ".git" || name == "target" || name.starts_with("out")) {
                    walk(&p, out);
                }
            } else {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(root(), &mut out);
    out
}

#[test]
fn no_file_points_to_documents_outside_the_repository() {
    // Spelled in pieces so this file does not match itself.
    let needles = [
        ["SPEC", ".md"].concat(),
        ["..", "/shared"].concat(),
        ["SPEC", " §"].concat(),
    ];
    let files = repository_files();
    assert!(files.len() > 50, "only {} files found", files.len());
    let mut hits = Vec::new();
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        for n in &needles {
            if bytes.windows(n.len()).any(|w| w == n.as_bytes()) {
                hits.push(format!("{} mentions {n:?}", f.display()));
            }
        }
    }
    assert!(hits.is_empty(), "{}", hits.join("\n"));
}

/// Is `key` documented, i.e. written as `key` (in backticks) in the text?
fn undocumented<'a>(keys: impl IntoIterator<Item = &'a String>, doc: &str) -> Vec<String> {
    keys.into_iter()
        .filter(|k| !doc.contains(&format!("`{k}`")))
        .cloned()
        .collect()
}

fn object_keys(v: &Value) -> BTreeSet<String> {
    v.as_object()
        .unwrap_or_else(|| panic!("not an object: {v}"))
        .keys()
        .cloned()
        .collect()
}

/// Every key of `v`, its objects' and its arrays' first elements', recursively —
/// except inside maps keyed by data (causes, groups, processes, hops, fault kinds),
/// whose keys are listed in the text rather than as table rows.
fn all_keys(v: &Value, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                out.insert(k.clone());
                all_keys(x, out);
            }
        }
        Value::Array(a) => {
            if let Some(x) = a.first() {
                all_keys(x, out);
            }
        }
        _ => {}
    }
}

#[test]
fn every_key_of_a_default_runs_report_is_documented() {
    let dir = tmpdir::TmpDir::new("docs");
    let out = support::calib()
        .args(["run", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.join("report.json")).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    let doc = read("docs/report.md");
    let mut keys = BTreeSet::new();
    all_keys(&v, &mut keys);
    assert!(keys.contains("com_offset") && keys.contains("chi2_per_dof"));
    let missing = undocumented(&keys, &doc);
    assert!(missing.is_empty(), "docs/report.md lacks {missing:?}");

    // The keys that only some runs write (faults, timing, the process set's counters).
    let mut full: Report = serde_json::from_str(&text).unwrap();
    full.faults = Some(serde_json::json!({}));
    full.wall_time_s = Some(1.0);
    full.timing = Some(serde_json::json!({}));
    full.restarts = Some(serde_json::json!({}));
    full.estimator_loop_allocations = Some(0);
    let top = object_keys(&serde_json::to_value(&full).unwrap());
    assert!(top.len() > object_keys(&v).len());
    let missing = undocumented(&top, &doc);
    assert!(missing.is_empty(), "docs/report.md lacks {missing:?}");
}

#[test]
fn every_key_of_montecarlo_json_is_documented() {
    let s = Scenario::from_toml_str("name = \"short\"\nduration_s = 3000.0\n").unwrap();
    let mc = montecarlo::run(&s, 1, 1, Method::Joint).unwrap();
    let mut v = serde_json::to_value(&mc).unwrap();
    // The runs' reports are report.json's, checked above.
    v.as_object_mut().unwrap().remove("reports");
    let mut keys = BTreeSet::new();
    all_keys(&v, &mut keys);
    keys.insert("reports".into());
    assert!(keys.contains("crlb_ratio"));
    let missing = undocumented(&keys, &read("docs/report.md"));
    assert!(missing.is_empty(), "docs/report.md lacks {missing:?}");
}

#[test]
fn every_scenario_key_is_documented() {
    let mut s = Scenario::default();
    // Optional keys are left out of a serialised default: give them values.
    for is in &mut s.inertial_sensor {
        is.beta_prior = Some(is.beta);
        is.com_offset_prior_m = Some(is.com_offset_m);
    }
    let mut drift = taiji::sim::scenario::Drift::default();
    drift.step.push(taiji::sim::scenario::DriftStep::default());
    s.drift = Some(drift.clone());
    s.timeline = Some(Default::default());
    let v = toml::Value::try_from(&s).unwrap();
    // The steps' own keys, under their heading.
    let doc = read("docs/scenario.md");
    assert!(doc.contains("`[[drift.step]]`"));
    let step = toml::Value::try_from(&drift.step[0]).unwrap();
    for f in step.as_table().unwrap().keys() {
        assert!(
            doc.contains(&format!("`{f}`")),
            "docs/scenario.md lacks drift.step.{f}"
        );
    }
    let doc = read("docs/scenario.md");
    let mut missing = Vec::new();
    let table = v.as_table().unwrap();
    for (k, x) in table {
        let (heading, fields) = match x {
            toml::Value::Table(t) => (format!("`[{k}]`"), Some(t)),
            toml::Value::Array(a) if a.first().is_some_and(|e| e.is_table()) => {
                (format!("`[[{k}]]`"), a[0].as_table())
            }
            _ => (format!("`{k}`"), None),
        };
        if !doc.contains(&heading) {
            missing.push(heading);
        }
        for f in fields.into_iter().flat_map(|t| t.keys()) {
            if !doc.contains(&format!("`{f}`")) {
                missing.push(format!("{k}.{f}"));
            }
        }
    }
    assert!(table.len() >= 12, "{table:?}");
    assert!(missing.is_empty(), "docs/scenario.md lacks {missing:?}");
}

/// GitHub's heading anchor: lower case, punctuation dropped, spaces to hyphens.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(markdown: &str) -> BTreeSet<String> {
    let mut in_code = false;
    let mut out = BTreeSet::new();
    for line in markdown.lines() {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            out.insert(slug(line.trim_start_matches('#')));
        }
    }
    out
}

#[test]
fn every_relative_link_of_the_readme_and_docs_resolves() {
    let mut pages = vec!["README.md".to_string()];
    for e in std::fs::read_dir(root().join("docs")).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.ends_with(".md") {
            pages.push(format!("docs/{name}"));
        }
    }
    assert!(pages.len() >= 6, "{pages:?}");
    let mut broken = Vec::new();
    for page in &pages {
        let text = read(page);
        let base = root().join(page);
        let dir = base.parent().unwrap();
        for (i, _) in text.match_indices("](") {
            let rest = &text[i + 2..];
            let Some(end) = rest.find(')') else { continue };
            let target = &rest[..end];
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
            let path = if file.is_empty() {
                base.clone()
            } else {
                dir.join(file)
            };
            if !path.exists() {
                broken.push(format!("{page}: {target} (no such file)"));
                continue;
            }
            if !anchor.is_empty() {
                let md = std::fs::read_to_string(&path).unwrap_or_default();
                if !anchors(&md).contains(anchor) {
                    broken.push(format!("{page}: {target} (no such heading)"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

/// Two significant digits, as the docs quote bounds (0.85, 0.017).
fn sig2(x: f64) -> String {
    let decimals = (1 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$}")
}

/// β's bound as "lo–hi×10⁻⁶" (relative, over every IS and axis) and r's worst per axis
/// as "x / y / z µm".
fn bound_numbers(s: &Scenario, c: &Crlb) -> (String, String) {
    let mut beta = Vec::new();
    let mut r_um = [0.0f64; 3];
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        for a in 0..3 {
            beta.push(c.beta[i][a] / is.beta[a]);
            r_um[a] = r_um[a].max(c.com_offset_m[i][a] * 1e6);
        }
    }
    let (lo, hi) = beta
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), b| (l.min(*b), h.max(*b)));
    let r: Vec<String> = r_um.iter().map(|x| sig2(*x)).collect();
    (
        format!("{:.1}–{:.1}×10⁻⁶", lo * 1e6, hi * 1e6),
        format!("{} µm", r.join(" / ")),
    )
}

/// `x` as "m×10ⁿ" with `digits` decimals of the mantissa (5.5×10⁻⁴).
fn sci(x: f64, digits: usize) -> String {
    let e = x.abs().log10().floor() as i32;
    format!("{:.digits$}×10{}", x / 10f64.powi(e), superscript(e))
}

fn superscript(e: i32) -> String {
    let digits = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let sign = if e < 0 { "⁻" } else { "" };
    let n: String = e
        .unsigned_abs()
        .to_string()
        .chars()
        .map(|c| digits[c.to_digit(10).unwrap_or(0) as usize])
        .collect();
    format!("{sign}{n}")
}

/// A size in bytes as the docs write it: "62 848 B".
fn bytes(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    format!("{out} B")
}

/// What each computed number is and what computes it: the rows of docs/validation.md's
/// "Deterministic figures" (`print_deterministic_figures`), one per name of
/// `computed_numbers`.
const FIGURES: &[(&str, &str, &str)] = &[
    (
        "crlb-beta",
        "CRLB of β (= k), relative, every IS and axis: the run at the scenario's seed",
        "`taiji-calib crlb`",
    ),
    (
        "crlb-r",
        "CRLB of r, the worst IS per axis x / y / z: the run at the scenario's seed",
        "`taiji-calib crlb`",
    ),
    (
        "maneuver-crlb-beta",
        "CRLB of β (= k), relative: the planned maneuver alone, at the planner's rate",
        "`taiji-calib crlb`",
    ),
    (
        "maneuver-crlb-r",
        "CRLB of r per axis: the planned maneuver alone, at the planner's rate",
        "`taiji-calib crlb`",
    ),
    (
        "crlb-worst",
        "the planned maneuver's worst CRLB / requirement (search bound)",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-worst-parameter",
        "the parameter with that worst ratio",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-schedule",
        "planned maneuver: schedule (axis order)",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-frequency",
        "planned maneuver: frequency",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-torque",
        "planned maneuver: torque amplitude per axis",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-periods",
        "planned maneuver: periods per axis",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-attitude",
        "planned maneuver: peak attitude",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-binding",
        "what binds the planned torque",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-candidates",
        "candidates a run's plan searches (`taiji-calib plan` adds an amplitude sweep)",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-best-sequential",
        "best worst ratio of a sequential schedule (search bound)",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "plan-best-simultaneous",
        "best worst ratio of a simultaneous schedule (search bound)",
        "`taiji-calib run`'s plan (report.json `maneuver`)",
    ),
    (
        "min-duration",
        "shortest window meeting every requirement with margin 3 on the bound",
        "`taiji-calib plan --min-duration`",
    ),
    (
        "min-duration-schedule",
        "that window's schedule",
        "`taiji-calib plan --min-duration`",
    ),
    (
        "min-duration-slow",
        "that window's slowest axis frequency",
        "`taiji-calib plan --min-duration`",
    ),
    (
        "state-bytes",
        "the flight core's state (the C library's `mem`)",
        "`taiji_estimator_size()`",
    ),
    (
        "checkpoint-bytes",
        "a checkpoint of it",
        "`taiji_checkpoint_size()`",
    ),
    (
        "scratch-bytes",
        "the solve's scratch, the caller's",
        "`taiji_solve_work_size()`",
    ),
    ("abi-version", "the C ABI's version", "`TAIJI_ABI_VERSION`"),
];

/// The numbers the docs quote that a command computes deterministically, by anchor
/// name: `<!--n:NAME-->value<!--/n-->` in a .md file must read `value`. Computed here
/// through the library calls `plan`, `plan --min-duration` and `crlb` make and the C
/// ABI's size functions, so a change of the model, planner, defaults or state fails
/// this test until the docs say the new number.
fn computed_numbers() -> std::collections::BTreeMap<&'static str, String> {
    let s = Scenario::load_or_default(None).unwrap();
    let shortest = min_duration(&s, 3.0).unwrap();
    let (planned, info) = resolve(s).unwrap();
    let info = info.expect("the default scenario is planned");
    // The run's bound at the scenario's seed (`crlb`), and the maneuver's alone at the
    // scenario's rate (the planner's tables).
    let run = crlb(&planned).unwrap();
    let maneuver = maneuver_bound_on(&planned, Threads::available()).unwrap();
    let (beta, r) = bound_numbers(&planned, &run);
    let (beta_m, r_m) = bound_numbers(&planned, &maneuver);
    let m = describe(&planned, Some(&run), Some(&info));
    let axes: Vec<String> = m.axis_order.chars().map(String::from).collect();
    let schedule = if m.schedule == "sequential" {
        format!("{} ({})", m.schedule, axes.join(", "))
    } else {
        m.schedule.clone()
    };
    let torque_exp = m
        .torque_amplitude_nm
        .iter()
        .fold(0.0f64, |a, t| a.max(t.abs()))
        .log10()
        .floor() as i32;
    let torque: Vec<String> = m
        .torque_amplitude_nm
        .iter()
        .map(|t| format!("{:.2}", t / 10f64.powi(torque_exp)))
        .collect();
    let periods: Vec<String> = m.periods.iter().map(u64::to_string).collect();
    let best = |name: &str| {
        info.best_by_schedule
            .iter()
            .find(|(s, _)| s == name)
            .map_or("—".to_string(), |(_, r)| sig2(*r))
    };
    [
        ("min-duration", format!("{} s", shortest.duration_s)),
        (
            "min-duration-slow",
            format!("{:.2} mHz", shortest.chosen.maneuver.frequency_hz * 1e3),
        ),
        (
            "min-duration-schedule",
            shortest.chosen.maneuver.schedule.name().to_string(),
        ),
        ("crlb-beta", beta),
        ("crlb-r", r),
        ("maneuver-crlb-beta", beta_m),
        ("maneuver-crlb-r", r_m),
        ("crlb-worst", sig2(info.worst_ratio)),
        ("plan-worst-parameter", info.worst_parameter.clone()),
        ("plan-schedule", schedule),
        (
            "plan-frequency",
            format!("{} mHz", sig2(planned.maneuver.frequency_hz * 1e3)),
        ),
        (
            "plan-torque",
            format!("[{}]×10{} N m", torque.join(", "), superscript(torque_exp)),
        ),
        ("plan-periods", periods.join(" / ")),
        (
            "plan-attitude",
            format!("{} rad", sci(m.peak_attitude_rad, 1)),
        ),
        ("plan-binding", info.binding.clone()),
        ("plan-candidates", info.candidates.to_string()),
        ("plan-best-sequential", best("sequential")),
        ("plan-best-simultaneous", best("simultaneous")),
        ("state-bytes", bytes(taiji_estimator_size())),
        ("checkpoint-bytes", bytes(taiji_checkpoint_size())),
        ("scratch-bytes", bytes(taiji_solve_work_size())),
        ("abi-version", TAIJI_ABI_VERSION.to_string()),
    ]
    .into_iter()
    .collect()
}

/// docs/validation.md's "Deterministic figures" table, printed for `tools/validate`
/// (`cargo test --release --test docs -- --ignored --exact print_deterministic_figures
/// --nocapture`): the rows begin with "| ".
#[test]
#[ignore = "run by tools/validate"]
fn print_deterministic_figures() {
    let want = computed_numbers();
    println!("| figure | value | computed by |");
    println!("|---|---|---|");
    for (name, what, by) in FIGURES {
        let value = want.get(name).expect("FIGURES names only computed numbers");
        println!("| {what} | <!--n:{name}-->{value}<!--/n--> | {by} |");
    }
}

/// The text of `heading`'s section (up to the next `## `) in `page`.
fn section<'a>(page: &'a str, heading: &str) -> &'a str {
    let start = page
        .find(&format!("\n{heading}\n"))
        .unwrap_or_else(|| panic!("no section {heading:?}"));
    let body = &page[start + heading.len() + 2..];
    body.find("\n## ").map_or(body, |end| &body[..end])
}

/// Every computed number has a row in docs/validation.md's deterministic section, and
/// every row there is a computed number (`tools/validate` writes them from `FIGURES`).
#[test]
fn every_computed_number_is_in_the_validation_reports_deterministic_figures() {
    let want = computed_numbers();
    let names: BTreeSet<&str> = FIGURES.iter().map(|f| f.0).collect();
    let computed: BTreeSet<&str> = want.keys().copied().collect();
    assert_eq!(
        names, computed,
        "FIGURES and computed_numbers name different figures"
    );
    let page = read("docs/validation.md");
    let table = section(&page, "## Deterministic figures");
    let missing: Vec<_> = names
        .iter()
        .filter(|n| !table.contains(&format!("<!--n:{n}-->")))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/validation.md's deterministic figures lack {missing:?}: run tools/validate --quick"
    );
}

#[test]
fn every_computed_number_in_the_docs_is_what_its_command_prints_now() {
    let want = computed_numbers();
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut stale = Vec::new();
    let docs = repository_files()
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "md"));
    for path in docs {
        let text = std::fs::read_to_string(&path).unwrap();
        let rel = path.strip_prefix(root()).unwrap().display().to_string();
        for (at, _) in text.match_indices("<!--n:") {
            let rest = &text[at + 6..];
            let (name, rest) = rest.split_once("-->").expect("an unclosed anchor");
            let (value, _) = rest
                .split_once("<!--/n-->")
                .unwrap_or_else(|| panic!("{rel}: anchor {name} without <!--/n-->"));
            let Some(w) = want.get(name) else {
                panic!("{rel}: anchor {name:?} names no computed number (tests/docs.rs)");
            };
            seen.insert(name.to_string());
            if value != w {
                stale.push(format!(
                    "{rel}: {name} says {value:?}, the command gives {w:?}"
                ));
            }
        }
    }
    assert!(
        stale.is_empty(),
        "stale numbers in the docs:\n{}",
        stale.join("\n")
    );
    let unused: Vec<_> = want.keys().filter(|k| !seen.contains(**k)).collect();
    assert!(unused.is_empty(), "computed but quoted nowhere: {unused:?}");
}

/// Every file a run writes into its folder has a row in docs/report.md's table of files
/// (`scenario.toml` was missing): the names as the code spells them.
#[test]
fn every_file_of_a_run_folder_is_in_the_table_of_report_md() {
    let text = read("docs/report.md");
    for f in [
        "report.json",
        "report.md",
        "report.html",
        "telemetry.h5",
        "plots/",
        PLANNED_SCENARIO_FILE,
        "estimator_table.json",
        "montecarlo.json",
    ] {
        assert!(
            text.contains(&format!("| `{f}` |")),
            "docs/report.md: no row for {f}"
        );
    }
}
