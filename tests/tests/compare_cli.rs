//! `candela compare` end to end: identical EXRs (relMSE 0, SSIM 1, FLIP 0), a known constant
//! offset, the FLIP heatmap PNG, the text report, and bad input (missing file, not an EXR, size
//! mismatch, bad options), each exiting 2 with one line.

use candela_tests::{assert_bad_input, run_candela as run, scratch, text};
use renderer::film::{write_exr, Image};
use std::path::{Path, PathBuf};

/// Values in multiples of 1/8, exact in f32, so an added 0.25 is an exact offset.
fn pattern(w: u32, h: u32, offset: f32) -> Image {
    Image::from_fn(w, h, |x, y| {
        [
            (x % 8) as f32 / 8.0 + offset,
            (y % 8) as f32 / 8.0 + offset,
            ((x + y) % 5) as f32 / 8.0 + offset,
        ]
    })
}

fn exr(dir: &Path, name: &str, img: &Image) -> PathBuf {
    let p = dir.join(name);
    write_exr(&p, img).unwrap();
    p
}

fn compare_json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["compare"];
    all.extend_from_slice(args);
    all.push("--json");
    let o = run(&all);
    assert!(o.status.success(), "{}", text(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("--json prints one JSON object")
}

#[test]
fn identical_images() {
    let dir = scratch("compare_identical");
    let a = exr(&dir, "a.exr", &pattern(24, 16, 0.0));
    let b = exr(&dir, "b.exr", &pattern(24, 16, 0.0));
    let v = compare_json(&[a.to_str().unwrap(), b.to_str().unwrap()]);
    let m = &v["metrics"];
    assert_eq!(m["mse"], 0.0);
    assert_eq!(m["rmse"], 0.0);
    assert_eq!(m["rel_mse"], 0.0);
    assert_eq!(m["ssim"], 1.0);
    assert_eq!(m["flip"], 0.0);
    assert!(m["psnr_db"].is_null(), "identical: infinite PSNR is null");
    assert_eq!(m["nan_fraction"], 0.0);
    assert_eq!(
        (m["width"].as_u64(), m["height"].as_u64()),
        (Some(24), Some(16))
    );
    assert_eq!(m["display"]["tonemap"], "clamp");
    assert!(v["notes"]["rel_mse"]
        .as_str()
        .unwrap()
        .contains("(x-r)^2/(r^2+0.01)"));
    assert!(v["notes"]["ssim"].as_str().unwrap().contains("sigma 1.5"));
}

#[test]
fn constant_offset() {
    let dir = scratch("compare_offset");
    let reference = pattern(24, 16, 0.0);
    let a = exr(&dir, "a.exr", &pattern(24, 16, 0.25));
    let b = exr(&dir, "b.exr", &reference);
    let v = compare_json(&[
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--tonemap",
        "aces",
        "--exposure",
        "-1",
    ]);
    let m = &v["metrics"];
    let get = |k: &str| m[k].as_f64().unwrap_or_else(|| panic!("{k}: {m}"));
    assert!((get("mse") - 0.0625).abs() < 1e-12, "{m}");
    assert!((get("rmse") - 0.25).abs() < 1e-12, "{m}");
    let mut sum = 0.0;
    for p in &reference.pixels {
        for &r in p {
            sum += 0.0625 / (f64::from(r) * f64::from(r) + 0.01);
        }
    }
    let rel = sum / (reference.pixels.len() * 3) as f64;
    assert!(
        (get("rel_mse") - rel).abs() < 1e-9 * rel,
        "{} vs {rel}",
        get("rel_mse")
    );
    assert!(get("ssim") < 1.0 && get("ssim") > 0.5);
    assert!(get("flip") > 0.0 && get("flip") < 1.0);
    assert!(get("psnr_db") > 0.0);
    assert_eq!(m["display"]["tonemap"], "aces");
    assert_eq!(m["display"]["exposure_ev"], -1.0);
    eprintln!("offset 0.25: {m}");
}

#[test]
fn text_report_and_heatmap() {
    let dir = scratch("compare_heatmap");
    let a = exr(&dir, "a.exr", &pattern(20, 12, 0.125));
    let b = exr(&dir, "b.exr", &pattern(20, 12, 0.0));
    let heat = dir.join("flip.png");
    let o = run(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--heatmap",
        heat.to_str().unwrap(),
    ]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    for needle in ["MSE", "RMSE", "PSNR", "SSIM", "FLIP", "NaN/Inf", "flip.png"] {
        assert!(out.contains(needle), "{needle} missing in:\n{out}");
    }
    let rel_line = out.lines().find(|l| l.starts_with("relMSE")).unwrap();
    assert!(rel_line.contains("(x-r)^2/(r^2+0.01)"), "{rel_line}");
    // A PNG of the image's size: signature, then IHDR with big-endian width and height.
    let png = std::fs::read(&heat).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (20, 12));
}

#[test]
fn bad_input_exits_2() {
    let dir = scratch("compare_bad");
    let a = exr(&dir, "a.exr", &pattern(16, 16, 0.0));
    let small = exr(&dir, "small.exr", &pattern(8, 16, 0.0));
    let not_exr = dir.join("not.exr");
    std::fs::write(&not_exr, "this is not an EXR").unwrap();
    let a = a.to_str().unwrap();
    let missing = dir.join("missing.exr");
    assert_bad_input(
        &run(&["compare", a, missing.to_str().unwrap()]),
        &["missing.exr"],
    );
    assert_bad_input(
        &run(&["compare", not_exr.to_str().unwrap(), a]),
        &["not.exr"],
    );
    assert_bad_input(
        &run(&["compare", a, small.to_str().unwrap()]),
        &["a.exr", "16x16", "small.exr", "8x16"],
    );
    assert_bad_input(
        &run(&["compare", a, a, "--tonemap", "filmic"]),
        &["--tonemap", "filmic", "clamp, reinhard, aces"],
    );
    assert_bad_input(
        &run(&["compare", a, a, "--heatmap", "out.jpg"]),
        &["--heatmap", "out.jpg", ".png"],
    );
    assert_bad_input(
        &run(&["compare", a, a, "--exposure", "inf"]),
        &["--exposure"],
    );
}

#[test]
fn a_reader_that_stops_early_ends_it_quietly() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    // `candela compare a b | head -0`: standard output is closed before the report is written.
    let dir = scratch("compare_closed_pipe");
    let a = exr(&dir, "a.exr", &pattern(64, 48, 0.0));
    let b = exr(&dir, "b.exr", &pattern(64, 48, 0.25));
    let mut child = Command::new(candela_tests::candela())
        .args(["compare", a.to_str().unwrap(), b.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run candela");
    drop(child.stdout.take());
    let o = child.wait_with_output().expect("wait");
    let err = text(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    // Ended by SIGPIPE (13), as Unix tools are.
    assert_eq!(o.status.signal(), Some(13), "{:?}: {err}", o.status);
}
