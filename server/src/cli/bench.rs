//! `candela bench`: speed/accuracy benchmark (being written).

use clap::Args;

use super::CliError;

#[derive(Debug, Args)]
pub struct BenchArgs {}

pub fn run(_a: BenchArgs) -> Result<(), CliError> {
    Err(CliError::failure(
        "candela bench is not available in this build yet",
    ))
}
