//! Named users in the store: name, role and the SHA-256 of their token (the token itself is
//! never stored). Managed by `candela users`; read by the authentication on every request, so
//! a user added or removed takes effect at once, even while a server runs.

use rusqlite::{params, OptionalExtension};

use super::{Store, StoreError};
use crate::jobs::model::now_s;

/// A user as stored.
#[derive(Debug, Clone)]
pub struct UserRecord {
    pub name: String,
    pub role: String,
    /// Unix seconds.
    pub created_at: f64,
}

impl Store {
    /// Adds a user; Conflict when the name is taken.
    pub fn add_user(&self, name: &str, role: &str, token_sha256: &str) -> Result<(), StoreError> {
        let conn = self.conn();
        let taken: Option<String> = conn
            .query_row(
                "SELECT name FROM users WHERE name = ?1",
                params![name],
                |r| r.get(0),
            )
            .optional()?;
        if taken.is_some() {
            return Err(StoreError::Db(format!("a user named \"{name}\" exists")));
        }
        conn.execute(
            "INSERT INTO users (name, role, token_sha256, created_at) VALUES (?1, ?2, ?3, ?4)",
            params![name, role, token_sha256, now_s()],
        )?;
        Ok(())
    }

    /// Removes a user; whether there was one.
    pub fn remove_user(&self, name: &str) -> Result<bool, StoreError> {
        let conn = self.conn();
        Ok(conn.execute("DELETE FROM users WHERE name = ?1", params![name])? > 0)
    }

    /// Every user, by name.
    pub fn list_users(&self) -> Result<Vec<UserRecord>, StoreError> {
        let conn = self.conn();
        let mut stmt =
            conn.prepare_cached("SELECT name, role, created_at FROM users ORDER BY name")?;
        let rows = stmt.query_map([], |r| {
            Ok(UserRecord {
                name: r.get(0)?,
                role: r.get(1)?,
                created_at: r.get(2)?,
            })
        })?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Number of users.
    pub fn user_count(&self) -> Result<u64, StoreError> {
        let conn = self.conn();
        let n: i64 = conn.query_row("SELECT COUNT(*) FROM users", [], |r| r.get(0))?;
        Ok(n.max(0) as u64)
    }

    /// The (name, role) of the user whose token hashes to `token_sha256`.
    pub fn user_by_token(
        &self,
        token_sha256: &str,
    ) -> Result<Option<(String, String)>, StoreError> {
        let conn = self.conn();
        Ok(conn
            .query_row(
                "SELECT name, role FROM users WHERE token_sha256 = ?1",
                params![token_sha256],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .optional()?)
    }
}
