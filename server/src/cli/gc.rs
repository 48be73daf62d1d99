//! `candela gc`: retention by hand. Removes finished jobs of a data directory (older than an age,
//! beyond a count, or while the job files exceed a size), prunes the event logs of finished jobs
//! and removes folders of no job; prints each thing removed. Safe beside a running server on the
//! same directory (it touches finished jobs only; the database arbitrates).

use std::path::PathBuf;

use clap::Args;

use super::CliError;
use crate::config::Database;
use crate::jobs::model::{now_s, rfc3339};
use crate::retention::{self, Policy};
use crate::store::Store;
use crate::units::{format_bytes, parse_duration, parse_size};

#[derive(Debug, Args)]
pub struct GcArgs {
    /// The server's data directory.
    #[arg(
        long = "data-dir",
        visible_alias = "data",
        default_value = "candela-data"
    )]
    pub data_dir: PathBuf,
    /// The job store, as `candela serve --database` (default: $CANDELA_DATABASE, else
    /// <data-dir>/candela.db).
    #[arg(long, value_name = "URL")]
    pub database: Option<String>,
    /// Remove finished jobs that ended longer ago than this (7d, 12h, 30m).
    #[arg(long, value_name = "AGE")]
    pub older_than: Option<String>,
    /// Keep only the newest N finished jobs.
    #[arg(long, value_name = "N")]
    pub keep: Option<u64>,
    /// Remove the oldest finished jobs while the job files exceed this (20GB, 500MB).
    #[arg(long, value_name = "SIZE")]
    pub max_size: Option<String>,
    /// Print what would be removed; change nothing.
    #[arg(long)]
    pub dry_run: bool,
}

pub fn run(a: GcArgs) -> Result<(), CliError> {
    // Step 1: the policy from the flags; event logs of every finished job are pruned.
    let policy = Policy {
        max_age: a
            .older_than
            .as_deref()
            .map(parse_duration)
            .transpose()
            .map_err(|e| CliError::input(format!("--older-than: {e}")))?,
        max_finished: a.keep,
        max_bytes: a
            .max_size
            .as_deref()
            .map(parse_size)
            .transpose()
            .map_err(|e| CliError::input(format!("--max-size: {e}")))?,
        prune_events_after: Some(std::time::Duration::ZERO),
    };
    // Step 2: the store (never created here: a wrong path is an error).
    let db = super::serve::database(a.database.as_deref(), &a.data_dir)?;
    let missing = match &db {
        Database::Sqlite(path) => !path.is_file(),
        Database::Postgres(_) => !a.data_dir.join("jobs").is_dir(),
    };
    if missing {
        return Err(CliError::input(format!(
            "--data-dir {}: no candela.db there (not a candela data directory)",
            a.data_dir.display()
        )));
    }
    let store =
        Store::connect(&db).map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
    // Step 3: the pass, and what it did.
    let report = retention::run(&store, &a.data_dir, &policy, now_s(), a.dry_run)
        .map_err(|e| CliError::failure(e.to_string()))?;
    let verb = if a.dry_run { "would remove" } else { "removed" };
    for r in &report.removed {
        let j = &r.job;
        println!(
            "{verb} job {} \"{}\" ({}, finished {}, {}): {}",
            j.id,
            j.name,
            j.state.as_str(),
            rfc3339(j.finished_at.unwrap_or(j.updated_at)),
            format_bytes(r.bytes),
            r.reason
        );
    }
    for (dir, bytes) in &report.orphans {
        println!(
            "{verb} folder of no job {} ({})",
            dir.display(),
            format_bytes(*bytes)
        );
    }
    println!(
        "{} {} events of finished jobs",
        if a.dry_run { "would prune" } else { "pruned" },
        report.events_pruned
    );
    println!(
        "{} job(s), {} {}",
        report.removed.len(),
        format_bytes(report.bytes()),
        if a.dry_run { "would be freed" } else { "freed" }
    );
    Ok(())
}
