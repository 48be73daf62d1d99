//! `candela serve`: the HTTP render server (being written).

use clap::Args;

use super::CliError;

#[derive(Debug, Args)]
pub struct ServeArgs {}

pub fn run(_a: ServeArgs) -> Result<(), CliError> {
    Err(CliError::failure(
        "candela serve is not available in this build yet",
    ))
}
