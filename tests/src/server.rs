//! Driving the real `candela serve` from tests: start it on a free loopback port with a scratch
//! data dir, talk JSON to it with a blocking reqwest client, read its SSE streams, stop it with
//! SIGTERM or SIGKILL. The server's stdout and stderr are collected for failure messages.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{mpsc, Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use reqwest::blocking::{Client, RequestBuilder, Response};
use serde_json::Value;

use crate::{candela, repo_root};

/// How long the server may take to print its address.
const STARTUP: Duration = Duration::from_secs(120);

/// A running `candela serve`, killed on drop.
pub struct Server {
    child: Child,
    /// `http://127.0.0.1:PORT`.
    pub url: String,
    pub data_dir: PathBuf,
    log: Arc<Mutex<String>>,
    client: Client,
}

fn pump(r: impl Read + Send + 'static, tx: mpsc::Sender<String>, log: Arc<Mutex<String>>) {
    thread::spawn(move || {
        for line in BufReader::new(r).lines().map_while(Result::ok) {
            if let Ok(mut l) = log.lock() {
                l.push_str(&line);
                l.push('\n');
            }
            let _ = tx.send(line);
        }
    });
}

/// The client used by the helpers: no overall timeout (SSE streams are long), short connect.
pub fn client() -> Client {
    Client::builder()
        .connect_timeout(Duration::from_secs(10))
        .timeout(None)
        .build()
        .expect("reqwest client")
}

impl Server {
    /// Starts `candela serve --bind 127.0.0.1:0 --data-dir DATA_DIR EXTRA...`.
    pub fn start(data_dir: &Path, extra: &[&str]) -> Server {
        Self::start_with_env(data_dir, extra, &[])
    }

    /// [`Server::start`] with environment variables.
    pub fn start_with_env(data_dir: &Path, extra: &[&str], env: &[(&str, &str)]) -> Server {
        let dir = data_dir.to_string_lossy().into_owned();
        let mut args = vec!["--bind", "127.0.0.1:0", "--data-dir", dir.as_str()];
        args.extend_from_slice(extra);
        Self::spawn(&args, data_dir, env)
    }

