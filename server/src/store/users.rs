//! Named users in the store: name, role and the SHA-256 of their token (the token itself is
//! never stored). Managed by `candela users`; read by the authentication on every request, so
//! a user added or removed takes effect at once, even while a server runs.

use super::db::params;
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
        self.write(|c| {
            if c.query_opt("SELECT name FROM users WHERE name = ?1", params![name])?
                .is_some()
            {
                return Err(StoreError::Db(format!("a user named \"{name}\" exists")));
            }
            c.exec(
                "INSERT INTO users (name, role, token_sha256, created_at) VALUES (?1, ?2, ?3, ?4)",
                params![name, role, token_sha256, now_s()],
            )?;
            Ok(((), Vec::new()))
        })
    }

    /// Removes a user; whether there was one.
    pub fn remove_user(&self, name: &str) -> Result<bool, StoreError> {
        self.read(|c| Ok(c.exec("DELETE FROM users WHERE name = ?1", params![name])? > 0))
    }

    /// Every user, by name.
    pub fn list_users(&self) -> Result<Vec<UserRecord>, StoreError> {
        let rows = self.read(|c| {
            c.query(
                "SELECT name, role, created_at FROM users ORDER BY name",
                &[],
            )
        })?;
        rows.iter()
            .map(|r| {
                Ok(UserRecord {
                    name: r.text(0)?,
                    role: r.text(1)?,
                    created_at: r.f64(2)?,
                })
            })
            .collect()
    }

    /// Number of users.
    pub fn user_count(&self) -> Result<u64, StoreError> {
        let n = self.read(|c| c.query_one("SELECT COUNT(*) FROM users", &[])?.i64(0))?;
        Ok(n.max(0) as u64)
    }

    /// The (name, role) of the user whose token hashes to `token_sha256`.
    pub fn user_by_token(
        &self,
        token_sha256: &str,
    ) -> Result<Option<(String, String)>, StoreError> {
        let row = self.read(|c| {
            c.query_opt(
                "SELECT name, role FROM users WHERE token_sha256 = ?1",
                params![token_sha256],
            )
        })?;
        row.map(|r| Ok((r.text(0)?, r.text(1)?))).transpose()
    }
}
