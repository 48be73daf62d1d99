//! `candela compare`: image metrics between two EXRs (being written).

use clap::Args;

use super::CliError;

#[derive(Debug, Args)]
pub struct CompareArgs {}

pub fn run(_a: CompareArgs) -> Result<(), CliError> {
    Err(CliError::failure(
        "candela compare is not available in this build yet",
    ))
}
