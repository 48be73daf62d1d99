//! `candela users add NAME --role R | list | remove NAME`: named tokens of a data directory.
//! (or of the `--database` it uses). `add` prints the new token once (only its SHA-256 is stored); changes take effect at once,
//! also on a server running on that directory.

use std::path::PathBuf;

use clap::{Args, Subcommand};

use super::CliError;
use crate::auth::{new_token, token_hash, Role};
use crate::jobs::model::rfc3339;
use crate::store::Store;

#[derive(Debug, Args)]
pub struct UsersArgs {
    /// The server's data directory (created if needed).
    #[arg(
        long = "data-dir",
        visible_alias = "data",
        default_value = "candela-data",
        global = true
    )]
    pub data_dir: PathBuf,
    /// The job store, as `candela serve --database` (default: $CANDELA_DATABASE, else
    /// <data-dir>/candela.db).
    #[arg(long, value_name = "URL", global = true)]
    pub database: Option<String>,
    #[command(subcommand)]
    pub command: UsersCommand,
}

#[derive(Debug, Subcommand)]
pub enum UsersCommand {
    /// Add a user and print its token (shown only this once).
    Add {
        /// Letters, digits, `.`, `_` or `-`, at most 64.
        name: String,
        /// admin (everything), submitter (submits; manages only its own jobs) or viewer (reads).
        #[arg(long, value_parser = Role::NAMES)]
        role: String,
    },
    /// List the users (name, role, created).
    List,
    /// Remove a user; its token stops working at once.
    Remove { name: String },
}

fn check_name(name: &str) -> Result<(), CliError> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if ok && name != crate::auth::SHARED_TOKEN_NAME {
        Ok(())
    } else {
        Err(CliError::input(format!(
            "user name \"{name}\": use 1 to 64 letters, digits, '.', '_' or '-' (and not \"{}\", the shared token's name)",
            crate::auth::SHARED_TOKEN_NAME
        )))
    }
}

pub fn run(a: UsersArgs) -> Result<(), CliError> {
    let dir = &a.data_dir;
    std::fs::create_dir_all(dir)
        .map_err(|e| CliError::failure(format!("--data-dir {}: {e}", dir.display())))?;
    let db = super::serve::database(a.database.as_deref(), dir)?;
    let store =
        Store::connect(&db).map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
    match a.command {
        UsersCommand::Add { name, role } => {
            check_name(&name)?;
            let token = new_token().map_err(CliError::failure)?;
            store
                .add_user(&name, &role, &token_hash(&token))
                .map_err(|e| CliError::input(e.to_string().replace("store: ", "")))?;
            eprintln!("added {role} \"{name}\"; its token (shown only now):");
            println!("{token}");
        }
        UsersCommand::List => {
            let users = store
                .list_users()
                .map_err(|e| CliError::failure(e.to_string()))?;
            for u in users {
                println!("{}\t{}\t{}", u.name, u.role, rfc3339(u.created_at));
            }
        }
        UsersCommand::Remove { name } => {
            let removed = store
                .remove_user(&name)
                .map_err(|e| CliError::failure(e.to_string()))?;
            if !removed {
                return Err(CliError::input(format!("no user \"{name}\"")));
            }
            println!("removed \"{name}\"");
        }
    }
    Ok(())
}
