//! `taiji-calib ground`: the ground side of the link (docs/ground.md).

use super::args::{DictionaryFormat, GroundCmd};
use super::error::CliError;
use crate::ground::publish;
use std::io::Write;
use std::process::ExitCode;

pub(crate) fn run(cmd: GroundCmd) -> Result<ExitCode, CliError> {
    match cmd {
        GroundCmd::Dictionary { format } => {
            let text = match format {
                DictionaryFormat::Json => serde_json::to_string_pretty(&publish::json())? + "\n",
                DictionaryFormat::Xtce => publish::xtce(),
            };
            // A closed pipe (`| head`) ends the printing, not the command with an error.
            let _ = std::io::stdout().lock().write_all(text.as_bytes());
            Ok(ExitCode::SUCCESS)
        }
    }
}
