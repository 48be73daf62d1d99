//! The web viewer in headless Chromium: starts the real `candela serve` on a free loopback port
//! with a scratch data dir, runs tests/browser/viewer.test.mjs against it (playwright-core driving
//! the system /usr/bin/chromium: submit the Cornell box, watch it refine, exposure/tonemap, job
//! controls, A/B view, uploads, a job with a reference and its live error chart beside the
//! image), stops the server and checks the run passed and left its
//! screenshots in target/test-scratch/browser_viewer{,_token}/screenshots/ (viewer.png first).
//! Once without and once with a bearer token.
//!
//! Needs node, Debian's `chromium` and `npm ci --prefix tests/browser` (scripts/setup.sh does all
//! three).

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use candela_tests::{candela, repo_root, scratch};

/// How long the server may take to print its address (GPU context creation included).
const STARTUP: Duration = Duration::from_secs(120);
/// The browser script's own limit is 10 minutes; this is a backstop.
const BROWSER_RUN: Duration = Duration::from_secs(11 * 60);

/// A running `candela serve`, killed on drop; its stdout and stderr are collected in `log`.
struct Server {
    child: Child,
    url: String,
    log: Arc<Mutex<String>>,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Forwards each line of `r` to `tx` and appends it to `log`, until the pipe closes.
fn pump_lines(r: impl Read + Send + 'static, tx: mpsc::Sender<String>, log: Arc<Mutex<String>>) {
    thread::spawn(move || {
        for line in BufReader::new(r).lines().map_while(Result::ok) {
            {
                let mut l = log.lock().unwrap();
                l.push_str(&line);
                l.push('\n');
            }
            let _ = tx.send(line);
        }
    });
}

/// Starts `candela serve --bind 127.0.0.1:0 --data-dir DIR [--token T]` and waits for its
/// `listening on http://ADDR` line.
fn start_server(data_dir: &Path, token: Option<&str>) -> Server {
    let mut cmd = Command::new(candela());
    cmd.args(["serve", "--bind", "127.0.0.1:0", "--data-dir"])
        .arg(data_dir)
        .env_remove("CANDELA_TOKEN");
    if let Some(t) = token {
        cmd.args(["--token", t]);
    }
    let mut child = cmd
        .current_dir(repo_root())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start candela serve");
    let log = Arc::new(Mutex::new(String::new()));
    let (tx, rx) = mpsc::channel();
    pump_lines(child.stdout.take().unwrap(), tx.clone(), log.clone());
    pump_lines(child.stderr.take().unwrap(), tx, log.clone());

    let deadline = Instant::now() + STARTUP;
    let mut server = Server {
        child,
        url: String::new(),
        log,
    };
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(line) => {
                if let Some(i) = line.find("listening on http://") {
                    let url = line[i + "listening on ".len()..].trim();
                    server.url = url.split_whitespace().next().unwrap_or(url).to_string();
                    return server;
                }
            }
            Err(_) => {
                let status = server.child.try_wait().ok().flatten();
                panic!(
                    "candela serve did not print `listening on http://ADDR` within {STARTUP:?} \
                     (exit status: {status:?}); its output:\n{}",
                    server.log.lock().unwrap()
                );
            }
        }
    }
}

/// Runs a command to completion with a time limit; returns (success, stdout + stderr).
fn run_with_limit(mut cmd: Command, limit: Duration) -> (bool, String) {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start node");
    let log = Arc::new(Mutex::new(String::new()));
    let (tx, _rx) = mpsc::channel();
    pump_lines(child.stdout.take().unwrap(), tx.clone(), log.clone());
    pump_lines(child.stderr.take().unwrap(), tx, log.clone());
    let deadline = Instant::now() + limit;
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for node") {
            break Some(s);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        thread::sleep(Duration::from_millis(100));
    };
    // Let the reader threads drain what is left in the pipes.
    thread::sleep(Duration::from_millis(200));
    let mut out = log.lock().unwrap().clone();
    if status.is_none() {
        out.push_str(&format!("\n(killed: ran over {limit:?})\n"));
    }
    (status.is_some_and(|s| s.success()), out)
}

fn chromium_path() -> PathBuf {
    std::env::var_os("CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"))
}

/// Fails with what to install when node, Chromium or the npm packages are missing.
fn check_prerequisites(browser_dir: &Path) {
    let node = Command::new("node").arg("--version").output();
    let version = match node {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).trim().to_string(),
        _ => panic!(
            "node is not installed: the browser test needs Node.js 20 or newer (scripts/setup.sh \
             installs it)"
        ),
    };
    let major: u32 = version
        .trim_start_matches('v')
        .split('.')
        .next()
        .and_then(|m| m.parse().ok())
        .unwrap_or(0);
    assert!(
        major >= 20,
        "node {version} is too old: playwright-core needs Node.js 20 or newer"
    );
    assert!(
        chromium_path().exists(),
        "{} not found: install Debian's Chromium with `apt-get install -y chromium` \
         (scripts/setup.sh does it), or set CHROMIUM to its path",
        chromium_path().display()
    );
    assert!(
        browser_dir.join("node_modules/playwright-core").is_dir(),
        "{} is missing: run `npm ci --prefix tests/browser` first (scripts/setup.sh does it)",
        browser_dir.join("node_modules").display()
    );
}

/// Runs the browser script against a fresh server (with `--token` when given) and checks it
/// passed and saved its screenshots; returns the main screenshot's path.
fn run_viewer_test(name: &str, token: Option<&str>) -> PathBuf {
    let browser_dir = repo_root().join("tests/browser");
    check_prerequisites(&browser_dir);

    let dir = scratch(name);
    let data = dir.join("data");
    let shots = dir.join("screenshots");
    std::fs::create_dir_all(&shots).unwrap();

    let server = start_server(&data, token);
    println!("server at {}", server.url);

    let mut cmd = Command::new("node");
    cmd.arg(browser_dir.join("viewer.test.mjs"))
        .arg(&server.url)
        .arg(&shots)
        .current_dir(repo_root())
        .env_remove("CANDELA_TOKEN");
    if let Some(t) = token {
        cmd.args(["--token", t]);
    }
    let (ok, output) = run_with_limit(cmd, BROWSER_RUN);
    let server_log = server.log.lock().unwrap().clone();
    drop(server);
    std::fs::write(dir.join("server.log"), &server_log).ok();
    std::fs::write(dir.join("browser.log"), &output).ok();

    println!("{output}");
    assert!(
        ok,
        "the browser test failed (screenshots and failure.png in {}; server log in {}):\n{output}",
        shots.display(),
        dir.join("server.log").display()
    );
    let main_shot = shots.join("viewer.png");
    assert!(
        main_shot.is_file(),
        "the browser test passed but wrote no {}",
        main_shot.display()
    );
    let mut others: Vec<_> = std::fs::read_dir(&shots)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "png") && *p != main_shot)
        .collect();
    others.sort();
    println!("screenshot: {}", main_shot.display());
    for p in others {
        println!("screenshot: {}", p.display());
    }
    main_shot
}

/// Submit, live refinement, tone controls, A/B, job controls, uploads and the error chart of a
/// job with a reference, in Chromium.
#[test]
fn web_viewer_in_headless_chromium() {
    run_viewer_test("browser_viewer", None);
}

/// The same with `--token`: the page asks for the token, then every request (the SSE stream
/// and the images included, which the browser cannot authenticate by itself) carries it.
#[test]
fn web_viewer_with_a_bearer_token() {
    run_viewer_test("browser_viewer_token", Some("browser-test-token"));
}
