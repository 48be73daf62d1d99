//! Fuzzing of the upload archive extraction (`extract`: .tar, .tar.gz, .zip) with the renderer's
//! stable fuzz driver (`renderer::fuzz::run`): seeds are archives of a small scene folder made
//! here, plus every input under fuzz/regressions/archive; mutations run for
//! `CANDELA_FUZZ_SECONDS` (default 3). Besides never panicking, nothing may be written outside
//! the destination folder, whatever the entries' names (`../`, absolute paths, links).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use super::upload::fuzz_extract;

/// A .tar, a .tar.gz and a .zip of `scene.json` and `assets/m.obj`.
fn seeds() -> Vec<Vec<u8>> {
    let files: [(&str, &[u8]); 2] = [
        ("scene.json", br#"{"version": 1}"#),
        ("assets/m.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ];
    let mut tar = tar::Builder::new(Vec::new());
    for (name, data) in files {
        let mut h = tar::Header::new_gnu();
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        h.set_cksum();
        tar.append_data(&mut h, name, data).unwrap();
    }
    let tar = tar.into_inner().unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&tar).unwrap();
    let gz = gz.finish().unwrap();
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (name, data) in files {
        zip.start_file(name, zip::write::SimpleFileOptions::default())
            .unwrap();
        zip.write_all(data).unwrap();
    }
    let zip = zip.finish().unwrap().into_inner();
    vec![tar, gz, zip]
}

/// Every file under `dir`, recursively.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let p = e.path();
        if p.is_dir() && !p.is_symlink() {
            walk(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// The target: the bytes as an upload archive, extracted into `sandbox/dest`; panics if anything
/// lands outside `dest`.
fn target(data: &[u8]) {
    let sandbox = std::env::temp_dir().join(format!("candela-fuzz-archive-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&sandbox);
    let dest = sandbox.join("dest");
    std::fs::create_dir_all(&dest).unwrap();
    let archive = sandbox.join("upload.bin");
    std::fs::write(&archive, data).unwrap();
    let _ = fuzz_extract(&archive, &dest);
    let mut all = Vec::new();
    walk(&sandbox, &mut all);
    for p in all {
        assert!(
            p == archive || p.starts_with(&dest),
            "extraction wrote {} outside its folder",
            p.display()
        );
        assert!(!p.is_symlink(), "extraction made a link {}", p.display());
    }
    let _ = std::fs::remove_dir_all(&sandbox);
}

#[test]
fn archive_extraction_survives_fuzzing() {
    let mut seeds = seeds();
    let regressions = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/regressions/archive");
    for e in std::fs::read_dir(regressions)
        .into_iter()
        .flatten()
        .flatten()
    {
        seeds.push(std::fs::read(e.path()).unwrap());
    }
    let secs = std::env::var("CANDELA_FUZZ_SECONDS")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(3.0);
    let report = renderer::fuzz::run(
        target,
        &seeds,
        0xa4c1,
        Duration::from_secs_f64(secs),
        Duration::from_secs(20),
    );
    println!(
        "archive: {} seeds, {} executions, {} failures",
        seeds.len(),
        report.executions,
        report.failures.len()
    );
    let messages: Vec<&str> = report.failures.iter().map(|f| f.message.as_str()).collect();
    assert!(report.failures.is_empty(), "{messages:?}");
}
