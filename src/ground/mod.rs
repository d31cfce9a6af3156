//! The ground link's packet layer: CCSDS space packets with PUS-C secondary headers
//! (`packet`, `crc`), the telecommands' authentication trailer and anti-replay state
//! (`auth`, `replay`), and the dictionary: the IDs, failure codes and housekeeping
//! layouts that the code and the published dictionary share (`dictionary`,
//! `housekeeping`), printed as XTCE and JSON (`publish`) and as docs/ground.md's tables
//! (`tables`); and the onboard calibration table, kept across restarts (`table`).
//! docs/ground.md describes them.

pub mod auth;
pub mod crc;
pub mod dictionary;
pub mod events;
pub mod health;
pub mod housekeeping;
pub mod packet;
pub mod parameters;
pub mod publish;
pub mod replay;
pub mod requests;
pub mod table;
pub mod tables;
