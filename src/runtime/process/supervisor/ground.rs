//! `taiji-supervisor --ground ADDR`: the set operated from the ground. It comes up in
//! standby with the TMTC process (`taiji-tmtc`) on the link; each accepted start runs
//! one campaign, as `tools/launch` runs one, into `OUT/campaign-N/`, its priors from the
//! onboard calibration table once one was applied; the set stays up for the next one
//! until function 5 or SIGTERM. The supervisor executes what the TMTC process forwards
//! (`GroundRequest`), answers it (`GroundNote`), says its mode and table every 100 ms
//! (`GroundState`), and restarts the TMTC process when it dies or falls silent.

mod desk;
mod tmtc;

use super::{Prepared, SupervisorArgs, UserError};
use crate::ground::auth::{Key, KeyError};
use std::net::SocketAddr;
use std::path::PathBuf;

/// Where the key goes when `--ground-key` names none.
pub const KEY_FILE: &str = "ground.key";

/// Why the ground link could not come up (exit 2).
#[derive(Debug, thiserror::Error)]
pub enum GroundError {
    #[error(transparent)]
    Run(#[from] UserError),
    #[error("--ground {addr:?}: not an address (give IP:PORT, e.g. 127.0.0.1:7301)")]
    Addr { addr: String },
    #[error("--ground {addr}: not a loopback address; binding the link to it needs --ground-remote")]
    NotLoopback { addr: SocketAddr },
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error("no taiji-tmtc beside the supervisor ({0}); build it with `cargo build --release --bins`")]
    NoTmtc(PathBuf),
    #[error("cannot start the TMTC process: {0}")]
    TmtcSpawn(String),
}

/// Run the set from the ground; returns the exit code: 0 after function 5, 130 after a
/// signal, 2 when it could not come up, 3 when the TMTC process could not be kept up.
pub fn run(args: &SupervisorArgs) -> u8 {
    let up = match check(args) {
        Ok(up) => up,
        Err(e) => {
            eprintln!("taiji-supervisor: error: {e}");
            return 2;
        }
    };
    desk::serve(args, up)
}

/// What the ground mode checked before anything starts.
pub(crate) struct Up {
    pub prepared: Prepared,
    pub addr: SocketAddr,
    pub key: PathBuf,
}

fn check(args: &SupervisorArgs) -> Result<Up, GroundError> {
    let text = args.ground.clone().unwrap_or_default();
    let addr: SocketAddr = text
        .parse()
        .map_err(|_| GroundError::Addr { addr: text.clone() })?;
    if !addr.ip().is_loopback() && !args.ground_remote {
        return Err(GroundError::NotLoopback { addr });
    }
    let prepared = super::prepare(args)?;
    let key = match &args.ground_key {
        Some(k) => {
            Key::load(k)?;
            k.clone()
        }
        None => {
            let k = args.out.join(KEY_FILE);
            if k.exists() {
                Key::load(&k)?;
            } else {
                std::fs::create_dir_all(&args.out).map_err(|source| {
                    UserError::OutFolder {
                        path: args.out.clone(),
                        source,
                    }
                })?;
                Key::create(&k)?;
                println!("Created the telecommand key {} (mode 0600)", k.display());
            }
            k
        }
    };
    Ok(Up {
        prepared,
        addr,
        key,
    })
}
