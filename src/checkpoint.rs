//! Estimator checkpoint: the whole filter state serialised (postcard) into a buffer
//! sized at start-up, written to a temporary file and renamed over the checkpoint, so a
//! process killed at any instant leaves the previous or the new checkpoint, never a
//! torn one. Layout: magic (8 B) | next tick (u64 LE) | payload length (u64 LE) |
//! FNV-1a 64 of the payload (u64 LE) | payload.

use crate::estimate::Estimator;
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: [u8; 8] = *b"TJCKPT01";
const HEADER: usize = 32;

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Writes checkpoints of one estimator without allocating after `new`.
pub struct Checkpointer {
    path: PathBuf,
    tmp: PathBuf,
    buf: Vec<u8>,
}

impl Checkpointer {
    /// Size the buffer from the estimator's serialised size (fixed for a given method).
    pub fn new(path: &Path, est: &Estimator) -> Result<Self, String> {
        let size = postcard::to_allocvec(est)
            .map_err(|e| format!("cannot serialise the estimator: {e}"))?
            .len();
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".tmp");
        Ok(Checkpointer {
            path: path.to_path_buf(),
            tmp: PathBuf::from(tmp),
            buf: vec![0; HEADER + 2 * size + 64],
        })
    }

    /// Write the state after every tick below `next_tick` has been consumed.
    pub fn save(&mut self, est: &Estimator, next_tick: u64) -> Result<(), String> {
        let (head, body) = self.buf.split_at_mut(HEADER);
        let n = postcard::to_slice(est, body)
            .map_err(|_| "checkpoint buffer too small")?
            .len();
        head[..8].copy_from_slice(&MAGIC);
        head[8..16].copy_from_slice(&next_tick.to_le_bytes());
        head[16..24].copy_from_slice(&(n as u64).to_le_bytes());
        head[24..32].copy_from_slice(&fnv1a(&body[..n]).to_le_bytes());
        let mut f = std::fs::File::create(&self.tmp).map_err(|_| "cannot create checkpoint")?;
        f.write_all(&self.buf[..HEADER + n])
            .map_err(|_| "cannot write checkpoint")?;
        drop(f);
        std::fs::rename(&self.tmp, &self.path).map_err(|_| "cannot rename checkpoint")?;
        Ok(())
    }
}

/// Read a checkpoint: `Ok(None)` when there is none, an error naming the problem when
/// it is truncated or corrupt.
pub fn load(path: &Path) -> Result<Option<(Estimator, u64)>, String> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("cannot read checkpoint {}: {e}", path.display())),
    };
    let bad = |what: &str| format!("checkpoint {} is {what}", path.display());
    if bytes.len() < HEADER || bytes[..8] != MAGIC {
        return Err(bad("not a checkpoint of this software (bad magic)"));
    }
    let word = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap());
    let (next, n, sum) = (word(8), word(16) as usize, word(24));
    if bytes.len() != HEADER + n {
        return Err(bad("truncated"));
    }
    if fnv1a(&bytes[HEADER..]) != sum {
        return Err(bad("corrupt (checksum mismatch)"));
    }
    let est: Estimator =
        postcard::from_bytes(&bytes[HEADER..]).map_err(|e| bad(&format!("unreadable ({e})")))?;
    Ok(Some((est, next)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::Stages;
    use crate::estimate::Method;
    use crate::scenario::Scenario;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("taiji-ckpt-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn restored_estimator_continues_bit_identically() {
        let s = Scenario {
            duration_s: 200.0,
            ..Default::default()
        };
        for method in [Method::Joint, Method::Paper] {
            let mut st = Stages::new(&s, 3, method);
            let path = dir(method.name()).join("est.ckpt");
            let mut ck = Checkpointer::new(&path, &st.estimator).unwrap();
            let samples: Vec<_> = (0..s.n_samples())
                .map(|t| {
                    let c = st.commander.step(t);
                    let truth = st.plant.step(t, &c.torque_cmd_b);
                    st.fee.step(&truth)
                })
                .collect();
            for (t, x) in samples.iter().enumerate().take(700) {
                st.estimator.step(x);
                if t == 599 {
                    ck.save(&st.estimator, 600).unwrap();
                }
            }
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
        let good = std::fs::read(&path).unwrap();
        std::fs::write(&path, &good[..good.len() / 2]).unwrap();
        assert!(load(&path).err().unwrap().contains("truncated"));
        let mut flipped = good.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 0x55;
        std::fs::write(&path, &flipped).unwrap();
        assert!(load(&path).err().unwrap().contains("checksum"));
        std::fs::write(&path, b"hello").unwrap();
        assert!(load(&path).err().unwrap().contains("magic"));
    }
}
