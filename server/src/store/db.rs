//! The store's two database backends behind one small interface: statements are written once,
//! in the SQL both SQLite and PostgreSQL accept, with `?N` placeholders (rewritten to `$N` for
//! PostgreSQL); parameters and columns are [`Value`]s. The few spots where the dialects differ
//! ask [`Dialect`]. [`Store::read`] runs statements outside a transaction, [`Store::write`]
//! inside one; both hold the store's single connection for the whole call, which is what keeps
//! the event broadcast in event id order (events.rs).

use std::sync::{Mutex, MutexGuard};

use rusqlite::types::ValueRef;

use super::events::StoredEvent;
use super::postgres::Pg;
use super::{Store, StoreError};

/// A parameter or a column value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Null,
    Int(i64),
    Real(f64),
    Text(String),
}

impl From<i64> for Value {
    fn from(v: i64) -> Self {
        Value::Int(v)
    }
}
impl From<u32> for Value {
    fn from(v: u32) -> Self {
        Value::Int(v.into())
    }
}
impl From<f64> for Value {
    fn from(v: f64) -> Self {
        Value::Real(v)
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Self {
        Value::Text(v.to_string())
    }
}
impl From<String> for Value {
    fn from(v: String) -> Self {
        Value::Text(v)
    }
}
impl From<&String> for Value {
    fn from(v: &String) -> Self {
        Value::Text(v.clone())
    }
}
impl<T: Into<Value>> From<Option<T>> for Value {
    fn from(v: Option<T>) -> Self {
        v.map_or(Value::Null, Into::into)
    }
}

/// `params![a, b]`: a parameter list.
macro_rules! params {
    ($($v:expr),* $(,)?) => { &[$($crate::store::db::Value::from($v)),*][..] };
}
pub(super) use params;

/// One result row.
#[derive(Debug)]
pub struct Row(pub Vec<Value>);

impl Row {
    fn at(&self, i: usize) -> Result<&Value, StoreError> {
        self.0
            .get(i)
            .ok_or_else(|| StoreError::Db(format!("no column {i}")))
    }
    fn bad(i: usize, what: &str) -> StoreError {
        StoreError::Db(format!("column {i}: expected {what}"))
    }
    pub fn i64(&self, i: usize) -> Result<i64, StoreError> {
        match self.at(i)? {
            Value::Int(v) => Ok(*v),
            _ => Err(Self::bad(i, "an integer")),
        }
    }
    pub fn opt_i64(&self, i: usize) -> Result<Option<i64>, StoreError> {
        match self.at(i)? {
            Value::Int(v) => Ok(Some(*v)),
            Value::Null => Ok(None),
            _ => Err(Self::bad(i, "an integer")),
        }
    }
    pub fn f64(&self, i: usize) -> Result<f64, StoreError> {
        self.opt_f64(i)?.ok_or_else(|| Self::bad(i, "a number"))
    }
    pub fn opt_f64(&self, i: usize) -> Result<Option<f64>, StoreError> {
        match self.at(i)? {
            Value::Real(v) => Ok(Some(*v)),
            Value::Int(v) => Ok(Some(*v as f64)),
            Value::Null => Ok(None),
            Value::Text(_) => Err(Self::bad(i, "a number")),
        }
    }
    pub fn text(&self, i: usize) -> Result<String, StoreError> {
        self.opt_text(i)?.ok_or_else(|| Self::bad(i, "text"))
    }
    pub fn opt_text(&self, i: usize) -> Result<Option<String>, StoreError> {
        match self.at(i)? {
            Value::Text(v) => Ok(Some(v.clone())),
            Value::Null => Ok(None),
            _ => Err(Self::bad(i, "text")),
        }
    }
}

/// Which SQL dialect a connection speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dialect {
    Sqlite,
    Postgres,
}

impl Dialect {
    /// Appended to a `SELECT` that reads a row the transaction then changes: PostgreSQL locks the
    /// row (other processes share the database); SQLite's write transaction already excludes
    /// every other writer.
    pub fn for_update(self) -> &'static str {
        match self {
            Dialect::Sqlite => "",
            Dialect::Postgres => " FOR UPDATE",
        }
    }
    /// Appended to the `SELECT` that picks a job to claim (leases.rs): PostgreSQL locks the row
    /// and passes over rows other processes are claiming; SQLite's write transaction already
    /// excludes every other writer.
    pub fn skip_locked(self) -> &'static str {
        match self {
            Dialect::Sqlite => "",
            Dialect::Postgres => " FOR UPDATE SKIP LOCKED",
        }
    }
    /// The position of a substring (1-based, 0 when absent): `instr(hay, needle)` in SQLite,
    /// `strpos(hay, needle)` in PostgreSQL.
    pub fn instr(self) -> &'static str {
        match self {
            Dialect::Sqlite => "instr",
            Dialect::Postgres => "strpos",
        }
    }
}

