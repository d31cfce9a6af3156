//! The ground link: CCSDS space packets with PUS-C secondary headers (`packet`, `crc`),
//! the telecommands' authentication trailer and anti-replay state (`auth`, `replay`),
//! the dictionary: the IDs, failure codes, events, parameters and housekeeping layouts
//! that the code and the published dictionary share (`dictionary`, `events`,
//! `parameters`, `housekeeping`, `health`, `layout`), the telecommands' application data
//! (`requests`), printed as XTCE and JSON (`publish` for the telemetry, `commands` for
//! the telecommands, `xtce` for what they share) and as docs/ground.md's tables
//! (`tables`); the onboard side's logic (`onboard`, writing into `downlink`), which the
//! TMTC process (`runtime::process::tmtc`) runs; and the onboard calibration table, kept
//! across restarts (`table`). docs/ground.md describes them.

pub mod auth;
pub mod commands;
pub mod crc;
pub mod dictionary;
pub mod downlink;
pub mod events;
pub mod health;
pub mod housekeeping;
pub mod layout;
pub mod onboard;
pub mod packet;
pub mod parameters;
pub mod publish;
pub mod replay;
pub mod requests;
pub mod table;
pub mod tables;
pub mod xtce;
