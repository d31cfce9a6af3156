//! The telecommands' anti-replay state: the last accepted sequence number, which each
//! accepted telecommand must exceed, kept across restarts in a small file written
//! atomically (a temporary file, synced, renamed over the old one) with a SHA-256
//! checksum. A file that fails its checksum is refused, never read as "no state".
//!
//! The file: `TJAR`, format version 1 (u8), 1 when a number was accepted (u8), the last
//! accepted number (u32, big-endian), then SHA-256 of those 10 bytes: 42 bytes.
//!
//! Accepting a number touches no heap (the paths are made ready when the file is
//! opened), so a TMTC loop that accepts telecommands stays allocation-free.

use sha2::{Digest, Sha256};
use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 4] = b"TJAR";
const FORMAT: u8 = 1;
const BODY: usize = 10;
/// Bytes of the state file.
pub const FILE_LEN: usize = BODY + 32;

/// Why a sequence number or the state file was refused.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("anti-replay sequence number {seq} is not larger than the last accepted, {last}")]
    Replayed { seq: u32, last: u32 },
    #[error("anti-replay state {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("anti-replay state {path} is corrupt ({why}): refused")]
    Corrupt { path: PathBuf, why: &'static str },
}

/// The last accepted sequence number and the file that keeps it.
#[derive(Debug)]
pub struct ReplayGuard {
    path: PathBuf,
    /// The file, its temporary sibling and its folder, ready for the system calls.
    c_path: CString,
    c_tmp: CString,
    c_dir: CString,
    last: Option<u32>,
}

/// `path` for a system call (a path with a NUL byte cannot name a file).
fn c_string(path: &Path) -> Result<CString, ReplayError> {
    CString::new(path.as_os_str().as_bytes()).map_err(|_| ReplayError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::from(std::io::ErrorKind::InvalidInput),
    })
}

/// The result of a system call that returns −1 on failure.
fn check(r: libc::c_int) -> std::io::Result<libc::c_int> {
    if r < 0 {
        Err(std::io::Error::last_os_error())
    } else {
        Ok(r)
    }
}

/// Opens `path` with `flags` (and mode 0600 when it creates it), runs `f` on the
/// descriptor, closes it.
fn with_fd(
    path: &CString,
    flags: libc::c_int,
    f: impl FnOnce(libc::c_int) -> std::io::Result<()>,
) -> std::io::Result<()> {
    // SAFETY: `path` is a NUL-terminated string that outlives the call.
    let fd = check(unsafe {
        libc::open(
            path.as_ptr(),
            flags | libc::O_CLOEXEC,
            0o600 as libc::c_uint,
        )
    })?;
    let r = f(fd);
    // SAFETY: `fd` was opened above and is closed once, here.
    let closed = check(unsafe { libc::close(fd) });
    r.and(closed.map(|_| ()))
}

/// The state file's bytes for `last`.
fn encode(last: Option<u32>) -> [u8; FILE_LEN] {
    let mut b = [0u8; FILE_LEN];
    b[..4].copy_from_slice(MAGIC);
    b[4] = FORMAT;
    b[5] = u8::from(last.is_some());
    b[6..BODY].copy_from_slice(&last.unwrap_or(0).to_be_bytes());
    let sum = Sha256::digest(&b[..BODY]);
    b[BODY..].copy_from_slice(&sum);
    b
}

/// The last accepted number a state file's bytes hold.
fn decode(b: &[u8]) -> Result<Option<u32>, &'static str> {
    if b.len() != FILE_LEN {
        return Err("wrong length");
    }
    if Sha256::digest(&b[..BODY]).as_slice() != &b[BODY..] {
        return Err("checksum mismatch");
    }
    if &b[..4] != MAGIC || b[4] != FORMAT || b[5] > 1 {
        return Err("unknown format");
    }
    Ok((b[5] == 1).then(|| u32::from_be_bytes([b[6], b[7], b[8], b[9]])))
}

