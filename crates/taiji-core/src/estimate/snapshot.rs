//! The joint estimator's checkpoint in a caller's buffer, for hosts without files or
//! heap (the C ABI): the state is plain data, so a checkpoint is a header and the
//! state's bytes. Layout (little-endian): magic `TJEST001` (8 B) | version (u64: the
//! message layout version, and `STATE_VERSION` in the high 32 bits) | state size (u64)
//! | FNV-1a 64 of the state bytes (u64) | state bytes.
//!
//! Restoring checks every header field and the checksum, then the table and the
//! counts inside the state, so a torn, foreign or corrupted buffer is refused with a
//! reason instead of becoming an estimator.

use super::joint::JointEstimator;
use crate::msg::LAYOUT_VERSION;

const MAGIC: [u8; 8] = *b"TJEST001";
/// Bytes before the state.
pub const HEADER: usize = 32;

/// What the state's bytes mean, where their size stays the same: bumped when a field
/// changes meaning (the host's file checkpoint, `TJCKPT` and two digits, with it).
/// 2: the angular group's Gram on ΔV1 − ρ0 ΔV2 and ΔV2; older builds wrote 0 here
/// (the Gram on ΔV1 and ΔV2), so their checkpoints are refused rather than misread.
/// 3: the SRP's turn modelled (the turn rows' filters, IS1's attitude without the
/// drift filter in the turn).
/// 4: the turn rows' levers on the attitude error signed (`turn_z`; 3 held them
/// squared), for the covariance of the rows' white noise with the attitude's step.
/// 5: Gram updates deferred (`pend`: the samples waiting for each Gram matrix).
pub const STATE_VERSION: u32 = 5;

/// The checkpoint's version word.
const VERSION: u64 = LAYOUT_VERSION as u64 | (STATE_VERSION as u64) << 32;

/// Why a checkpoint cannot be written or restored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SnapshotError {
    /// The buffer is shorter than `size()`.
    TooSmall,
    /// Not a checkpoint: wrong magic.
    Magic,
    /// Written by a build with another message/state layout (another layout version,
    /// or an intact checkpoint of a state of another size).
    Version,
    /// Wrong state size or checksum: truncated or corrupted.
    Corrupt,
    /// The bytes are intact but hold a state no estimator could be in (its table fails
    /// `EstimatorConfig::check`).
    Invalid,
}

/// FNV-1a 64: a checksum that needs no table and no allocation.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Bytes a checkpoint takes.
pub const fn size() -> usize {
    HEADER + core::mem::size_of::<JointEstimator>()
}

fn word(buf: &[u8], k: usize) -> u64 {
    let mut w = [0u8; 8];
    w.copy_from_slice(&buf[8 * k..8 * k + 8]);
    u64::from_le_bytes(w)
}

/// Writes the checkpoint of `est` into `buf`; returns the bytes written.
pub fn write(est: &JointEstimator, buf: &mut [u8]) -> Result<usize, SnapshotError> {
    let state = bytemuck::bytes_of(est);
    let n = HEADER + state.len();
    if buf.len() < n {
        return Err(SnapshotError::TooSmall);
    }
    buf[0..8].copy_from_slice(&MAGIC);
    buf[8..16].copy_from_slice(&VERSION.to_le_bytes());
    buf[16..24].copy_from_slice(&(state.len() as u64).to_le_bytes());
    buf[24..32].copy_from_slice(&fnv1a(state).to_le_bytes());
    buf[HEADER..n].copy_from_slice(state);
    Ok(n)
}

/// Reads a checkpoint written by `write` (the buffer needs no alignment).
pub fn read(buf: &[u8]) -> Result<JointEstimator, SnapshotError> {
    let mut est = <JointEstimator as bytemuck::Zeroable>::zeroed();
    read_into(buf, &mut est)?;
    Ok(est)
}

/// `read` into `dst` in place (the C ABI's caller-owned memory: no 50 kB value on the
/// stack). On an error `dst` may hold part of the checkpoint; the caller treats it as
/// uninitialised.
pub fn read_into(buf: &[u8], dst: &mut JointEstimator) -> Result<(), SnapshotError> {
    if buf.len() < HEADER {
        return Err(SnapshotError::TooSmall);
    }
    if buf[0..8] != MAGIC {
        return Err(SnapshotError::Magic);
    }
    if word(buf, 1) != VERSION {
        return Err(SnapshotError::Version);
    }
    let len = core::mem::size_of::<JointEstimator>();
    if word(buf, 2) != len as u64 {
        // Intact under its own length and checksum: a build with another state layout
        // wrote it (the state's size is part of its layout), not a torn checkpoint.
        let own = usize::try_from(word(buf, 2))
            .ok()
            .and_then(|n| buf.get(HEADER..HEADER.checked_add(n)?));
        return Err(match own {
            Some(state) if fnv1a(state) == word(buf, 3) => SnapshotError::Version,
            _ => SnapshotError::Corrupt,
        });
    }
    if buf.len() < HEADER + len {
        return Err(SnapshotError::Corrupt);
    }
    let state = &buf[HEADER..HEADER + len];
    if word(buf, 3) != fnv1a(state) {
        return Err(SnapshotError::Corrupt);
    }
    bytemuck::bytes_of_mut(dst).copy_from_slice(state);
    if !dst.is_sane() {
        return Err(SnapshotError::Invalid);
    }
    Ok(())
}
