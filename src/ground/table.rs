//! The onboard calibration table: per IS, group (β, k, r) and axis the trend of the
//! applied campaigns' results (`sim::trend`, the timeline's: value, rate
//! per day, their covariance, the epoch of the last result and the drift model), whose
//! prediction for a campaign's epoch is that campaign's priors
//! (`Scenario::with_onboard_priors`); the values at the last apply's epoch (what 20,2
//! reports); the campaign whose result it holds; and the table before it (function 4
//! restores it).
//!
//! It is kept in a folder, in `calibration-table.json`, a JSON object
//! `{"table": {...}, "sha256": "..."}` whose `sha256` is the SHA-256 (hex) of `table`
//! printed compact (`serde_json`'s canonical form of the parsed value); `table` holds
//! `version` (2), `current` (the table, or null for none), `can_restore` and
//! `previous` (what function 4 brings back; null for "no table"). Each table is
//! `campaign`, six 2×3 arrays in `TableValues`' units: `beta`, `beta_sigma`, `k`,
//! `k_sigma`, `r`, `r_sigma` (the values at the last apply's epoch: each trend's value
//! and σ there), and `trends`: per IS (2), group (β, k, r) and axis, null (no trend: an
//! IS the scenario lacks) or `epoch_day`, `value`, `rate` [per day], `p` (the 2×2
//! covariance of value and rate), `walk_per_day` and `rate_sigma` (the drift model).
//! Version 1 files (no `trends`) are read: their tables hold their values at every
//! epoch, and the next apply starts the trends from its result (`trends` null).
//!
//! Every write is atomic (a temporary file, synced, renamed over the file, the folder
//! synced), then the same bytes go the same way to `calibration-table.json.bak`, the
//! last good copy. A main file that is unreadable, fails its checksum or does not
//! decode is refused and the copy is used (`LoadProblem::MainBad`); both refused, no
//! table (`LoadProblem::BothBad`). No bytes make it panic.

use super::dictionary::Failure;
use crate::sim::msg::TableValues;
use crate::sim::trend::{self, Trend, TrendModel, Trends};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::{Read as _, Write as _};
use std::path::{Path, PathBuf};

/// The table's file in the store's folder.
pub const TABLE_FILE: &str = "calibration-table.json";
/// Its last good copy, beside it.
pub const BACKUP_FILE: &str = "calibration-table.json.bak";
/// The file format's version (`table.version`); version 1 files are read too.
pub const FORMAT_VERSION: u32 = 2;
/// The version without trends.
const FORMAT_VERSION_1: u32 = 1;
/// A larger file is refused unread (a table and its previous one with trends: ~25 kB).
const MAX_FILE_BYTES: u64 = 64 * 1024;

/// A table and the campaign whose result it holds (1, 2, …).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    pub campaign: u32,
    /// The values at the last apply's epoch (each trend's value and σ there).
    pub values: TableValues,
    /// The trends; `None`: a version 1 table, its values at every epoch.
    pub trends: Option<Trends>,
}

impl Entry {
    /// The table of `trends` after campaign `campaign`'s result.
    pub fn from_trends(campaign: u32, trends: Trends) -> Entry {
        Entry {
            campaign,
            values: trend::at_epochs(&trends),
            trends: Some(trends),
        }
    }

    /// A table of values alone (as version 1 held them): the same at every epoch.
    pub fn values_only(campaign: u32, values: TableValues) -> Entry {
        Entry {
            campaign,
            values,
            trends: None,
        }
    }

    /// The priors of a campaign that starts on mission day `day`: the trends'
    /// prediction for it (`trend::predicted`), or the values of a table without trends.
    pub fn at(&self, day: f64) -> TableValues {
        match &self.trends {
            Some(t) => trend::predicted(t, day),
            None => self.values,
        }
    }
}

/// What the store holds: the table in use and what function 4 would bring back
/// (`Some(None)`: "no table", after the first apply).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct State {
    current: Option<Entry>,
    previous: Option<Option<Entry>>,
}

/// Why the main file was not used on opening (the supervisor's event 9, `copy`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LoadProblem {
    #[error("calibration table {} refused ({why}): its last good copy {} is used", main.display(), backup.display())]
    MainBad {
        main: PathBuf,
        backup: PathBuf,
        why: String,
    },
    #[error("calibration table {} refused ({why_main}) and its last good copy too ({why_backup}): no table", main.display())]
    BothBad {
        main: PathBuf,
        why_main: String,
        why_backup: String,
    },
}

