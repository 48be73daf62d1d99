//! `candela`: the render server's single binary. Subcommands: `render` (one image from a scene
//! file), `devices` (list Vulkan devices). The HTTP server (`serve`), `bench` and `compare`
//! arrive with their issues.
//!
//! Exit codes: 0 success, 2 bad input (a one-line error naming what and where), 1 any other
//! failure. No input may make it panic.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("CANDELA_LOG")
                .unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.message);
            ExitCode::from(e.code)
        }
    }
}
