//! `taiji-calib ground`'s arguments: one subcommand per telecommand, `listen`,
//! `decode` and `dictionary`, and the link options they share.

use crate::ground::client::{self, LinkConfig};
use clap::{Subcommand, ValueEnum};
use std::net::{SocketAddr, ToSocketAddrs};
use std::path::PathBuf;

#[derive(Subcommand)]
pub(crate) enum GroundCmd {
    /// Are you there? 17,1; the set answers 17,2.
    Ping {
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Start a campaign: 8,1 function 1; ends at the start report (the campaign runs;
    /// `--ack all` waits for its end).
    Start {
        /// The campaign's random seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// The campaign's length [s]; 0: the scenario's.
        #[arg(long, default_value_t = 0.0)]
        duration: f64,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Stop the campaign: 8,1 function 2.
    Stop {
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Apply the last campaign's result to the onboard calibration table: 8,1 function 3.
    Apply {
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Restore the table's previous values: 8,1 function 4.
    Restore {
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Shut the set down: 8,1 function 5.
    Shutdown {
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Enable periodic housekeeping reports of these structures: 3,5.
    HkEnable {
        /// Structure IDs or names (1 estimate, 2 health).
        #[arg(required = true)]
        ids: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Disable periodic housekeeping reports of these structures: 3,6.
    HkDisable {
        #[arg(required = true)]
        ids: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Change a structure's reporting interval: 3,31.
    HkInterval {
        /// Structure ID.
        id: u16,
        /// Interval [ms] (the set takes 100 to 3 600 000).
        ms: u32,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// One report of each structure now: 3,27; the set answers 3,25.
    HkNow {
        #[arg(required = true)]
        ids: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Enable event reports of these events (IDs or names): 5,5.
    EventEnable {
        #[arg(required = true)]
        ids: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Disable event reports of these events (IDs or names): 5,6.
    EventDisable {
        #[arg(required = true)]
        ids: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Report parameter values (IDs or names; none: every parameter): 20,1; the set
    /// answers 20,2.
    Get {
        ids: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Set parameter values, NAME_OR_ID=VALUE each (the set checks the range): 20,3.
    Set {
        #[arg(required = true, value_name = "NAME_OR_ID=VALUE")]
        values: Vec<String>,
        #[command(flatten)]
        x: ExchangeArgs,
    },
    /// Print the telemetry as it comes, claiming it with a ping at start and every
    /// --keepalive seconds (telemetry goes to the sender of the last accepted
    /// telecommand); SIGINT or SIGTERM ends it (exit 0).
    Listen {
        /// Append every datagram received to FILE: each as a u32 big-endian length,
        /// then the packet's bytes (`ground decode FILE` prints them).
        #[arg(long)]
        save: Option<PathBuf>,
        /// Ping again every S seconds (0: only at start).
        #[arg(long, default_value_t = 5.0, value_name = "S")]
        keepalive: f64,
        /// End after S seconds (default: run until SIGINT or SIGTERM).
        #[arg(long, value_name = "S")]
        seconds: Option<f64>,
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Print the packets of a file `listen --save` wrote.
    Decode {
        file: PathBuf,
        /// JSON lines instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Print the dictionary, generated from the definitions the code uses: XTCE (as
    /// space-packet-parser reads it) or JSON.
    Dictionary {
        #[arg(long, value_enum, default_value = "json")]
        format: DictionaryFormat,
    },
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum DictionaryFormat {
    Json,
    Xtce,
}

/// Where the set is and how to sign: every subcommand that talks to it.
#[derive(clap::Args, Clone)]
pub(crate) struct LinkArgs {
    /// The onboard set's address (`tools/launch --ground ADDR`).
    #[arg(long, default_value = client::DEFAULT_ADDR, value_parser = address)]
    pub(crate) to: SocketAddr,
    /// The link's key file (64 hexadecimal characters; readable by its owner only).
    #[arg(long)]
    pub(crate) key: PathBuf,
    /// Anti-replay sequence number of the (first) telecommand (default: the next of
    /// the counter file <KEY>.seq).
    #[arg(long)]
    pub(crate) seq: Option<u32>,
    /// Local address to send from and receive on (default: an ephemeral port on the
    /// loopback, or on every interface when --to is not a loopback address).
    #[arg(long, value_parser = address)]
    pub(crate) bind: Option<SocketAddr>,
    /// JSON lines instead of text.
    #[arg(long)]
    pub(crate) json: bool,
}

impl LinkArgs {
    pub(crate) fn config(&self) -> LinkConfig {
        LinkConfig {
            to: self.to,
            bind: self.bind,
            key: self.key.clone(),
            seq: self.seq,
        }
    }
}

/// A telecommand's exchange: the link, how long to wait, which reports to ask for.
#[derive(clap::Args, Clone)]
pub(crate) struct ExchangeArgs {
    #[command(flatten)]
    pub(crate) link: LinkArgs,
    /// Give up after S seconds without the telecommand's last report (exit 3).
    #[arg(long, default_value_t = 10.0, value_name = "S")]
    pub(crate) timeout: f64,
    /// Verification reports to ask for: `all`, or a comma list of acceptance, start,
    /// progress, completion (failures are always reported). Default: all; for `start`,
    /// acceptance,start (its completion comes once every process of the campaign runs).
    #[arg(long, value_parser = ack_flags)]
    pub(crate) ack: Option<u8>,
    /// Send the telecommand alone. By default a ping from the same socket comes first,
    /// so that the set, which sends its telemetry to the sender of the last accepted
    /// telecommand, sends a refusal of this one here (with --seq: never).
    #[arg(long)]
    pub(crate) no_claim: bool,
}

/// An address as `HOST:PORT`, the first it resolves to.
fn address(s: &str) -> Result<SocketAddr, String> {
    s.to_socket_addrs()
        .map_err(|e| format!("{s:?} is not an address HOST:PORT ({e})"))?
        .next()
        .ok_or_else(|| format!("{s:?} resolves to no address"))
}

/// `--ack`'s flags.
fn ack_flags(s: &str) -> Result<u8, String> {
    if s == "all" {
        return Ok(client::ACK_ALL);
    }
    s.split(',')
        .map(|w| match w.trim() {
            "acceptance" => Ok(client::ACK_ACCEPTANCE),
            "start" => Ok(client::ACK_START),
            "progress" => Ok(client::ACK_PROGRESS),
            "completion" => Ok(client::ACK_COMPLETION),
            "none" => Ok(0),
            other => Err(format!(
                "{other:?}: expected all, none, or a list of acceptance, start, progress, completion"
            )),
        })
        .try_fold(0u8, |acc, f| f.map(|f| acc | f))
}
