//! Kernels compile once per machine (issue 13), checked through the real `candela render`: a
//! second run reads every kernel from the kernel cache folder; a truncated SPIR-V file and a
//! corrupt pipeline cache are reported with a warning and rebuilt; a pipeline cache made by
//! another driver (same file name, another pipelineCacheUUID in the driver's header) is ignored
//! with a warning and replaced. A change of source invalidates a kernel's key (the unit tests of
//! renderer/src/gpu/kernel_cache.rs edit an included file three levels down). And glslang
//! compiles give the same SPIR-V on several threads at once as one at a time (why compiles may
//! run in parallel: renderer/src/gpu/shader.rs).

use std::path::Path;

use candela_tests::{gpu, run_candela, scene_path, scratch, text};
use renderer::gpu::{compile_uncached, DriverKey};
use serde_json::Value;

/// Renders the Cornell box at 8×8 with `nee` through the CLI with the kernel cache in `dir`;
/// returns the report's `kernel_build` object and stderr.
fn render(dir: &Path) -> (Value, String) {
    let out = dir.join("out.exr");
    let o = run_candela(&[
        "render",
        scene_path("cornell.json").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "nee",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--no-accel-cache",
        "--json",
        "--kernel-cache",
        dir.join("kernels").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).expect("JSON report");
    (report["kernel_build"].clone(), text(&o.stderr))
}

fn files(dir: &Path, prefix: &str) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir.join("kernels"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix))
        })
        .collect()
}

#[test]
fn kernels_are_cached_and_bad_files_rebuilt() {
    let dir = scratch("kernel_cache_cli");
    // Step 1: cold, then warm.
    let (k, _) = render(&dir);
    assert!(k["compiled"].as_u64().unwrap() >= 1, "{k}");
    assert_eq!(k["disk_hits"], 0, "{k}");
    let spirv = files(&dir, "spirv-");
    let pipelines = files(&dir, "pipelines-");
    assert!(
        !spirv.is_empty() && pipelines.len() == 1,
        "{spirv:?} {pipelines:?}"
    );
    let (k, err) = render(&dir);
    assert_eq!(k["compiled"], 0, "{k}");
    assert!(k["disk_hits"].as_u64().unwrap() >= 1, "{k}");
    assert!(!err.contains("WARN"), "{err}");
    println!("warm run: {k}");

    // Step 2: a truncated SPIR-V file and a corrupt pipeline cache: warnings, then rebuilt.
    for f in &spirv {
        let bytes = std::fs::read(f).unwrap();
        std::fs::write(f, &bytes[..bytes.len() / 2]).unwrap();
    }
    std::fs::write(&pipelines[0], b"not a pipeline cache").unwrap();
    let (k, err) = render(&dir);
    assert!(
        err.contains("kernel cache") && err.contains("recompiling"),
        "{err}"
    );
    assert!(
        err.contains("pipeline cache") && err.contains("starting empty"),
        "{err}"
    );
    assert!(k["compiled"].as_u64().unwrap() >= 1, "{k}");
    let (k, err) = render(&dir);
    assert_eq!(k["compiled"], 0, "rebuilt files are read again: {k}");
    assert!(!err.contains("WARN"), "{err}");

    // Step 3: the driver changed (another pipelineCacheUUID under the same name): ignored with
    // a warning, and replaced by this driver's cache.
    let driver: DriverKey = gpu().driver_key();
    let cache_dir = dir.join("kernels");
    let mine = driver
        .read_file(&cache_dir)
        .unwrap()
        .expect("a saved pipeline cache");
    let mut other = mine.clone();
    other[16] ^= 0xff;
    driver.write_file(&cache_dir, &other).unwrap();
    assert!(driver
        .read_file(&cache_dir)
        .unwrap_err()
        .contains("another device or driver"));
    let (_, err) = render(&dir);
    assert!(err.contains("another device or driver"), "{err}");
    let saved = driver
        .read_file(&cache_dir)
        .expect("this driver's cache again");
    assert!(saved.is_some());
}

#[test]
fn parallel_compiles_match_serial_ones() {
    // Small kernels, so the test stays short on a 2-core machine.
    let kernels = [
        "tests/layout_check.comp",
        "vct/normalize.comp",
        "vct/octree.comp",
    ];
    let serial: Vec<Vec<u32>> = kernels
        .iter()
        .map(|k| compile_uncached(k, &vec![]).unwrap())
        .collect();
    let threads: Vec<_> = (0..4)
        .map(|i| {
            std::thread::spawn(move || {
                // Each thread compiles every kernel, starting at a different one.
                (0..kernels.len())
                    .map(|j| {
                        let k = kernels[(i + j) % kernels.len()];
                        (k, compile_uncached(k, &vec![]).unwrap())
                    })
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    for t in threads {
        for (k, words) in t.join().expect("a compiling thread panicked") {
            let i = kernels.iter().position(|x| *x == k).unwrap();
            assert_eq!(words, serial[i], "{k} differs when compiled in parallel");
        }
    }
}