impl LoadProblem {
    /// Event 9's `copy`: 1 the main file bad, the copy used; 2 both bad, no table.
    pub fn copy(&self) -> u8 {
        match self {
            LoadProblem::MainBad { .. } => 1,
            LoadProblem::BothBad { .. } => 2,
        }
    }
}

/// Why the table was not changed.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    #[error("no previous table to restore")]
    NothingToRestore,
    #[error("calibration table {}: {source}: not applied", path.display())]
    NotSaved {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("a table value is not finite, or the campaign number is 0: not applied")]
    Invalid,
}

impl TableError {
    /// The failure code of the telecommand it refuses.
    pub fn failure(&self) -> Failure {
        Failure::from(self)
    }
}

impl From<&TableError> for Failure {
    fn from(e: &TableError) -> Failure {
        match e {
            TableError::NothingToRestore => Failure::NothingToRestore,
            TableError::NotSaved { .. } => Failure::TableNotSaved,
            TableError::Invalid => Failure::OutOfRange,
        }
    }
}

/// The calibration table kept in a folder.
#[derive(Debug)]
pub struct TableStore {
    dir: PathBuf,
    state: State,
}

/// One table as the file writes it (version 1: no `trends`).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryFile {
    campaign: u32,
    beta: [[f64; 3]; 2],
    beta_sigma: [[f64; 3]; 2],
    k: [[f64; 3]; 2],
    k_sigma: [[f64; 3]; 2],
    r: [[f64; 3]; 2],
    r_sigma: [[f64; 3]; 2],
    #[serde(default)]
    trends: Option<[[[Option<TrendFile>; 3]; 3]; 2]>,
}

/// One parameter's trend as the file writes it.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TrendFile {
    epoch_day: f64,
    value: f64,
    rate: f64,
    p: [[f64; 2]; 2],
    walk_per_day: f64,
    rate_sigma: f64,
}

impl From<&Trend> for TrendFile {
    fn from(t: &Trend) -> TrendFile {
        TrendFile {
            epoch_day: t.epoch_day,
            value: t.value,
            rate: t.rate,
            p: t.p,
            walk_per_day: t.model.walk_per_day,
            rate_sigma: t.model.rate_sigma,
        }
    }
}

impl From<TrendFile> for Trend {
    fn from(t: TrendFile) -> Trend {
        Trend {
            epoch_day: t.epoch_day,
            value: t.value,
            rate: t.rate,
            p: t.p,
            model: TrendModel {
                walk_per_day: t.walk_per_day,
                rate_sigma: t.rate_sigma,
            },
        }
    }
}

/// The checksummed part of the file.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Body {
    version: u32,
    current: Option<EntryFile>,
    can_restore: bool,
    previous: Option<EntryFile>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    table: serde_json::Value,
    sha256: String,
}

impl From<&Entry> for EntryFile {
    fn from(e: &Entry) -> EntryFile {
        let v = &e.values;
        EntryFile {
            campaign: e.campaign,
            beta: v.beta,
            beta_sigma: v.beta_sigma,
            k: v.k,
            k_sigma: v.k_sigma,
            r: v.r,
            r_sigma: v.r_sigma,
            trends: e
                .trends
                .map(|t| t.map(|tg| tg.map(|ta| ta.map(|t| t.as_ref().map(TrendFile::from))))),
        }
    }
}

impl From<EntryFile> for Entry {
    fn from(e: EntryFile) -> Entry {
        Entry {
            campaign: e.campaign,
            values: TableValues {
                beta: e.beta,
                beta_sigma: e.beta_sigma,
                k: e.k,
                k_sigma: e.k_sigma,
                r: e.r,
                r_sigma: e.r_sigma,
            },
            trends: e
                .trends
                .map(|t| t.map(|tg| tg.map(|ta| ta.map(|t| t.map(Trend::from))))),
        }
    }
}

