//! The ground link's packet layer: CCSDS space packets with PUS-C secondary headers
//! (`packet`, `crc`), the telecommands' authentication trailer and anti-replay state
//! (`auth`, `replay`), and the dictionary: the IDs, failure codes and housekeeping
//! layouts that the code and the published dictionary share (`dictionary`,
//! `housekeeping`), printed as XTCE and JSON (`publish`) and as docs/ground.md's tables
//! (`tables`). docs/ground.md describes them.
//!
//! The ground side: the link that sends authenticated telecommands and receives the
//! telemetry (`client`), with its sequence counter (`seq`), the telecommands built from
//! what an operator types (`tc`), and any telemetry packet decoded for people and
//! scripts (`describe`), when a telecommand's exchange is over (`exchange`), and
//! housekeeping read back into the messages it was made from (`readback`).

pub mod auth;
pub mod client;
pub mod crc;
pub mod describe;
pub mod dictionary;
pub mod events;
pub mod exchange;
pub mod health;
pub mod housekeeping;
pub mod packet;
pub mod parameters;
pub mod publish;
pub mod readback;
pub mod replay;
pub mod requests;
pub mod seq;
pub mod tables;
pub mod tc;
