//! The ground side's anti-replay counter: the last sequence number a ground tool sent
//! with a key, kept beside the key in `<key>.seq` so that every telecommand carries a
//! larger one than the last, across runs of the tool and between tools run at once.
//!
//! The file is one line, the last number used, in decimal padded to 10 digits (so a
//! rewrite overwrites it exactly). Taking a number opens the file (mode 0600, created
//! when missing), locks it (`flock`, exclusive), reads the last number, writes the next
//! and syncs it, then unlocks: two tools never take the same number. A missing or
//! empty file starts at the current Unix time in seconds, so a fresh file still beats
//! the numbers sent before it was made (one a second at most); a file that holds
//! anything else is refused, never read as "nothing sent yet".

use std::io::{Read, Seek, SeekFrom, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

/// Why no sequence number could be taken.
#[derive(Debug, thiserror::Error)]
pub enum SeqError {
    #[error("sequence counter {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("sequence counter {path} holds {text:?}, not a number: fix or remove it (a new file starts at the current Unix time)")]
    Corrupt { path: PathBuf, text: String },
    #[error(
        "sequence counter {path} is at {last}, the largest sequence number: a new key is needed"
    )]
    Exhausted { path: PathBuf, last: u32 },
}

/// The counter file of a key file: `<key>.seq` beside it.
pub fn counter_path(key: &Path) -> PathBuf {
    let mut s = key.as_os_str().to_os_string();
    s.push(".seq");
    PathBuf::from(s)
}

/// Seconds since the Unix epoch (0 before it), as a first sequence number.
fn now_s() -> u32 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u32::try_from(d.as_secs()).unwrap_or(u32::MAX))
}

/// Takes the next sequence number from the counter file at `path`: the last one plus
/// one (the current Unix time for a missing or empty file). With `given`, takes that
/// number instead and leaves the larger of it and the last in the file, so that the
/// numbers taken after it still beat it.
pub fn take(path: &Path, given: Option<u32>) -> Result<u32, SeqError> {
    let io = |source| SeqError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .mode(0o600)
        .open(path)
        .map_err(io)?;
    let _lock = Flock::exclusive(&f).map_err(io)?;
    let mut text = String::new();
    (&f).take(64)
        .read_to_string(&mut text)
        .map_err(|_| SeqError::Corrupt {
            path: path.to_path_buf(),
            text: "(not text)".into(),
        })?;
    let last = match text.trim() {
        "" => None,
        t => Some(t.parse::<u32>().map_err(|_| SeqError::Corrupt {
            path: path.to_path_buf(),
            text: t.chars().take(40).collect(),
        })?),
    };
    let (seq, keep) = match (given, last) {
        (Some(g), Some(l)) => (g, g.max(l)),
        (Some(g), None) => (g, g),
        (None, None) => (now_s(), now_s()),
        (None, Some(l)) => {
            let next = l.checked_add(1).ok_or(SeqError::Exhausted {
                path: path.to_path_buf(),
                last: l,
            })?;
            (next, next)
        }
    };
    if Some(keep) != last {
        f.seek(SeekFrom::Start(0)).map_err(io)?;
        f.write_all(format!("{keep:010}\n").as_bytes())
            .and_then(|_| f.set_len(11))
            .and_then(|_| f.sync_all())
            .map_err(io)?;
    }
    Ok(seq)
}

/// An exclusive `flock` on an open file, released when dropped.
struct Flock(libc::c_int);

impl Flock {
    fn exclusive(f: &std::fs::File) -> std::io::Result<Flock> {
        let fd = f.as_raw_fd();
        loop {
            // SAFETY: `fd` is an open descriptor that `f` keeps open while the lock lives.
            if unsafe { libc::flock(fd, libc::LOCK_EX) } == 0 {
                return Ok(Flock(fd));
            }
            let e = std::io::Error::last_os_error();
            if e.kind() != std::io::ErrorKind::Interrupted {
                return Err(e);
            }
        }
    }
}

impl Drop for Flock {
    fn drop(&mut self) {
        // SAFETY: the descriptor is still open (the file outlives the lock).
        unsafe { libc::flock(self.0, libc::LOCK_UN) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("taiji-seq-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_fresh_counter_starts_at_the_time_and_counts_up() {
        let d = dir("fresh");
        let p = counter_path(&d.join("k.key"));
        assert_eq!(p, d.join("k.key.seq"));
        let before = now_s();
        let first = take(&p, None).unwrap();
        assert!(first >= before && first <= now_s());
        assert_eq!(take(&p, None).unwrap(), first + 1);
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            format!("{:010}\n", first + 1)
        );
        // A given number is used; the file keeps the larger.
        assert_eq!(take(&p, Some(5)).unwrap(), 5);
        assert_eq!(take(&p, None).unwrap(), first + 2);
        assert_eq!(take(&p, Some(first + 100)).unwrap(), first + 100);
        assert_eq!(take(&p, None).unwrap(), first + 101);
        std::fs::write(&p, "").unwrap();
        assert!(take(&p, None).unwrap() >= before);
        std::fs::write(&p, "12 apples\n").unwrap();
        assert!(matches!(take(&p, None), Err(SeqError::Corrupt { .. })));
        std::fs::write(&p, format!("{}\n", u32::MAX)).unwrap();
        assert!(matches!(take(&p, None), Err(SeqError::Exhausted { .. })));
        std::fs::write(&p, "7").unwrap();
        assert_eq!(take(&p, None).unwrap(), 8);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "0000000008\n");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn threads_taking_numbers_at_once_never_share_one() {
        let d = dir("threads");
        let p = counter_path(&d.join("k.key"));
        std::fs::write(&p, "100\n").unwrap();
        let got: Vec<u32> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..4)
                .map(|_| s.spawn(|| (0..50).map(|_| take(&p, None).unwrap()).collect::<Vec<_>>()))
                .collect();
            hs.into_iter().flat_map(|h| h.join().unwrap()).collect()
        });
        let mut sorted = got.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted, (101..301).collect::<Vec<_>>());
        std::fs::remove_dir_all(&d).unwrap();
    }
}