/// Every value finite, the campaign numbered (from 1), and with trends the values
/// theirs at their epochs.
fn valid(e: &Entry) -> bool {
    let v = &e.values;
    let finite = |t: &Trend| {
        [
            t.epoch_day,
            t.value,
            t.rate,
            t.model.walk_per_day,
            t.model.rate_sigma,
        ]
        .iter()
        .chain(t.p.iter().flatten())
        .all(|x| x.is_finite())
    };
    e.campaign != 0
        && [v.beta, v.beta_sigma, v.k, v.k_sigma, v.r, v.r_sigma]
            .iter()
            .flatten()
            .flatten()
            .all(|x| x.is_finite())
        && e.trends.as_ref().is_none_or(|t| {
            t.iter().flatten().flatten().flatten().all(finite) && trend::at_epochs(t) == *v
        })
}

fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The file's bytes for `s`.
fn encode(s: &State) -> Vec<u8> {
    let body = Body {
        version: FORMAT_VERSION,
        current: s.current.as_ref().map(EntryFile::from),
        can_restore: s.previous.is_some(),
        previous: s.previous.flatten().as_ref().map(EntryFile::from),
    };
    // Finite values only (`valid`): nothing here can fail.
    let table = serde_json::to_value(&body).unwrap_or_default();
    let sha256 = sha256_hex(&serde_json::to_vec(&table).unwrap_or_default());
    let text = serde_json::to_string_pretty(&File { table, sha256 }).unwrap_or_default();
    (text + "\n").into_bytes()
}

/// What a file's bytes hold, or why they are refused.
fn decode(bytes: &[u8]) -> Result<State, String> {
    let f: File = serde_json::from_slice(bytes).map_err(|e| format!("not a table file: {e}"))?;
    let canonical = serde_json::to_vec(&f.table).map_err(|e| e.to_string())?;
    if !sha256_hex(&canonical).eq_ignore_ascii_case(&f.sha256) {
        return Err("checksum mismatch".into());
    }
    let body: Body =
        serde_json::from_value(f.table).map_err(|e| format!("not a table file: {e}"))?;
    if body.version != FORMAT_VERSION && body.version != FORMAT_VERSION_1 {
        return Err(format!("format version {} unknown", body.version));
    }
    let with_trends = |e: &Option<EntryFile>| e.as_ref().is_some_and(|e| e.trends.is_some());
    if body.version == FORMAT_VERSION_1
        && (with_trends(&body.current) || with_trends(&body.previous))
    {
        return Err("trends in a version 1 table".into());
    }
    if !body.can_restore && body.previous.is_some() {
        return Err("a previous table that cannot be restored".into());
    }
    let current = body.current.map(Entry::from);
    let previous = body.previous.map(Entry::from);
    if !current.iter().chain(previous.iter()).all(valid) {
        return Err(
            "a value not finite, a campaign numbered 0, or values not their trends'".into(),
        );
    }
    Ok(State {
        current,
        previous: body.can_restore.then_some(previous),
    })
}

/// The state in `path`: `None` when there is no file; why it is refused otherwise.
fn read(path: &Path) -> Result<Option<State>, String> {
    let f = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("unreadable: {e}")),
    };
    let mut bytes = Vec::new();
    f.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("unreadable: {e}"))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(format!("larger than {MAX_FILE_BYTES} bytes"));
    }
    decode(&bytes).map(Some)
}

/// Writes `bytes` to `dir/name` atomically: a temporary file `name.tmp`, synced,
/// renamed over it, the folder synced. On an error the temporary file is removed.
fn write_atomic(dir: &Path, name: &str, bytes: &[u8]) -> std::io::Result<()> {
    use std::os::unix::fs::OpenOptionsExt as _;
    let path = dir.join(name);
    let tmp = dir.join(format!("{name}.tmp"));
    let r = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .mode(0o644)
            .open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, &path)?;
        std::fs::File::open(dir)?.sync_all()
    })();
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}

