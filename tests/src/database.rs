//! Running server tests on both job-store backends. [`on_both_databases!`] turns test functions
//! into `NAME::sqlite` and `NAME::postgres` tests. On PostgreSQL, a throwaway cluster is started
//! once per test process (initdb into a scratch folder, `postgres` on a free loopback port, as
//! the unprivileged `nobody` when the tests run as root, which PostgreSQL refuses) and stopped
//! and removed when the process exits; each data directory a test uses gets a fresh database,
//! passed to every `candela` the helpers start as `$CANDELA_DATABASE`.
//!
//! `CANDELA_SKIP_POSTGRES=1` skips the PostgreSQL variants (printing so); without it, missing
//! PostgreSQL binaries fail the test.

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// A job-store backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    Postgres,
}

thread_local! {
    static BACKEND: Cell<Backend> = const { Cell::new(Backend::Sqlite) };
    /// Data directory → its database URL (PostgreSQL tests).
    static DATABASES: RefCell<HashMap<PathBuf, String>> = RefCell::new(HashMap::new());
}

/// `on_both_databases!(a, b)`: tests `a::sqlite`, `a::postgres`, `b::sqlite`, `b::postgres`
/// running the plain functions `a` and `b` on each backend.
#[macro_export]
macro_rules! on_both_databases {
    ($($name:ident),* $(,)?) => {$(
        mod $name {
            #[test]
            fn sqlite() {
                $crate::database::run_on($crate::database::Backend::Sqlite, super::$name)
            }
            #[test]
            fn postgres() {
                $crate::database::run_on($crate::database::Backend::Postgres, super::$name)
            }
        }
    )*};
}

/// Runs `test` with the servers and commands it starts on `backend`.
pub fn run_on(backend: Backend, test: fn()) {
    if backend == Backend::Postgres {
        if std::env::var("CANDELA_SKIP_POSTGRES").as_deref() == Ok("1") {
            eprintln!("skipped: CANDELA_SKIP_POSTGRES=1 (this test's PostgreSQL variant)");
            return;
        }
        cluster(); // fails here when PostgreSQL is missing
    }
    BACKEND.with(|b| b.set(backend));
    DATABASES.with(|d| d.borrow_mut().clear());
    test();
    BACKEND.with(|b| b.set(Backend::Sqlite));
}

/// The backend of the running test.
pub fn backend() -> Backend {
    BACKEND.with(Cell::get)
}

/// The `$CANDELA_DATABASE` for a `candela` using `data_dir` (None: the default SQLite file).
pub fn database_env(data_dir: &Path) -> Option<String> {
    if backend() == Backend::Sqlite {
        return None;
    }
    let key = std::path::absolute(data_dir).unwrap_or_else(|_| data_dir.to_path_buf());
    Some(DATABASES.with(|d| {
        d.borrow_mut()
            .entry(key)
            .or_insert_with(|| cluster().create_database())
            .clone()
    }))
}

/// The store's bytes as kept on disk: the SQLite file, or a `pg_dump` of the database.
pub fn store_bytes(data_dir: &Path) -> Vec<u8> {
    match database_env(data_dir) {
        None => std::fs::read(data_dir.join("candela.db")).expect("read candela.db"),
        Some(url) => {
            let c = cluster();
            let o = Command::new(c.tool("pg_dump"))
                .arg(&url)
                .output()
                .expect("run pg_dump");
            assert!(
                o.status.success(),
                "pg_dump: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            o.stdout
        }
    }
}

/// A throwaway PostgreSQL cluster, stopped and removed when the test process exits.
pub struct Cluster {
    bin: PathBuf,
    port: u16,
    next: Mutex<u32>,
    /// The stop-and-clean-up wrapper; its stdin closes when this process exits.
    _keeper: Mutex<(Child, ChildStdin)>,
}

/// Where the PostgreSQL server binaries are: `$PATH`, else Debian's /usr/lib/postgresql/N/bin.
fn find_bin() -> Option<PathBuf> {
    let on_path = std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .find(|d| d.join("initdb").is_file() && d.join("postgres").is_file())
    });
    on_path.or_else(|| {
        let mut dirs: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
            .ok()?
            .flatten()
            .map(|e| e.path().join("bin"))
            .filter(|d| d.join("initdb").is_file())
            .collect();
        dirs.sort();
        dirs.pop()
    })
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// `program args` as shell words, run as `nobody` when we are root.
fn as_server_user(program: &Path) -> Command {
    if is_root() {
        let mut c = Command::new("runuser");
        c.args(["-u", "nobody", "--"]).arg(program);
        c
    } else {
        Command::new(program)
    }
}

