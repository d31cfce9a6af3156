//! The ground link: CCSDS space packets with PUS-C secondary headers (`packet`, `crc`),
//! the telecommands' authentication trailer and anti-replay state (`auth`, `replay`),
//! the dictionary: the IDs, failure codes, events, parameters and housekeeping layouts
//! that the code and the published dictionary share (`dictionary`, `events`,
//! `parameters`, `housekeeping`, `health`, `layout`), the telecommands' application data
//! (`requests`), printed as XTCE and JSON (`publish` for the telemetry, `commands` for
//! the telecommands, `xtce` for what they share) and as docs/ground-packets.md's tables
//! (`tables`); the onboard side's logic (`onboard`, writing into `downlink`), which the
//! TMTC process (`runtime::process::tmtc`) runs; and the onboard calibration table, kept
//! across restarts (`table`). docs/ground.md and docs/ground-packets.md describe them.
//!
//! The ground side: the link that sends authenticated telecommands and receives the
//! telemetry (`client`), with its sequence counter (`seq`), the telecommands built from
//! what an operator types (`tc`), any telemetry packet decoded for people and scripts
//! (`describe`), when a telecommand's exchange is over (`exchange`), and housekeeping
//! read back into the messages it was made from (`readback`).

pub mod auth;
pub mod client;
pub mod commands;
pub mod crc;
pub mod describe;
pub mod dictionary;
pub mod downlink;
pub mod events;
pub mod exchange;
pub mod health;
pub mod housekeeping;
pub mod layout;
pub mod onboard;
pub mod packet;
pub mod parameters;
pub mod publish;
pub mod readback;
pub mod replay;
pub mod requests;
pub mod seq;
pub mod table;
pub mod tables;
pub mod tc;
pub mod xtce;