impl TableStore {
    /// The table kept in `dir` (created if missing). No file: no table, no problem. A
    /// main file that is refused: the last good copy, and `MainBad`; both refused (or
    /// the copy missing): no table, and `BothBad`.
    pub fn open(dir: &Path) -> (TableStore, Option<LoadProblem>) {
        let _ = std::fs::create_dir_all(dir);
        let mut store = TableStore {
            dir: dir.to_path_buf(),
            state: State::default(),
        };
        let (main, backup) = (store.path(), dir.join(BACKUP_FILE));
        let why_main = match read(&main) {
            Ok(Some(s)) => {
                store.state = s;
                return (store, None);
            }
            Ok(None) => match read(&backup) {
                // Never written.
                Ok(None) => return (store, None),
                _ => "missing, though its copy is there".to_string(),
            },
            Err(why) => why,
        };
        let problem = match read(&backup) {
            Ok(Some(s)) => {
                store.state = s;
                LoadProblem::MainBad {
                    main,
                    backup,
                    why: why_main,
                }
            }
            Ok(None) => LoadProblem::BothBad {
                main,
                why_main,
                why_backup: "missing".into(),
            },
            Err(why_backup) => LoadProblem::BothBad {
                main,
                why_main,
                why_backup,
            },
        };
        (store, Some(problem))
    }

    /// The main file's path.
    pub fn path(&self) -> PathBuf {
        self.dir.join(TABLE_FILE)
    }

    /// The table in use (its values at the last apply's epoch) and the campaign whose
    /// result it holds.
    pub fn current(&self) -> Option<(TableValues, u32)> {
        self.state.current.map(|e| (e.values, e.campaign))
    }

    /// The table in use, trends included.
    pub fn entry(&self) -> Option<&Entry> {
        self.state.current.as_ref()
    }

    /// Whether function 4 has a previous table to bring back ("no table" included).
    pub fn can_restore(&self) -> bool {
        self.state.previous.is_some()
    }

    /// Makes `e` (the table after a campaign's result) the table, the table in use the
    /// previous one. Kept on disk before it counts: on an error nothing changed.
    pub fn apply(&mut self, e: Entry) -> Result<(), TableError> {
        if !valid(&e) {
            return Err(TableError::Invalid);
        }
        self.commit(State {
            current: Some(e),
            previous: Some(self.state.current),
        })
    }

    /// Brings the previous table back (one step: afterwards there is none to restore);
    /// the campaign whose result the table now holds, 0 for "no table".
    pub fn restore(&mut self) -> Result<u32, TableError> {
        let prev = self.state.previous.ok_or(TableError::NothingToRestore)?;
        self.commit(State {
            current: prev,
            previous: None,
        })?;
        Ok(prev.map_or(0, |e| e.campaign))
    }

