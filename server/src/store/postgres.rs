//! The PostgreSQL backend: one `tokio-postgres` connection per store. Its socket is driven by a
//! thread of its own (a one-thread tokio runtime that runs nothing else), and the store's calls
//! wait for their results with a plain `block_on` on the calling thread. So a store call behaves
//! like the SQLite one — it blocks its caller for one short statement — from anywhere: an async
//! handler on the server's runtime, a blocking task, the GPU worker thread or a CLI command (the
//! `postgres` crate's own runtime would panic inside the server's). A lost connection (the
//! database restarted) fails the calls in flight and is opened again by the next call.

use std::error::Error;
use std::sync::{Mutex, MutexGuard};

use bytes::BytesMut;
use futures_executor::block_on;
use tokio_postgres::types::{to_sql_checked, IsNull, ToSql, Type};
use tokio_postgres::{Client, NoTls, Transaction};

use super::db::{Conn, Dialect, Row, Value};
use super::events::StoredEvent;
use super::StoreError;

impl From<tokio_postgres::Error> for StoreError {
    fn from(e: tokio_postgres::Error) -> Self {
        // `Display` of a server error is only "db error"; its message says what went wrong.
        match e.as_db_error() {
            Some(db) => StoreError::Db(format!("postgres: {}", db.message())),
            None => StoreError::Db(format!("postgres: {e}")),
        }
    }
}

/// A connection string `postgres://…` and its (re)opened connection.
pub struct Pg {
    url: String,
    client: Mutex<Option<Client>>,
}

/// Opens a connection; its socket is driven by a thread named `candela-pg`.
fn connect(url: &str) -> Result<Client, StoreError> {
    let (tx, rx) = std::sync::mpsc::channel();
    let url = url.to_string();
    std::thread::Builder::new()
        .name("candela-pg".into())
        .spawn(move || {
            let rt = match tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            {
                Ok(rt) => rt,
                Err(e) => return drop(tx.send(Err(StoreError::Db(e.to_string())))),
            };
            rt.block_on(async move {
                match tokio_postgres::connect(&url, NoTls).await {
                    Ok((client, connection)) => {
                        let _ = tx.send(Ok(client));
                        if let Err(e) = connection.await {
                            tracing::warn!("postgres connection lost: {e}");
                        }
                    }
                    Err(e) => drop(tx.send(Err(e.into()))),
                }
            });
        })
        .map_err(|e| StoreError::Db(e.to_string()))?;
    rx.recv()
        .map_err(|_| StoreError::Db("postgres: the connection thread ended".into()))?
}

impl Pg {
    /// Connects to `url` (fails at once when the database cannot be reached).
    pub fn open(url: &str) -> Result<Pg, StoreError> {
        let client = connect(url)?;
        Ok(Pg {
            url: url.to_string(),
            client: Mutex::new(Some(client)),
        })
    }

    /// The open connection, reopened when it was lost.
    fn client(&self) -> Result<MutexGuard<'_, Option<Client>>, StoreError> {
        let mut guard = self.client.lock().unwrap_or_else(|p| p.into_inner());
        if guard.as_ref().is_none_or(Client::is_closed) {
            *guard = None;
            *guard = Some(connect(&self.url)?);
        }
        Ok(guard)
    }

    pub fn read<T>(
        &self,
        f: impl FnOnce(&mut dyn Conn) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let guard = self.client()?;
        let client = guard.as_ref().expect("connected");
        f(&mut PgConn::Client(client))
    }

    pub fn write<T>(
        &self,
        f: impl FnOnce(&mut dyn Conn) -> Result<(T, Vec<StoredEvent>), StoreError>,
        broadcast: impl FnOnce(Vec<StoredEvent>),
    ) -> Result<T, StoreError> {
        let mut guard = self.client()?;
        let client = guard.as_mut().expect("connected");
        let tx = block_on(client.transaction())?;
        let (out, events) = f(&mut PgConn::Tx(&tx))?;
        block_on(tx.commit())?;
        broadcast(events);
        Ok(out)
    }
}

/// A PostgreSQL connection or transaction.
enum PgConn<'a> {
    Client(&'a Client),
    Tx(&'a Transaction<'a>),
}

