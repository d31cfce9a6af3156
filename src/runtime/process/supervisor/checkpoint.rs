//! The estimator's checkpoint file in the run folder: an earlier run's removed at
//! the start, removed at the end of a run, kept (and said) when the set failed.

use crate::runtime::process::estimator::CHECKPOINT_FILE;
pub use crate::runtime::process::set::SupervisorArgs;
use crate::runtime::process::set::SupervisorError;
pub use crate::runtime::process::set::{SetError, UserError};
use crate::sim::files::FileError;
use std::path::PathBuf;

/// The estimator's checkpoint path in the run folder, with an earlier run's removed
/// (a checkpoint only serves restarts within its own run).
pub(super) fn fresh_checkpoint(args: &SupervisorArgs) -> Result<PathBuf, SupervisorError> {
    let user = SupervisorError::user;
    std::fs::create_dir_all(&args.out)
        .map_err(|source| user(UserError::from(FileError::create(args.out.clone(), source))))?;
    let ckpt = args.out.join(CHECKPOINT_FILE);
    if ckpt.exists() {
        std::fs::remove_file(&ckpt).map_err(|source| {
            user(UserError::RemoveCheckpoint {
                path: ckpt.clone(),
                source,
            })
        })?;
    }
    Ok(ckpt)
}

/// A run that ended is cleared of its checkpoint; a failed set keeps it for diagnosis
/// and says so.
pub(super) fn settle_checkpoint<T>(
    result: Result<T, SupervisorError>,
    ckpt: &std::path::Path,
) -> Result<T, SupervisorError> {
    match result {
        Err(SupervisorError::Set(e)) if ckpt.exists() => {
            Err(SupervisorError::Set(SetError::CheckpointKept {
                error: Box::new(e),
                checkpoint: ckpt.to_path_buf(),
            }))
        }
        r => {
            remove_checkpoint(ckpt);
            r
        }
    }
}

/// Remove the estimator's checkpoint and the temporary file a killed writer may leave.
pub(super) fn remove_checkpoint(ckpt: &std::path::Path) {
    let mut tmp = ckpt.as_os_str().to_owned();
    tmp.push(".tmp");
    for p in [ckpt.to_path_buf(), PathBuf::from(tmp)] {
        if let Err(e) = std::fs::remove_file(&p) {
            if e.kind() != std::io::ErrorKind::NotFound {
                log::warn!("cannot remove {}: {e}", p.display());
            }
        }
    }
}
