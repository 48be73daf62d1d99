//! `candela`: the render server's single binary. Subcommands: `render` (one image from a scene
//! file), `serve` (the HTTP render server and web viewer), `worker` (a render farm process), `bench`, `compare`, `convert`, `gc`,
//! `users`, `devices`.
//!
//! Exit codes: 0 success, 2 bad input (a one-line error naming what and where), 1 any other
//! failure. No input may make it panic.
//!
//! The server's modules: `app` (router), `auth` (tokens, roles), `state` (what handlers reach),
//! `routes/` (handlers), `jobs/` (model, requests, uploads), `store/` (SQLite or PostgreSQL:
//! jobs, event log, users), `worker/` (GPU thread, scheduler, checkpoints, storage holds),
//! `shared` (snapshots, metrics), `retention` (deleting finished jobs), `storage` (free space), `builtin_scenes`,
//! `config`, `units`, `api_error`.

mod api_error;
mod app;
mod auth;
mod benchmark;
mod builtin_scenes;
mod cli;
mod config;
mod jobs;
mod process_memory;
mod retention;
mod routes;
mod shared;
mod state;
mod storage;
mod store;
mod units;
mod worker;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    if quiet_on_closed_pipe(&args.command) {
        // A reader that stops early (`candela compare … | head`) ends the process as it ends
        // other Unix tools, instead of a write error that `println!` turns into a panic. Rust
        // ignores SIGPIPE by default; the commands that hold network connections (serve, worker,
        // and gc / users with a PostgreSQL store) keep that, so a broken socket is an error.
        // SAFETY: setting a signal's disposition before any thread starts.
        #[cfg(unix)]
        unsafe {
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
    }
    // The server logs what it does (info); the one-shot commands only warnings.
    let default_filter = match args.command {
        cli::Command::Serve(_) | cli::Command::Worker(_) => "warn,candela=info",
        _ => "warn",
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("CANDELA_LOG")
                .unwrap_or_else(|_| default_filter.into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.message);
            ExitCode::from(e.code)
        }
    }
}

/// The commands that only read and write local files and standard output.
fn quiet_on_closed_pipe(command: &cli::Command) -> bool {
    use cli::Command::*;
    matches!(
        command,
        Render(_) | Bench(_) | Compare(_) | Convert(_) | Devices { .. }
    )
}
