//! Estimator checkpoint: the whole filter state serialised (postcard) into a buffer
//! sized at start-up; a writer thread writes it to a temporary file and renames it over
//! the checkpoint, so a process killed at any instant leaves the previous or the new
//! checkpoint, never a torn one. Layout: magic (8 B) | next tick (u64 LE) | payload
//! length (u64 LE) | FNV-1a 64 of the payload (u64 LE) | payload.

use crate::sim::estimate::snapshot::fnv1a;
use crate::sim::estimate::Estimator;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// `TJCKPT` and the state's version (`snapshot::STATE_VERSION`, two digits): a
/// checkpoint of a build whose state means something else is refused, not resumed.
const MAGIC: [u8; 8] = *b"TJCKPT05";

/// A checkpoint that could not be written or read; the message names the file.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("cannot serialise the estimator: {0}")]
    Serialise(#[source] postcard::Error),
    #[error("cannot start the checkpoint writer: {0}")]
    Spawn(#[source] std::io::Error),
    /// The estimator's state outgrew the buffer sized at start-up.
    #[error("checkpoint buffer too small")]
    BufferTooSmall,
    #[error("cannot write checkpoint {}: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot read checkpoint {}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("checkpoint {} is not a checkpoint of this software (bad magic)", path.display())]
    BadMagic { path: PathBuf },
    #[error("checkpoint {} was written by a build whose estimator state means something else (state version {found}, this build's {})", path.display(), crate::sim::estimate::snapshot::STATE_VERSION)]
    OtherVersion { path: PathBuf, found: String },
    #[error("checkpoint {} is truncated", path.display())]
    Truncated { path: PathBuf },
    #[error("checkpoint {} is corrupt (checksum mismatch)", path.display())]
    Checksum { path: PathBuf },
    #[error("checkpoint {} is unreadable ({source})", path.display())]
    Unreadable {
        path: PathBuf,
        #[source]
        source: postcard::Error,
    },
}

const HEADER: usize = 32;

/// Hand-off between the filter loop and the writer thread: one slot, newest wins.
struct Slot {
    buf: Vec<u8>,
    len: usize,
    next_tick: u64,
    pending: bool,
    quit: bool,
    /// First write failure, reported to the loop on its next `save`.
    error: Option<CheckpointError>,
}

struct Shared {
    slot: Mutex<Slot>,
    cv: Condvar,
    /// `next_tick` of the newest checkpoint on disk (`u64::MAX`: none yet).
    written: AtomicU64,
    /// Writes in flight or queued (for `flush`).
    busy: AtomicBool,
}

/// Writes checkpoints of one estimator without allocating after `new` and without file
/// I/O in the filter loop: `save` serialises into a buffer sized at start-up and hands
/// it to a writer thread (a file write and rename take ~0.3 ms, a third of a real-time
/// tick at ×100). A newer checkpoint supersedes one not yet written.
pub struct Checkpointer {
    buf: Vec<u8>,
    shared: Arc<Shared>,
    writer: Option<JoinHandle<()>>,
}

impl Checkpointer {
    /// Size the buffers from the estimator's serialised size (fixed for a given method).
    pub fn new(path: &Path, est: &Estimator) -> Result<Self, CheckpointError> {
        Self::with_write_delay(path, est, Duration::ZERO)
    }

    /// As `new`, with every write held back by `delay`: fault injection for a slow or
    /// contended disk (the filter loop must neither wait for the writer nor miss the
    /// moment it finishes).
    pub fn with_write_delay(
        path: &Path,
        est: &Estimator,
        delay: Duration,
    ) -> Result<Self, CheckpointError> {
        let size = postcard::to_allocvec(est)
            .map_err(CheckpointError::Serialise)?
            .len();
        let cap = HEADER + 2 * size + 64;
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot {
                buf: vec![0; cap],
                len: 0,
                next_tick: 0,
                pending: false,
                quit: false,
                error: None,
            }),
            cv: Condvar::new(),
            written: AtomicU64::new(u64::MAX),
            busy: AtomicBool::new(false),
        });
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".tmp");
        let (path, tmp) = (path.to_path_buf(), PathBuf::from(tmp));
        let sh = Arc::clone(&shared);
        let writer = std::thread::Builder::new()
            .name("checkpoint".into())
            .spawn(move || write_loop(&sh, &path, &tmp, vec![0; cap], delay))
            .map_err(CheckpointError::Spawn)?;
        Ok(Checkpointer {
            buf: vec![0; cap],
            shared,
            writer: Some(writer),
        })
    }

    /// Queue the state after every tick below `next_tick` has been consumed. Returns
    /// the error of an earlier write that failed.
    pub fn save(&mut self, est: &Estimator, next_tick: u64) -> Result<(), CheckpointError> {
        let (head, body) = self.buf.split_at_mut(HEADER);
        let n = postcard::to_slice(est, body)
            .map_err(|_| CheckpointError::BufferTooSmall)?
            .len();
        head[..8].copy_from_slice(&MAGIC);
        head[8..16].copy_from_slice(&next_tick.to_le_bytes());
        head[16..24].copy_from_slice(&(n as u64).to_le_bytes());
        // The checksum (≈50 µs for 50 kB) is the writer's job.
        let mut slot = lock(&self.shared.slot);
        if let Some(e) = slot.error.take() {
            return Err(e);
        }
        std::mem::swap(&mut slot.buf, &mut self.buf);
        slot.len = HEADER + n;
        slot.next_tick = next_tick;
        slot.pending = true;
        self.shared.busy.store(true, Ordering::Release);
        drop(slot);
        self.shared.cv.notify_one();
        Ok(())
    }

    /// `next_tick` of the newest checkpoint safely on disk, if any: a restarted
    /// estimator resumes there, so the front-end must keep every sample from it on.
    pub fn written(&self) -> Option<u64> {
        match self.shared.written.load(Ordering::Acquire) {
            u64::MAX => None,
            t => Some(t),
        }
    }

    /// Wait until every queued checkpoint is on disk; returns a write error if any.
    pub fn flush(&mut self) -> Result<(), CheckpointError> {
        while self.shared.busy.load(Ordering::Acquire) {
            std::thread::sleep(Duration::from_micros(200));
        }
        match lock(&self.shared.slot).error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

impl Drop for Checkpointer {
    fn drop(&mut self) {
        lock(&self.shared.slot).quit = true;
        self.shared.cv.notify_one();
        if let Some(w) = self.writer.take() {
            let _ = w.join();
        }
    }
}

fn lock(m: &Mutex<Slot>) -> std::sync::MutexGuard<'_, Slot> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The writer thread: temporary file, then rename over the checkpoint, so a process
/// killed at any instant leaves the previous or the new checkpoint, never a torn one.
fn write_loop(sh: &Shared, path: &Path, tmp: &Path, mut buf: Vec<u8>, delay: Duration) {
    loop {
        let (len, next_tick) = {
            let mut slot = lock(&sh.slot);
            while !slot.pending && !slot.quit {
                slot = sh.cv.wait(slot).unwrap_or_else(|p| p.into_inner());
            }
            if !slot.pending {
                return;
            }
            std::mem::swap(&mut slot.buf, &mut buf);
            slot.pending = false;
            (slot.len, slot.next_tick)
        };
        if !delay.is_zero() {
            std::thread::sleep(delay);
        }
        let sum = fnv1a(&buf[HEADER..len]);
        buf[24..32].copy_from_slice(&sum.to_le_bytes());
        let res = std::fs::File::create(tmp)
            .and_then(|mut f| f.write_all(&buf[..len]))
            .and_then(|_| std::fs::rename(tmp, path));
        let mut slot = lock(&sh.slot);
        match res {
            Ok(()) => sh.written.store(next_tick, Ordering::Release),
            Err(e) => {
                slot.error.get_or_insert_with(|| CheckpointError::Write {
                    path: path.to_path_buf(),
                    source: e,
                });
            }
        }
        if !slot.pending {
            sh.busy.store(false, Ordering::Release);
        }
    }
}

/// Read a checkpoint: `Ok(None)` when there is none, an error naming the problem when
/// it is truncated or corrupt.
pub fn load(path: &Path) -> Result<Option<(Estimator, u64)>, CheckpointError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => {
            return Err(CheckpointError::Read {
                path: path.to_path_buf(),
                source,
            })
        }
    };
    let path = path.to_path_buf();
    if bytes.len() >= HEADER && bytes[..6] == MAGIC[..6] && bytes[..8] != MAGIC {
        let found = String::from_utf8_lossy(&bytes[6..8]).into_owned();
        return Err(CheckpointError::OtherVersion { path, found });
    }
    if bytes.len() < HEADER || bytes[..8] != MAGIC {
        return Err(CheckpointError::BadMagic { path });
    }
    let word = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap());
    let (next, n, sum) = (word(8), word(16) as usize, word(24));
    if bytes.len() != HEADER + n {
        return Err(CheckpointError::Truncated { path });
    }
    if fnv1a(&bytes[HEADER..]) != sum {
        return Err(CheckpointError::Checksum { path });
    }
    let est: Estimator = postcard::from_bytes(&bytes[HEADER..])
        .map_err(|source| CheckpointError::Unreadable { path, source })?;
    Ok(Some((est, next)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::campaign::Stages;
    use crate::sim::estimate::Method;
    use crate::sim::scenario::Scenario;

    /// A test's folder, removed when the test ends (pass or fail) so runs of the suite
    /// do not pile folders up in /tmp.
    struct Dir(PathBuf);

    impl std::ops::Deref for Dir {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn dir(name: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("taiji-ckpt-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }

    #[test]
    fn restored_estimator_continues_bit_identically() {
        let s = Scenario {
            duration_s: 200.0,
            ..Default::default()
        };
        for method in [Method::Joint, Method::Paper] {
            let mut st = Stages::new(&s, 3, method);
            let d = dir(method.name());
            let path = d.join("est.ckpt");
            let mut ck = Checkpointer::new(&path, &st.estimator).unwrap();
            let samples = st.sensor_samples(s.n_samples());
            for (t, x) in samples.iter().enumerate().take(700) {
                st.estimator.step(x);
                if t == 599 {
                    ck.save(&st.estimator, 600).unwrap();
                }
            }
            ck.flush().unwrap();
            assert_eq!(ck.written(), Some(600));
            let (mut restored, next) = load(&path).unwrap().unwrap();
            assert_eq!(next, 600);
            let mut a = st.estimator.clone();
            // `a` goes on from 700; `restored` replays 600..700 first, as after a crash.
            for x in &samples[600..] {
                restored.step(x);
            }
            for x in &samples[700..] {
                a.step(x);
            }
            assert_eq!(a.finish(), restored.finish(), "{}", method.name());
        }
    }

    #[test]
    fn damaged_checkpoints_are_rejected_with_a_reason() {
        let d = dir("bad");
        let s = Scenario::default();
        let st = Stages::new(&s, 1, Method::Joint);
        let path = d.join("est.ckpt");
        assert!(load(&path).unwrap().is_none());
        let mut ck = Checkpointer::new(&path, &st.estimator).unwrap();
        ck.save(&st.estimator, 0).unwrap();
        ck.flush().unwrap();
        let good = std::fs::read(&path).unwrap();
        std::fs::write(&path, &good[..good.len() / 2]).unwrap();
        assert!(load(&path).err().unwrap().to_string().contains("truncated"));
        let mut flipped = good.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 0x55;
        std::fs::write(&path, &flipped).unwrap();
        assert!(load(&path).err().unwrap().to_string().contains("checksum"));
        std::fs::write(&path, b"hello").unwrap();
        assert!(load(&path).err().unwrap().to_string().contains("magic"));
        // An older build's (its state means something else): refused, saying so.
        let mut older = good.clone();
        older[..8].copy_from_slice(b"TJCKPT04");
        std::fs::write(&path, &older).unwrap();
        let e = load(&path).err().unwrap().to_string();
        assert!(e.contains("state version 04, this build's 5"), "{e}");
    }

    /// The magic's two digits are the state's version.
    #[test]
    fn the_magic_carries_the_state_version() {
        let v = crate::sim::estimate::snapshot::STATE_VERSION;
        assert_eq!(&MAGIC[6..], format!("{v:02}").as_bytes());
    }
}