    /// Runs `candela serve ARGS...` (with `env`) and waits for its listening line.
    pub fn spawn(args: &[&str], data_dir: &Path, env: &[(&str, &str)]) -> Server {
        let mut cmd = Command::new(candela());
        cmd.arg("serve")
            .args(args)
            .current_dir(repo_root())
            .env("CANDELA_LOG", "info")
            .env_remove("CANDELA_TOKEN")
            .env_remove("CANDELA_DATABASE")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        if let Some(url) = crate::database::database_env(data_dir) {
            cmd.env("CANDELA_DATABASE", url);
        }
        for (k, v) in env {
            cmd.env(k, v);
        }
        let mut child = cmd.spawn().expect("start candela serve");
        let log = Arc::new(Mutex::new(String::new()));
        let (tx, rx) = mpsc::channel();
        pump(child.stdout.take().unwrap(), tx.clone(), log.clone());
        pump(child.stderr.take().unwrap(), tx, log.clone());
        let deadline = Instant::now() + STARTUP;
        let url = loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match rx.recv_timeout(left) {
                Ok(line) => {
                    if let Some(rest) = line.strip_prefix("candela: listening on ") {
                        break rest.trim().to_string();
                    }
                }
                Err(_) => {
                    let _ = child.kill();
                    panic!(
                        "candela serve did not report its address:\n{}",
                        log.lock().unwrap()
                    );
                }
            }
        };
        Server {
            child,
            url,
            data_dir: data_dir.to_path_buf(),
            log,
            client: client(),
        }
    }

    /// What the server printed so far.
    pub fn log(&self) -> String {
        self.log.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// `url + path`.
    pub fn at(&self, path: &str) -> String {
        format!("{}{path}", self.url)
    }

    /// A request builder for `method path`.
    pub fn request(&self, method: reqwest::Method, path: &str) -> RequestBuilder {
        self.client.request(method, self.at(path))
    }

    /// Sends a request and returns (status, JSON body or Null).
    pub fn send(&self, req: RequestBuilder) -> (u16, Value) {
        let r = req
            .timeout(Duration::from_secs(120))
            .send()
            .unwrap_or_else(|e| panic!("request failed: {e}\n{}", self.log()));
        let status = r.status().as_u16();
        let text = r.text().unwrap_or_default();
        (status, serde_json::from_str(&text).unwrap_or(Value::Null))
    }

    /// The `/metrics` text.
    pub fn metrics(&self) -> String {
        self.request(reqwest::Method::GET, "/metrics")
            .send()
            .and_then(|r| r.text())
            .unwrap_or_else(|e| panic!("GET /metrics: {e}\n{}", self.log()))
    }

    /// The value of one `/metrics` series (its name and labels as written, e.g.
    /// `candela_cache_entries{cache="kernels"}`).
    pub fn metric(&self, series: &str) -> f64 {
        let text = self.metrics();
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("{series} ")))
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("no {series} in\n{text}"))
    }

    /// `GET path` → (status, JSON).
    pub fn get(&self, path: &str) -> (u16, Value) {
        self.send(self.request(reqwest::Method::GET, path))
    }

    /// `POST path` with a JSON body → (status, JSON).
    pub fn post(&self, path: &str, body: &Value) -> (u16, Value) {
        self.send(self.request(reqwest::Method::POST, path).json(body))
    }

    /// `POST path` with a raw body → (status, JSON).
    pub fn post_raw(&self, path: &str, body: impl Into<reqwest::blocking::Body>) -> (u16, Value) {
        self.send(
            self.request(reqwest::Method::POST, path)
                .header("content-type", "application/json")
                .body(body),
        )
    }

    /// Submits a job; panics unless 201. Returns the job.
    pub fn submit(&self, body: &Value) -> Value {
        let (status, job) = self.post("/api/jobs", body);
        assert_eq!(status, 201, "{job}\n{}", self.log());
        job
    }

    /// `GET /api/jobs/{id}`.
    pub fn job(&self, id: i64) -> Value {
        let (status, job) = self.get(&format!("/api/jobs/{id}"));
        assert_eq!(status, 200, "{job}");
        job
    }

    /// Polls job `id` until `pred` holds (panics after `timeout`).
    pub fn wait_job(&self, id: i64, timeout: Duration, pred: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + timeout;
        loop {
            let job = self.job(id);
            if pred(&job) {
                return job;
            }
            if Instant::now() > deadline {
                panic!("job {id} never got there: {job}\n{}", self.log());
            }
            thread::sleep(Duration::from_millis(50));
        }
    }

    /// Opens job `id`'s event stream, optionally resuming after `last_event_id`.
    pub fn events(&self, id: i64, last_event_id: Option<i64>) -> SseReader {
        let mut req = self
            .request(reqwest::Method::GET, &format!("/api/jobs/{id}/events"))
            .timeout(Duration::from_secs(300));
        if let Some(n) = last_event_id {
            req = req.header("Last-Event-ID", n.to_string());
        }
        let r = req.send().expect("open event stream");
        assert_eq!(r.status().as_u16(), 200, "events of job {id}");
        SseReader::new(r)
    }

    /// Sends SIGTERM and waits (at most `timeout`) for the exit status.
    pub fn terminate(&mut self, timeout: Duration) -> ExitStatus {
        let ok = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        assert!(ok, "kill -TERM failed");
        self.wait_exit(timeout)
    }

    /// Sends SIGKILL (a crash) and reaps the process.
    pub fn kill9(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Waits for the process to exit.
    pub fn wait_exit(&mut self, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return status;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!("the server did not exit in {timeout:?}:\n{}", self.log());
            }
            thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One server-sent event.
#[derive(Debug, Clone)]
pub struct SseEvent {
    pub id: Option<i64>,
    pub event: String,
    pub data: Value,
}

/// Reads an SSE response event by event (comments are counted, not returned).
pub struct SseReader {
    lines: std::io::Lines<BufReader<Response>>,
    /// Comment lines seen (keep-alives).
    pub comments: usize,
}

impl SseReader {
    fn new(r: Response) -> Self {
        SseReader {
            lines: BufReader::new(r).lines(),
            comments: 0,
        }
    }

    /// The next event, or None when the stream ended.
    pub fn next_event(&mut self) -> Option<SseEvent> {
        let (mut id, mut event, mut data) = (None, String::from("message"), String::new());
        let mut any = false;
        loop {
            let line = match self.lines.next() {
                Some(Ok(l)) => l,
                _ => return None,
            };
            if line.is_empty() {
                if any {
                    return Some(SseEvent {
                        id,
                        event,
                        data: serde_json::from_str(&data).unwrap_or(Value::String(data)),
                    });
                }
                continue;
            }
            if line.starts_with(':') {
                self.comments += 1;
                continue;
            }
            any = true;
            let (field, value) = line.split_once(':').unwrap_or((line.as_str(), ""));
            let value = value.strip_prefix(' ').unwrap_or(value);
            match field {
                "id" => id = value.parse().ok(),
                "event" => event = value.to_string(),
                "data" => {
                    if !data.is_empty() {
                        data.push('\n');
                    }
                    data.push_str(value);
                }
                _ => {}
            }
        }
    }

    /// Every remaining event until the stream ends.
    pub fn collect_all(&mut self) -> Vec<SseEvent> {
        std::iter::from_fn(|| self.next_event()).collect()
    }
}