/// The cluster of this test process, started at the first call.
pub fn cluster() -> &'static Cluster {
    static CLUSTER: OnceLock<Cluster> = OnceLock::new();
    CLUSTER.get_or_init(start)
}

fn start() -> Cluster {
    let bin = find_bin().unwrap_or_else(|| {
        panic!(
            "PostgreSQL is not installed (no initdb/postgres on PATH or in /usr/lib/postgresql/*/bin): \
             run scripts/setup.sh, or set CANDELA_SKIP_POSTGRES=1 to skip the PostgreSQL tests"
        )
    });
    // Step 1: a folder the server user owns (the system temp dir: short socket paths).
    let dir = std::env::temp_dir().join(format!("candela-pg-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("cluster dir");
    if is_root() {
        let ok = Command::new("chown")
            .args(["-R", "nobody"])
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "chown nobody {}", dir.display());
    }
    let data = dir.join("data");
    // Step 2: initdb, trusting local connections of user `candela`.
    let o = as_server_user(&bin.join("initdb"))
        .args([
            "-A",
            "trust",
            "-U",
            "candela",
            "-E",
            "UTF8",
            "--no-sync",
            "-D",
        ])
        .arg(&data)
        .output()
        .expect("run initdb");
    assert!(
        o.status.success(),
        "initdb: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Step 3: the server on a free port, under a shell that stops it (fast shutdown) and removes
    // the folder once our end of its stdin closes, i.e. when this test process exits.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("free port")
        .port();
    let script = format!(
        "{postgres} -D {data} -p {port} -k {dir} -c listen_addresses=127.0.0.1 -c fsync=off \
         > {dir}/log 2>&1 & p=$!; cat > /dev/null; kill -INT $p; wait $p; rm -rf {dir}",
        postgres = bin.join("postgres").display(),
        data = data.display(),
        dir = dir.display(),
    );
    let mut child = as_server_user(Path::new("sh"))
        .args(["-c", &script])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start postgres");
    let stdin = child.stdin.take().expect("stdin");
    let cluster = Cluster {
        bin,
        port,
        next: Mutex::new(0),
        _keeper: Mutex::new((child, stdin)),
    };
    // Step 4: wait until it accepts connections.
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let ready = Command::new(cluster.tool("pg_isready"))
            .args(["-q", "-h", "127.0.0.1", "-p", &port.to_string()])
            .status()
            .is_ok_and(|s| s.success());
        if ready {
            break;
        }
        let log = std::fs::read_to_string(dir.join("log")).unwrap_or_default();
        assert!(Instant::now() < deadline, "postgres did not start:\n{log}");
        std::thread::sleep(Duration::from_millis(100));
    }
    cluster
}

impl Cluster {
    /// A client tool: beside the server binaries, else on `$PATH`.
    pub fn tool(&self, name: &str) -> PathBuf {
        let beside = self.bin.join(name);
        if beside.is_file() {
            beside
        } else {
            PathBuf::from(name)
        }
    }

    /// The connection URL of database `name`.
    pub fn url(&self, name: &str) -> String {
        format!("postgres://candela@127.0.0.1:{}/{name}", self.port)
    }

    /// Creates a fresh database; its URL.
    pub fn create_database(&self) -> String {
        let name = {
            let mut n = self.next.lock().unwrap_or_else(|p| p.into_inner());
            *n += 1;
            format!("t{}_{}", std::process::id(), *n)
        };
        let o = Command::new(self.tool("psql"))
            .args(["-q", "-v", "ON_ERROR_STOP=1", &self.url("postgres"), "-c"])
            .arg(format!("CREATE DATABASE {name}"))
            .output()
            .expect("run psql");
        assert!(
            o.status.success(),
            "CREATE DATABASE: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        self.url(&name)
    }
}