/// A connection (or transaction) statements run on.
pub trait Conn {
    fn dialect(&self) -> Dialect;
    /// Runs a statement; the number of rows changed.
    fn exec(&mut self, sql: &str, params: &[Value]) -> Result<u64, StoreError>;
    /// Runs a query; its rows.
    fn query(&mut self, sql: &str, params: &[Value]) -> Result<Vec<Row>, StoreError>;
    /// Runs several `;`-separated statements without parameters.
    fn batch(&mut self, sql: &str) -> Result<(), StoreError>;

    /// The first row, if any.
    fn query_opt(&mut self, sql: &str, params: &[Value]) -> Result<Option<Row>, StoreError> {
        Ok(self.query(sql, params)?.into_iter().next())
    }
    /// The first row, which must exist.
    fn query_one(&mut self, sql: &str, params: &[Value]) -> Result<Row, StoreError> {
        self.query_opt(sql, params)?
            .ok_or_else(|| StoreError::Db("a query returned no row".into()))
    }
}

/// SQLite: rusqlite's connection (a transaction derefs to it).
pub struct SqliteConn<'a>(pub &'a rusqlite::Connection);

fn sqlite_params(params: &[Value]) -> Vec<rusqlite::types::Value> {
    use rusqlite::types::Value as V;
    params
        .iter()
        .map(|p| match p {
            Value::Null => V::Null,
            Value::Int(v) => V::Integer(*v),
            Value::Real(v) => V::Real(*v),
            Value::Text(v) => V::Text(v.clone()),
        })
        .collect()
}

impl Conn for SqliteConn<'_> {
    fn dialect(&self) -> Dialect {
        Dialect::Sqlite
    }
    fn exec(&mut self, sql: &str, params: &[Value]) -> Result<u64, StoreError> {
        let mut stmt = self.0.prepare_cached(sql)?;
        let n = stmt.execute(rusqlite::params_from_iter(sqlite_params(params)))?;
        Ok(n as u64)
    }
    fn query(&mut self, sql: &str, params: &[Value]) -> Result<Vec<Row>, StoreError> {
        let mut stmt = self.0.prepare_cached(sql)?;
        let n = stmt.column_count();
        let rows = stmt.query_map(rusqlite::params_from_iter(sqlite_params(params)), |r| {
            (0..n)
                .map(|i| {
                    Ok(match r.get_ref(i)? {
                        ValueRef::Null => Value::Null,
                        ValueRef::Integer(v) => Value::Int(v),
                        ValueRef::Real(v) => Value::Real(v),
                        ValueRef::Text(t) | ValueRef::Blob(t) => {
                            Value::Text(String::from_utf8_lossy(t).into_owned())
                        }
                    })
                })
                .collect::<rusqlite::Result<Vec<_>>>()
                .map(Row)
        })?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }
    fn batch(&mut self, sql: &str) -> Result<(), StoreError> {
        Ok(self.0.execute_batch(sql)?)
    }
}

/// The database a store talks to; [`Store::read`] and [`Store::write`] are the only places that
/// look inside.
pub enum Backend {
    Sqlite(Mutex<rusqlite::Connection>),
    Postgres(Pg),
}

impl Backend {
    /// The SQLite connection (a poisoned lock is recovered: SQLite keeps itself consistent).
    fn sqlite(m: &Mutex<rusqlite::Connection>) -> MutexGuard<'_, rusqlite::Connection> {
        m.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl Store {
    /// Runs `f` on the connection, outside a transaction.
    pub(super) fn read<T>(
        &self,
        f: impl FnOnce(&mut dyn Conn) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        match &self.db {
            Backend::Sqlite(m) => f(&mut SqliteConn(&Backend::sqlite(m))),
            Backend::Postgres(pg) => pg.read(f),
        }
    }

    /// Runs `f` in a transaction, committed when `f` succeeds (rolled back otherwise), then
    /// broadcasts the events `f` returned — still holding the connection, so that subscribers
    /// see events in id order.
    pub(super) fn write<T>(
        &self,
        f: impl FnOnce(&mut dyn Conn) -> Result<(T, Vec<StoredEvent>), StoreError>,
    ) -> Result<T, StoreError> {
        // Relaying: the jobs written to, whose new events are then broadcast from the table.
        let mut touched = Vec::new();
        let mut deliver = |events: Vec<StoredEvent>| match &self.relay {
            Some(_) => touched.extend(events.iter().map(|e| e.job_id)),
            None => self.broadcast(events),
        };
        let out = match &self.db {
            Backend::Sqlite(m) => {
                let mut conn = Backend::sqlite(m);
                let tx = conn.transaction()?;
                let (out, events) = f(&mut SqliteConn(&tx))?;
                tx.commit()?;
                deliver(events);
                out
            }
            Backend::Postgres(pg) => pg.write(f, deliver)?,
        };
        if !touched.is_empty() {
            // Committed already: a failure here only delays the broadcast to the next poll.
            let _ = self.relay_jobs(Some(&touched));
        }
        Ok(out)
    }
}