/// `?N` placeholders become `$N`.
fn dollar(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len());
    let mut chars = sql.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '?' && chars.peek().is_some_and(char::is_ascii_digit) {
            out.push('$');
        } else {
            out.push(c);
        }
    }
    out
}

/// A PostgreSQL column as a [`Value`].
fn column(row: &tokio_postgres::Row, i: usize) -> Result<Value, StoreError> {
    let ty = row.columns()[i].type_();
    let v = if *ty == Type::INT8 {
        row.try_get::<_, Option<i64>>(i)?.map(Value::Int)
    } else if *ty == Type::INT4 {
        row.try_get::<_, Option<i32>>(i)?
            .map(|v| Value::Int(v.into()))
    } else if *ty == Type::INT2 {
        row.try_get::<_, Option<i16>>(i)?
            .map(|v| Value::Int(v.into()))
    } else if *ty == Type::BOOL {
        row.try_get::<_, Option<bool>>(i)?
            .map(|v| Value::Int(v.into()))
    } else if *ty == Type::FLOAT8 {
        row.try_get::<_, Option<f64>>(i)?.map(Value::Real)
    } else if *ty == Type::FLOAT4 {
        row.try_get::<_, Option<f32>>(i)?
            .map(|v| Value::Real(v.into()))
    } else {
        row.try_get::<_, Option<String>>(i)?.map(Value::Text)
    };
    Ok(v.unwrap_or(Value::Null))
}

impl ToSql for Value {
    fn to_sql(
        &self,
        ty: &Type,
        out: &mut BytesMut,
    ) -> Result<IsNull, Box<dyn Error + Sync + Send>> {
        match self {
            Value::Null => Ok(IsNull::Yes),
            Value::Int(v) if *ty == Type::INT4 => i32::try_from(*v)?.to_sql(ty, out),
            Value::Int(v) if *ty == Type::INT2 => i16::try_from(*v)?.to_sql(ty, out),
            Value::Int(v) if *ty == Type::FLOAT8 => (*v as f64).to_sql(ty, out),
            Value::Int(v) if *ty == Type::INT8 => v.to_sql(ty, out),
            Value::Int(v) => v.to_string().to_sql(ty, out),
            Value::Real(v) if *ty == Type::FLOAT8 => v.to_sql(ty, out),
            Value::Real(v) => Err(format!("a number ({v}) for a {ty} parameter").into()),
            Value::Text(v) => v.to_sql(ty, out),
        }
    }
    fn accepts(_: &Type) -> bool {
        true
    }
    to_sql_checked!();
}

impl PgConn<'_> {
    fn run_query(
        &self,
        sql: &str,
        params: &[Value],
    ) -> Result<Vec<tokio_postgres::Row>, StoreError> {
        let sql = dollar(sql);
        let p: Vec<&(dyn ToSql + Sync)> = params.iter().map(|v| v as _).collect();
        Ok(match self {
            PgConn::Client(c) => block_on(c.query(&sql, &p))?,
            PgConn::Tx(t) => block_on(t.query(&sql, &p))?,
        })
    }
}

impl Conn for PgConn<'_> {
    fn dialect(&self) -> Dialect {
        Dialect::Postgres
    }
    fn exec(&mut self, sql: &str, params: &[Value]) -> Result<u64, StoreError> {
        let sql = dollar(sql);
        let p: Vec<&(dyn ToSql + Sync)> = params.iter().map(|v| v as _).collect();
        Ok(match self {
            PgConn::Client(c) => block_on(c.execute(&sql, &p))?,
            PgConn::Tx(t) => block_on(t.execute(&sql, &p))?,
        })
    }
    fn query(&mut self, sql: &str, params: &[Value]) -> Result<Vec<Row>, StoreError> {
        self.run_query(sql, params)?
            .iter()
            .map(|r| {
                (0..r.len())
                    .map(|i| column(r, i))
                    .collect::<Result<_, _>>()
                    .map(Row)
            })
            .collect()
    }
    fn batch(&mut self, sql: &str) -> Result<(), StoreError> {
        match self {
            PgConn::Client(c) => block_on(c.batch_execute(sql))?,
            PgConn::Tx(t) => block_on(t.batch_execute(sql))?,
        }
        Ok(())
    }
}
