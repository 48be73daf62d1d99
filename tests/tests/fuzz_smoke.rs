//! The fuzz targets of `renderer::fuzz` on the stable toolchain: every input of the corpus
//! (fuzz/corpus/TARGET: seeds) and of fuzz/regressions/TARGET (inputs that once failed) is
//! replayed, then mutations of them run for `CANDELA_FUZZ_SECONDS` (default 3) per target. Any
//! panic, or an input running over 20 s, fails the test; the inputs are written to
//! target/fuzz-failures/TARGET/ to add to fuzz/regressions once fixed. Long runs use cargo-fuzz
//! (fuzz/, docs/fuzzing.md).

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use candela_tests::repo_root;
use renderer::fuzz::{run, TARGETS};

/// The files of `dir` (none when it does not exist), in name order.
fn inputs(dir: &Path) -> Vec<Vec<u8>> {
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    paths.sort();
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

fn budget() -> Duration {
    let s = std::env::var("CANDELA_FUZZ_SECONDS")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(3.0);
    Duration::from_secs_f64(s)
}

/// Panics seen by the hook, caught or not (the glTF reader catches the gltf crate's own).
static PANICS: AtomicUsize = AtomicUsize::new(0);

#[test]
fn corpus_replays_and_mutations_never_panic() {
    let root = repo_root().join("fuzz");
    // Panics are collected with their messages by the driver; the default hook would print
    // every one (the glTF reader's caught panics can run to thousands).
    std::panic::set_hook(Box::new(|_| {
        PANICS.fetch_add(1, Ordering::Relaxed);
    }));
    let mut failed = Vec::new();
    for (i, (name, target)) in TARGETS.iter().enumerate() {
        let mut seeds = inputs(&root.join("corpus").join(name));
        let regressions = inputs(&root.join("regressions").join(name));
        assert!(!seeds.is_empty(), "fuzz/corpus/{name} has no seeds");
        seeds.extend(regressions.iter().cloned());
        // Seeds and regressions must not panic at all, not even where the panic is caught
        // (libFuzzer aborts on caught panics too).
        for (k, seed) in seeds.iter().enumerate() {
            let before = PANICS.load(Ordering::Relaxed);
            let _ = std::panic::catch_unwind(|| target(seed.as_slice()));
            if PANICS.load(Ordering::Relaxed) != before {
                failed.push(format!("{name}: input {k} of corpus + regressions panics"));
            }
        }
        let before = PANICS.load(Ordering::Relaxed);
        let report = run(
            *target,
            &seeds,
            0x5eed + i as u64,
            budget(),
            Duration::from_secs(20),
        );
        println!(
            "{name}: {} seeds ({} regressions), {} executions, {} failures, {} caught panics",
            seeds.len(),
            regressions.len(),
            report.executions,
            report.failures.len(),
            (PANICS.load(Ordering::Relaxed) - before).saturating_sub(report.failures.len())
        );
        if !report.failures.is_empty() {
            let dir = repo_root().join("target/fuzz-failures").join(name);
            std::fs::create_dir_all(&dir).unwrap();
            for (k, f) in report.failures.iter().enumerate() {
                let p = dir.join(format!("failure-{k}"));
                std::fs::write(&p, &f.input).unwrap();
                failed.push(format!("{name}: {} ({})", f.message, p.display()));
            }
        }
    }
    assert!(failed.is_empty(), "fuzz failures:\n{}", failed.join("\n"));
}
