//! Layer 4, analysis: in-process campaigns, the Cramér–Rao bound, the maneuver
//! planner, reports and figures, Monte Carlo, and the fuzz and upset harnesses.

pub mod campaign;
pub mod campaign_report;
pub mod checkpoint;
pub mod crlb;
pub mod export;
pub mod fuzz;
pub mod mission;
pub mod montecarlo;
pub mod plan;
pub mod plots;
pub mod progress;
pub mod replay;
pub mod report;
pub mod report_doc;
pub mod upset;