impl ReplayGuard {
    /// The state kept in `path`: none accepted yet when the file does not exist; a file
    /// that is there but unreadable or corrupt is an error.
    pub fn open(path: &Path) -> Result<ReplayGuard, ReplayError> {
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(".tmp");
        let dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let mut g = ReplayGuard {
            path: path.to_path_buf(),
            c_path: c_string(path)?,
            c_tmp: c_string(&path.with_file_name(name))?,
            c_dir: c_string(dir)?,
            last: None,
        };
        match std::fs::read(path) {
            Ok(bytes) => {
                g.last = decode(&bytes).map_err(|why| ReplayError::Corrupt {
                    path: g.path.clone(),
                    why,
                })?
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => {
                return Err(ReplayError::Io {
                    path: g.path,
                    source,
                })
            }
        }
        Ok(g)
    }

    /// The last accepted sequence number (`None`: none yet).
    pub fn last(&self) -> Option<u32> {
        self.last
    }

    /// Whether `seq` would be accepted: larger than the last accepted.
    pub fn check(&self, seq: u32) -> Result<(), ReplayError> {
        match self.last {
            Some(last) if seq <= last => Err(ReplayError::Replayed { seq, last }),
            _ => Ok(()),
        }
    }

    /// Accepts `seq`: checks it, then keeps it on disk before it counts (a telecommand
    /// whose number could not be kept is not to be executed).
    pub fn accept(&mut self, seq: u32) -> Result<(), ReplayError> {
        self.check(seq)?;
        self.persist(Some(seq))?;
        self.last = Some(seq);
        Ok(())
    }

    /// Writes the state to the temporary file, syncs it, renames it over the file and
    /// syncs the folder: the file holds the old state or the new, whole.
    fn persist(&self, last: Option<u32>) -> Result<(), ReplayError> {
        let bytes = encode(last);
        let write = || -> std::io::Result<()> {
            with_fd(
                &self.c_tmp,
                libc::O_WRONLY | libc::O_CREAT | libc::O_TRUNC,
                |fd| {
                    // SAFETY: `bytes` is valid for its length for the duration of the call.
                    let n = check(
                        unsafe { libc::write(fd, bytes.as_ptr().cast(), bytes.len()) }
                            as libc::c_int,
                    )?;
                    if n as usize != bytes.len() {
                        return Err(std::io::Error::from(std::io::ErrorKind::WriteZero));
                    }
                    // SAFETY: a plain fsync of a descriptor this function owns.
                    check(unsafe { libc::fsync(fd) }).map(|_| ())
                },
            )?;
            // SAFETY: both are NUL-terminated strings that outlive the call.
            check(unsafe { libc::rename(self.c_tmp.as_ptr(), self.c_path.as_ptr()) })?;
            with_fd(&self.c_dir, libc::O_RDONLY | libc::O_DIRECTORY, |fd| {
                // SAFETY: a plain fsync of a descriptor this function owns.
                check(unsafe { libc::fsync(fd) }).map(|_| ())
            })
        };
        write().map_err(|source| ReplayError::Io {
            path: self.path.clone(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("taiji-replay-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn the_last_accepted_number_survives_a_restart() {
        let d = dir("restart");
        let path = d.join("replay.state");
        let mut g = ReplayGuard::open(&path).unwrap();
        assert_eq!(g.last(), None);
        g.check(0).unwrap();
        g.accept(5).unwrap();
        assert!(matches!(
            g.accept(5),
            Err(ReplayError::Replayed { seq: 5, last: 5 })
        ));
        assert!(matches!(
            g.accept(4),
            Err(ReplayError::Replayed { seq: 4, last: 5 })
        ));
        g.accept(9).unwrap();
        drop(g);
        let g = ReplayGuard::open(&path).unwrap();
        assert_eq!(g.last(), Some(9));
        assert!(matches!(g.check(9), Err(ReplayError::Replayed { .. })));
        assert!(!d.join("replay.state.tmp").exists());
        assert_eq!(std::fs::read(&path).unwrap().len(), FILE_LEN);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_corrupt_state_file_is_refused() {
        let d = dir("corrupt");
        let path = d.join("replay.state");
        let good = encode(Some(77));
        assert_eq!(decode(&good), Ok(Some(77)));
        assert_eq!(decode(&encode(None)), Ok(None));
        for i in 0..FILE_LEN * 8 {
            let mut b = good;
            b[i / 8] ^= 1 << (i % 8);
            std::fs::write(&path, b).unwrap();
            assert!(
                matches!(ReplayGuard::open(&path), Err(ReplayError::Corrupt { .. })),
                "bit {i}"
            );
        }
        for len in [0, 1, FILE_LEN - 1, FILE_LEN + 1] {
            std::fs::write(&path, vec![0u8; len]).unwrap();
            assert!(matches!(
                ReplayGuard::open(&path),
                Err(ReplayError::Corrupt {
                    why: "wrong length",
                    ..
                })
            ));
        }
        let mut alien = good;
        alien[0] = b'X';
        let sum = Sha256::digest(&alien[..BODY]);
        alien[BODY..].copy_from_slice(&sum);
        std::fs::write(&path, alien).unwrap();
        assert!(matches!(
            ReplayGuard::open(&path),
            Err(ReplayError::Corrupt {
                why: "unknown format",
                ..
            })
        ));
        assert!(matches!(ReplayGuard::open(&d), Err(ReplayError::Io { .. })));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
