//! Who is calling, and what they may do. Three roles: `admin` (everything), `submitter` (reads
//! everything, submits jobs, manages only its own: cancel, pause, resume, priority, delete) and
//! `viewer` (reads only). Callers are named users (`candela users add NAME --role R`, their
//! token stored as its SHA-256) or the shared `--token`, which is an admin.
//!
//! With neither users nor a shared token the server is open (the zero-setup default, loopback
//! only: `candela serve` refuses other addresses): every caller is an unnamed admin.

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use sha2::{Digest, Sha256};

use crate::api_error::ApiError;
use crate::config::ServerConfig;
use crate::jobs::model::JobRecord;
use crate::store::Store;

/// What a caller may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    Admin,
    Submitter,
    Viewer,
}

impl Role {
    pub const NAMES: [&'static str; 3] = ["admin", "submitter", "viewer"];

    pub fn as_str(self) -> &'static str {
        match self {
            Role::Admin => "admin",
            Role::Submitter => "submitter",
            Role::Viewer => "viewer",
        }
    }

    pub fn parse(s: &str) -> Option<Role> {
        match s {
            "admin" => Some(Role::Admin),
            "submitter" => Some(Role::Submitter),
            "viewer" => Some(Role::Viewer),
            _ => None,
        }
    }
}

/// The caller of a request (put in the request's extensions by the authentication layer).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Caller {
    /// The user's name; None on an open server.
    pub name: Option<String>,
    pub role: Role,
}

/// The name recorded for changes made with the shared `--token`.
pub const SHARED_TOKEN_NAME: &str = "token";

impl Caller {
    /// Anyone, on a server without tokens.
    pub fn open() -> Caller {
        Caller {
            name: None,
            role: Role::Admin,
        }
    }

    /// 403 unless the caller may change things (not a viewer).
    pub fn may_write(&self) -> Result<(), ApiError> {
        match self.role {
            Role::Viewer => Err(ApiError::Forbidden(format!(
                "{} is a viewer: viewers may only read",
                self.describe()
            ))),
            _ => Ok(()),
        }
    }

    /// 403 unless the caller may manage `job`: an admin any job, a submitter its own.
    pub fn may_manage(&self, job: &JobRecord) -> Result<(), ApiError> {
        self.may_write()?;
        if self.role == Role::Admin || (self.name.is_some() && self.name == job.owner) {
            return Ok(());
        }
        Err(ApiError::Forbidden(format!(
            "job {} belongs to {}; {} (a submitter) manages only its own jobs",
            job.id,
            job.owner.as_deref().unwrap_or("no user"),
            self.describe()
        )))
    }

    fn describe(&self) -> String {
        match &self.name {
            Some(n) => format!("user \"{n}\""),
            None => "this caller".into(),
        }
    }
}

impl<S: Send + Sync> FromRequestParts<S> for Caller {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _state: &S) -> Result<Self, ApiError> {
        // Every API route passes the authentication layer, which puts the caller here.
        parts
            .extensions
            .get::<Caller>()
            .cloned()
            .ok_or_else(|| ApiError::internal("no caller: the route bypassed authentication"))
    }
}

/// Lowercase hex SHA-256 of a token.
pub fn token_hash(token: &str) -> String {
    Sha256::digest(token.trim().as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// A fresh token: `cdl_` and 32 random bytes in hex.
pub fn new_token() -> Result<String, String> {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes).map_err(|e| format!("no randomness: {e}"))?;
    Ok(format!(
        "cdl_{}",
        bytes.iter().map(|b| format!("{b:02x}")).collect::<String>()
    ))
}

/// Equal-time comparison of two secrets.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// Whether the server needs a token at all (a shared token or any user).
pub fn required(config: &ServerConfig, store: &Store) -> Result<bool, ApiError> {
    Ok(config.token.is_some() || store.user_count()? > 0)
}

/// The caller presenting `given` (a bearer token, if any): 401 when a token is needed and it
/// is missing or matches no one.
pub fn resolve(
    config: &ServerConfig,
    store: &Store,
    given: Option<&str>,
) -> Result<Caller, ApiError> {
    if !required(config, store)? {
        return Ok(Caller::open());
    }
    let given = given.map(str::trim).ok_or(ApiError::Unauthorized)?;
    if let Some(shared) = config.token.as_deref() {
        if same_secret(given.as_bytes(), shared.as_bytes()) {
            return Ok(Caller {
                name: Some(SHARED_TOKEN_NAME.into()),
                role: Role::Admin,
            });
        }
    }
    match store.user_by_token(&token_hash(given))? {
        Some((name, role)) => Ok(Caller {
            name: Some(name),
            role: Role::parse(&role).unwrap_or(Role::Viewer),
        }),
        None => Err(ApiError::Unauthorized),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_and_tokens() {
        // FIPS 180-2 test vector.
        assert_eq!(
            token_hash("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let (a, b) = (new_token().unwrap(), new_token().unwrap());
        assert!(a.starts_with("cdl_") && a.len() == 68 && a != b);
    }
}