    /// Writes `next` to the main file, then (it counts from then on) to the copy.
    fn commit(&mut self, next: State) -> Result<(), TableError> {
        let bytes = encode(&next);
        write_atomic(&self.dir, TABLE_FILE, &bytes).map_err(|source| TableError::NotSaved {
            path: self.path(),
            source,
        })?;
        self.state = next;
        if let Err(e) = write_atomic(&self.dir, BACKUP_FILE, &bytes) {
            // The table is kept (the main file holds it); only its copy is stale.
            log::warn!(
                "calibration table's last good copy {} not written: {e}",
                self.dir.join(BACKUP_FILE).display()
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("taiji-table-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// A table whose every value differs, from `x`.
    fn values(x: f64) -> TableValues {
        let m = |o: f64| {
            std::array::from_fn(|i| {
                std::array::from_fn(|a| x * (1.0 + o) + (3 * i + a) as f64 * 1e-9)
            })
        };
        TableValues {
            beta: m(0.0),
            beta_sigma: m(0.1),
            k: m(0.2),
            k_sigma: m(0.3),
            r: m(-0.4),
            r_sigma: m(0.5),
        }
    }

    fn bits(v: &TableValues) -> Vec<u64> {
        [v.beta, v.beta_sigma, v.k, v.k_sigma, v.r, v.r_sigma]
            .iter()
            .flatten()
            .flatten()
            .map(|x| x.to_bits())
            .collect()
    }

    fn files(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_table_survives_a_restart_bit_for_bit_and_leaves_no_temporary_file() {
        let d = dir("roundtrip");
        let (mut t, p) = TableStore::open(&d);
        assert_eq!(p, None);
        assert_eq!(t.current(), None);
        assert!(!t.can_restore());
        let a = values(5.52143e-8 / 3.0);
        t.apply(Entry::values_only(1, a)).unwrap();
        assert_eq!(files(&d), [TABLE_FILE, BACKUP_FILE]);
        let b = values(0.1 / 7.0);
        t.apply(Entry::values_only(4, b)).unwrap();
        assert_eq!(files(&d), [TABLE_FILE, BACKUP_FILE]);
        drop(t);
        let (mut t, p) = TableStore::open(&d);
        assert_eq!(p, None);
        let (v, c) = t.current().unwrap();
        assert_eq!((bits(&v), c), (bits(&b), 4));
        assert!(t.can_restore());
        // The copy holds the same table.
        assert_eq!(
            std::fs::read(d.join(TABLE_FILE)).unwrap(),
            std::fs::read(d.join(BACKUP_FILE)).unwrap()
        );
        assert_eq!(t.restore().unwrap(), 1);
        let (v, c) = t.current().unwrap();
        assert_eq!((bits(&v), c), (bits(&a), 1));
        assert!(!t.can_restore());
        assert!(matches!(t.restore(), Err(TableError::NothingToRestore)));
        drop(t);
        let (t, _) = TableStore::open(&d);
        assert_eq!(t.current().map(|(_, c)| c), Some(1));
        assert!(!t.can_restore());
        assert_eq!(files(&d), [TABLE_FILE, BACKUP_FILE]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn restoring_the_first_table_leaves_none_and_an_empty_store_has_nothing_to_restore() {
        let d = dir("restore");
        let (mut t, _) = TableStore::open(&d);
        let e = t.restore().unwrap_err();
        assert!(matches!(e, TableError::NothingToRestore));
        assert_eq!(e.failure(), Failure::NothingToRestore);
        assert!(
            !d.join(TABLE_FILE).exists(),
            "a refused restore writes nothing"
        );
        t.apply(Entry::values_only(1, values(1.0))).unwrap();
        assert!(t.can_restore());
        assert_eq!(t.restore().unwrap(), 0);
        assert_eq!(t.current(), None);
        assert!(matches!(t.restore(), Err(TableError::NothingToRestore)));
        let (t, p) = TableStore::open(&d);
        assert_eq!((p, t.current(), t.can_restore()), (None, None, false));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn non_finite_values_and_campaign_0_are_refused_and_change_nothing() {
        let d = dir("invalid");
        let (mut t, _) = TableStore::open(&d);
        t.apply(Entry::values_only(2, values(1.0))).unwrap();
        let mut bad = values(1.0);
        bad.r_sigma[1][2] = f64::NAN;
        for (v, c) in [(bad, 3), (values(2.0), 0)] {
            let e = t.apply(Entry::values_only(c, v)).unwrap_err();
            assert!(matches!(e, TableError::Invalid));
            assert_eq!(e.failure(), Failure::OutOfRange);
        }
        assert_eq!(t.current().map(|(_, c)| c), Some(2));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_table_that_cannot_be_written_is_not_applied() {
        let d = dir("unwritable");
        let (mut t, _) = TableStore::open(&d);
        t.apply(Entry::values_only(1, values(1.0))).unwrap();
        // A folder where the temporary file would go: the write fails.
        std::fs::create_dir(d.join(format!("{TABLE_FILE}.tmp"))).unwrap();
        std::fs::write(d.join(format!("{TABLE_FILE}.tmp")).join("x"), b"x").unwrap();
        let e = t.apply(Entry::values_only(2, values(2.0))).unwrap_err();
        assert!(matches!(e, TableError::NotSaved { .. }), "{e}");
        assert_eq!(e.failure(), Failure::TableNotSaved);
        assert!(e.to_string().contains("not applied"), "{e}");
        assert_eq!(t.current().map(|(_, c)| c), Some(1));
        assert!(matches!(t.restore(), Err(TableError::NotSaved { .. })));
        assert!(t.can_restore());
        let (t, p) = TableStore::open(&d);
        assert_eq!((p, t.current().map(|(_, c)| c)), (None, Some(1)));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_corrupt_main_file_is_refused_and_its_last_good_copy_used() {
        let d = dir("corrupt");
        let (mut t, _) = TableStore::open(&d);
        t.apply(Entry::values_only(1, values(3.0))).unwrap();
        t.apply(Entry::values_only(2, values(4.0))).unwrap();
        let good = std::fs::read(d.join(TABLE_FILE)).unwrap();
        let held = decode(&good).unwrap();
        // Every bit of the file flipped, one at a time: refused (the copy used), or,
        // where the flip leaves the table as it was (`e` for `E` in a number), the same.
        let (mut refused, mut same) = (0, 0);
        for i in 0..good.len() * 8 {
            let mut b = good.clone();
            b[i / 8] ^= 1 << (i % 8);
            std::fs::write(d.join(TABLE_FILE), &b).unwrap();
            let (t, p) = TableStore::open(&d);
            assert_eq!(t.state, held, "bit {i}");
            match p {
                Some(LoadProblem::MainBad { .. }) => refused += 1,
                None => same += 1,
                Some(other) => panic!("bit {i}: {other}"),
            }
        }
        assert!(refused > 20 * same, "{refused} refused, {same} harmless");
        // Missing, truncated, empty, a folder: refused, the copy used, event copy 1.
        std::fs::remove_file(d.join(TABLE_FILE)).unwrap();
        let (t, p) = TableStore::open(&d);
        assert_eq!((t.state, p.map(|p| p.copy())), (held, Some(1)));
        for bytes in [&good[..good.len() / 2], &[][..]] {
            std::fs::write(d.join(TABLE_FILE), bytes).unwrap();
            let (t, p) = TableStore::open(&d);
            assert_eq!((t.state, p.as_ref().map(|p| p.copy())), (held, Some(1)));
            assert!(p.unwrap().to_string().contains("last good copy"));
        }
        std::fs::remove_file(d.join(TABLE_FILE)).unwrap();
        std::fs::create_dir(d.join(TABLE_FILE)).unwrap();
        let (mut t, p) = TableStore::open(&d);
        assert_eq!((t.state, p.map(|p| p.copy())), (held, Some(1)));
        // Writing is refused while a folder is in the way; cleared, it repairs the file.
        assert!(matches!(
            t.apply(Entry::values_only(3, values(5.0))),
            Err(TableError::NotSaved { .. })
        ));
        std::fs::remove_dir(d.join(TABLE_FILE)).unwrap();
        t.apply(Entry::values_only(3, values(5.0))).unwrap();
        let (t, p) = TableStore::open(&d);
        assert_eq!((p, t.current().map(|(_, c)| c)), (None, Some(3)));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn both_files_corrupt_leave_no_table() {
        let d = dir("both");
        let (mut t, _) = TableStore::open(&d);
        t.apply(Entry::values_only(1, values(3.0))).unwrap();
        std::fs::write(d.join(TABLE_FILE), b"{}").unwrap();
        std::fs::write(d.join(BACKUP_FILE), b"\xff\x00garbage").unwrap();
        let (mut t, p) = TableStore::open(&d);
        let p = p.unwrap();
        assert!(matches!(p, LoadProblem::BothBad { .. }), "{p}");
        assert_eq!(p.copy(), 2);
        assert_eq!((t.current(), t.can_restore()), (None, false));
        // The copy missing is no better.
        std::fs::remove_file(d.join(BACKUP_FILE)).unwrap();
        let (_, p) = TableStore::open(&d);
        assert_eq!(p.map(|p| p.copy()), Some(2));
        // The next apply writes both again.
        t.apply(Entry::values_only(7, values(6.0))).unwrap();
        let (t, p) = TableStore::open(&d);
        assert_eq!((p, t.current().map(|(_, c)| c)), (None, Some(7)));
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// The file of `current` (no previous table) edited by `edit` under a checksum
    /// made anew, decoded.
    fn resealed(current: Entry, edit: &dyn Fn(&mut serde_json::Value)) -> Result<State, String> {
        let s = State {
            current: Some(current),
            previous: None,
        };
        let mut f: File = serde_json::from_slice(&encode(&s)).unwrap();
        edit(&mut f.table);
        f.sha256 = sha256_hex(&serde_json::to_vec(&f.table).unwrap());
        decode(&serde_json::to_vec(&f).unwrap())
    }

    #[test]
    fn a_file_with_a_right_checksum_but_wrong_content_is_refused() {
        let reseal = |edit: &dyn Fn(&mut serde_json::Value)| {
            resealed(Entry::values_only(1, values(1.0)), edit)
        };
        assert!(reseal(&|_| {}).is_ok());
        for (edit, why) in [
            (
                &(|t: &mut serde_json::Value| t["version"] = 3.into())
                    as &dyn Fn(&mut serde_json::Value),
                "version",
            ),
            (&|t| t["current"]["campaign"] = 0.into(), "numbered 0"),
            (
                &|t| t["current"]["beta"][0][0] = serde_json::Value::Null,
                "not a table",
            ),
            (
                &|t| t["previous"] = t["current"].clone(),
                "cannot be restored",
            ),
            (&|t| t["extra"] = 1.into(), "unknown field"),
        ] {
            let e = reseal(edit).unwrap_err();
            assert!(e.contains(why), "{e}");
        }
    }

    /// Trends of every parameter of both IS, started at day 10 and updated at day 40
    /// (no two numbers alike).
    fn trends() -> Trends {
        let mut t: Trends = [[[None; 3]; 3]; 2];
        for (i, tg) in t.iter_mut().enumerate() {
            for (g, ta) in tg.iter_mut().enumerate() {
                for (a, x) in ta.iter_mut().enumerate() {
                    let v = 1.0 + (9 * i + 3 * g + a) as f64 / 7.0;
                    let m = TrendModel {
                        walk_per_day: 1e-6 * v,
                        rate_sigma: 1e-3 * v,
                    };
                    let mut tr = Trend::start(10.0, v, 1e-4 * v, m);
                    tr.update(40.0, v * (1.0 + 1e-5), 1e-4 * v);
                    *x = Some(tr);
                }
            }
        }
        t
    }

    #[test]
    fn trends_survive_a_restart_bit_for_bit_and_predict_the_priors() {
        let d = dir("trends");
        let (mut t, _) = TableStore::open(&d);
        let a = trends();
        let mut b = a;
        b[1][2][0] = None;
        t.apply(Entry::from_trends(1, a)).unwrap();
        t.apply(Entry::from_trends(2, b)).unwrap();
        let size = std::fs::metadata(d.join(TABLE_FILE)).unwrap().len();
        assert!(size < MAX_FILE_BYTES / 2, "{size} bytes");
        drop(t);
        let (mut t, p) = TableStore::open(&d);
        assert_eq!(p, None);
        let e = *t.entry().unwrap();
        assert_eq!(e, Entry::from_trends(2, b));
        let bits_of = |t: &Trends| {
            format!(
                "{:?}",
                t.map(|x| x.map(|y| y.map(|z| z.map(|z| (
                    z.value.to_bits(),
                    z.rate.to_bits(),
                    z.p.map(|r| r.map(f64::to_bits))
                )))))
            )
        };
        assert_eq!(bits_of(&e.trends.unwrap()), bits_of(&b));
        // The values are the trends' at their epoch (what 20,2 reports); the priors of
        // a campaign at day 70 their prediction; no trend: 0.
        let (v, c) = t.current().unwrap();
        assert_eq!((bits(&v), c), (bits(&trend::at_epochs(&b)), 2));
        assert_eq!(v.beta[0][0], b[0][0][0].unwrap().value);
        assert_eq!(bits(&e.at(70.0)), bits(&trend::predicted(&b, 70.0)));
        assert_ne!(bits(&e.at(70.0)), bits(&v));
        assert_eq!((e.at(70.0).r[1][0], e.at(70.0).r_sigma[1][0]), (0.0, 0.0));
        // Function 4 brings the previous trends back.
        assert_eq!(t.restore().unwrap(), 1);
        assert_eq!(t.entry().copied(), Some(Entry::from_trends(1, a)));
        let (t, _) = TableStore::open(&d);
        assert_eq!(t.entry().copied(), Some(Entry::from_trends(1, a)));
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// A version 1 file (values, no trends), as the previous build wrote it.
    fn version_1_file(v: &TableValues) -> Vec<u8> {
        let entry = |c: u32| {
            serde_json::json!({
                "campaign": c, "beta": v.beta, "beta_sigma": v.beta_sigma, "k": v.k,
                "k_sigma": v.k_sigma, "r": v.r, "r_sigma": v.r_sigma,
            })
        };
        let table = serde_json::json!({
            "version": 1, "current": entry(3), "can_restore": true, "previous": entry(2),
        });
        let sha256 = sha256_hex(&serde_json::to_vec(&table).unwrap());
        serde_json::to_vec_pretty(&serde_json::json!({"table": table, "sha256": sha256})).unwrap()
    }

    #[test]
    fn a_version_1_table_is_read_as_values_at_every_epoch() {
        let d = dir("v1");
        std::fs::create_dir_all(&d).unwrap();
        let v = values(0.25);
        std::fs::write(d.join(TABLE_FILE), version_1_file(&v)).unwrap();
        let (mut t, p) = TableStore::open(&d);
        assert_eq!(p, None);
        let e = *t.entry().unwrap();
        assert_eq!((e.campaign, e.trends), (3, None));
        assert_eq!(bits(&e.at(0.0)), bits(&v));
        assert_eq!(bits(&e.at(200.0)), bits(&v));
        assert!(t.can_restore());
        // Applying on top writes version 2, the version 1 table its previous.
        t.apply(Entry::from_trends(4, trends())).unwrap();
        let text = std::fs::read_to_string(d.join(TABLE_FILE)).unwrap();
        assert!(text.contains("\"version\": 2"), "{text}");
        let (mut t, p) = TableStore::open(&d);
        assert_eq!(p, None);
        assert_eq!(t.restore().unwrap(), 3);
        assert_eq!(t.entry().copied(), Some(Entry::values_only(3, v)));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn trends_that_disagree_with_the_values_or_in_a_version_1_file_are_refused() {
        let reseal =
            |edit: &dyn Fn(&mut serde_json::Value)| resealed(Entry::from_trends(1, trends()), edit);
        assert!(reseal(&|_| {}).is_ok());
        for (edit, why) in [
            (
                &(|t: &mut serde_json::Value| t["version"] = 1.into())
                    as &dyn Fn(&mut serde_json::Value),
                "version 1",
            ),
            (&|t| t["current"]["beta"][0][1] = 2.5.into(), "trends'"),
            (
                &|t| t["current"]["trends"][0][2][1]["rate"] = "inf".into(),
                "not a table",
            ),
            (
                &|t| t["current"]["trends"][1][0][0]["value"] = 0.5.into(),
                "trends'",
            ),
            (
                &|t| t["current"]["trends"][0][0][0]["extra"] = 1.into(),
                "unknown field",
            ),
            (
                &|t| t["current"]["trends"][0][0] = serde_json::json!([]),
                "not a table",
            ),
        ] {
            let e = reseal(edit).unwrap_err();
            assert!(e.contains(why), "{why}: {e}");
        }
        // A trend that is not finite is refused on apply.
        let d = dir("badtrend");
        let (mut t, _) = TableStore::open(&d);
        let mut bad = trends();
        if let Some(x) = bad[0][1][2].as_mut() {
            x.rate = f64::INFINITY;
        }
        assert!(matches!(
            t.apply(Entry::from_trends(1, bad)),
            Err(TableError::Invalid)
        ));
        assert_eq!(t.entry(), None);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn no_bytes_make_it_panic() {
        use rand::{Rng as _, SeedableRng as _};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(50);
        let s = State {
            current: Some(Entry {
                campaign: 9,
                values: values(2.0),
                trends: None,
            }),
            previous: Some(None),
        };
        let good = encode(&s);
        assert_eq!(decode(&good), Ok(s));
        for n in 0..20_000 {
            let b: Vec<u8> = if n % 2 == 0 {
                let len = rng.gen_range(0..300);
                (0..len).map(|_| rng.gen()).collect()
            } else {
                // The good file with a few bytes changed, cut or grown.
                let mut b = good.clone();
                for _ in 0..rng.gen_range(1..6) {
                    let i = rng.gen_range(0..b.len());
                    match rng.gen_range(0..3) {
                        0 => b[i] = rng.gen(),
                        1 => b.truncate(i),
                        _ => b.insert(i, rng.gen()),
                    }
                    if b.is_empty() {
                        break;
                    }
                }
                b
            };
            if let Ok(got) = decode(&b) {
                assert_eq!(got, s, "{:?}", String::from_utf8_lossy(&b));
            }
        }
        // Deep nesting and a file too large are refused, not followed.
        let deep = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
        assert!(decode(deep.as_bytes()).is_err());
        let d = dir("large");
        std::fs::create_dir_all(&d).unwrap();
        let mut big = good.clone();
        big.resize(MAX_FILE_BYTES as usize + 10, b' ');
        std::fs::write(d.join(TABLE_FILE), &big).unwrap();
        let (_, p) = TableStore::open(&d);
        assert_eq!(p.map(|p| p.copy()), Some(2));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
