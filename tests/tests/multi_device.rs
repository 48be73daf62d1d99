//! `candela render --devices`: one render split across devices by sample index. On lavapipe the
//! same device is listed twice (two contexts, two sessions, two threads); the merged image must
//! equal the single-device render of the same seed and spp up to float summation order, and the
//! report must count every sample once.

use std::path::Path;

use candela_tests::{assert_bad_input, run_candela as run, scene_path, scratch, text};
use renderer::film::read_exr;
use renderer::integrators::{ExtraBuffer, ExtraSum};
use renderer::metrics::rel_mse;
use renderer::render::{merge_accumulation, SampleDispenser};

/// Renders Cornell at 48×48 with `extra` arguments; returns the JSON report.
fn render(out: &Path, integrator: &str, seed: u64, extra: &[&str]) -> serde_json::Value {
    let scene = scene_path("cornell.json");
    let seed = seed.to_string();
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "48",
        "--height",
        "48",
        "--integrator",
        integrator,
        "--max-depth",
        "4",
        "--seed",
        &seed,
        "--json",
    ];
    args.extend_from_slice(extra);
    let o = run(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("one JSON object")
}

/// The per-device spp of a `--devices` report, checked to add up to its total.
fn shard_spp(report: &serde_json::Value) -> Vec<u64> {
    let devices = report["devices"].as_array().expect("devices in the report");
    let spp: Vec<u64> = devices.iter().map(|d| d["spp"].as_u64().unwrap()).collect();
    assert_eq!(spp.iter().sum::<u64>(), report["spp"].as_u64().unwrap());
    for d in devices {
        assert!(d["msamples_per_s"].as_f64().unwrap() > 0.0, "{d}");
    }
    spp
}

/// Two shards on one device give the single-device image of the same seed and spp; returns the
/// folder of both images (one.exr, two.exr).
fn split_equals_single(integrator: &str, options: &str) -> std::path::PathBuf {
    let dir = scratch(&format!("multi_device_{integrator}_{}", options.len()));
    let (one, two) = (dir.join("one.exr"), dir.join("two.exr"));
    let single = render(&one, integrator, 7, &["--spp", "6", "--options", options]);
    let split = render(
        &two,
        integrator,
        7,
        &["--spp", "6", "--options", options, "--devices", "0,0"],
    );
    assert_eq!(single["spp"], 6);
    assert_eq!(split["spp"], 6);
    let spp = shard_spp(&split);
    assert_eq!(spp.len(), 2);
    // An integrator's details are each device's, not one of them passed off as the whole's.
    if single.get("details").is_some() {
        assert!(split.get("details").is_none(), "{split}");
        for d in split["devices"].as_array().unwrap() {
            assert!(d["details"].is_object(), "{d}");
            assert_eq!(d["details"]["design"], single["details"]["design"], "{d}");
        }
    }
    assert!(spp.iter().all(|&s| s >= 1), "both shards rendered: {spp:?}");
    let (a, b) = (read_exr(&two).unwrap(), read_exr(&one).unwrap());
    let e = rel_mse(&a, &b).unwrap();
    assert!(e < 1e-8, "{integrator}: split vs single relMSE {e}");
    // The merged halves (bdpt: with both splat buffers) give the single render's estimate.
    let (x, y) = (
        single["rel_mse_estimate"].as_f64().expect("an estimate"),
        split["rel_mse_estimate"].as_f64().expect("an estimate"),
    );
    assert!(
        (x - y).abs() <= 1e-4 * x,
        "{integrator}: estimate {x} vs {y} split"
    );
    dir
}

#[test]
fn nee_split_over_two_contexts_equals_one_device() {
    let dir = split_equals_single("nee", "{}");
    // The comparison can tell renders apart: another seed is far from equal.
    let other = dir.join("other.exr");
    render(&other, "nee", 8, &["--spp", "6"]);
    let one = read_exr(&dir.join("one.exr")).unwrap();
    let e = rel_mse(&read_exr(&other).unwrap(), &one).unwrap();
    assert!(e > 1e-4, "another seed gave relMSE {e}");
}

#[test]
fn bdpt_split_merges_light_splats() {
    // Float splats where the device has float atomics (lavapipe may not), and 64-bit fixed
    // point, whose two words per channel must add with carry.
    split_equals_single("bdpt", "{}");
    split_equals_single("bdpt", r#"{"fixed_point_splats": true}"#);
}

#[test]
fn time_budget_runs_every_device_and_counts_each_sample_once() {
    let dir = scratch("multi_device_time");
    let report = render(
        &dir.join("t.exr"),
        "nee",
        1,
        &["--time", "0.5", "--devices", "0,0"],
    );
    let spp = shard_spp(&report);
    assert!(spp.iter().all(|&s| s >= 1), "{spp:?}");
    assert!(report["wall_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_device_lists_are_refused() {
    let dir = scratch("multi_device_bad");
    let out = dir.join("x.exr");
    let scene = scene_path("cornell.json");
    for (spec, needle) in [("99", "no device 99"), ("0,x", "device indices")] {
        let o = run(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--spp",
            "1",
            "--devices",
            spec,
        ]);
        assert_bad_input(&o, &["--devices", needle]);
    }
}

#[test]
fn the_dispenser_gives_every_index_once() {
    let d = SampleDispenser::new(10);
    let mut got = Vec::new();
    while let Some((first, n)) = d.claim(3) {
        got.extend(first..first + n);
    }
    assert_eq!(got, (0..10).collect::<Vec<_>>());
    assert_eq!(d.given(), 10);
    // Shared by 3: at most a third of what is left (rounded up) per block.
    let d = SampleDispenser::new(10).shared_by(3);
    assert_eq!(d.claim(100), Some((0, 4)));
    assert_eq!(d.claim(100), Some((4, 2)));
    assert_eq!(d.claim(100), Some((6, 2)));
    assert_eq!(d.claim(100), Some((8, 1)));
    assert_eq!(d.claim(100), Some((9, 1)));
    assert_eq!(d.claim(100), None);
    let d = SampleDispenser::new(u32::MAX);
    assert_eq!(d.claim(0), Some((0, 1)));
    d.stop();
    assert_eq!(d.claim(4), None);
}

#[test]
fn fixed_point_splats_add_with_carry() {
    let e = [ExtraBuffer {
        binding: 0,
        name: "splat",
        entries_per_pixel: 2,
        sum: ExtraSum::Fixed64,
        odd_share_of: None,
    }];
    let fixed = |v: u64| {
        [
            [f32::from_bits(v as u32); 4],
            [f32::from_bits((v >> 32) as u32); 4],
        ]
    };
    // The layout of RenderSession::accumulation: sums, the splat words, the odd half.
    let acc = |v: u64, w: f32| {
        let [lo, hi] = fixed(v);
        vec![[0.5, 1.0, 2.0, w], lo, hi, [0.25, 0.5, 1.0, w]]
    };
    let mut a = acc(0xffff_fff0, 1.0);
    merge_accumulation(&mut a, &acc(0x20, 2.0), 1, &e).unwrap();
    assert_eq!(a[0], [1.0, 2.0, 4.0, 3.0]);
    assert_eq!(a[1][2].to_bits(), 0x10);
    assert_eq!(a[2][2].to_bits(), 1);
    assert_eq!(a[3], [0.5, 1.0, 2.0, 3.0]);
    assert!(merge_accumulation(&mut a, &[[0.0; 4]; 3], 1, &e).is_err());
}

#[test]
fn threads_claiming_at_once_share_the_indices_exactly() {
    let d = SampleDispenser::new(10_000);
    let mut all: Vec<u32> = std::thread::scope(|s| {
        let hs: Vec<_> = (1..=4u32)
            .map(|k| {
                let d = &d;
                s.spawn(move || {
                    let mut mine = Vec::new();
                    while let Some((first, n)) = d.claim(k * 7) {
                        mine.extend(first..first + n);
                    }
                    mine
                })
            })
            .collect();
        hs.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    all.sort_unstable();
    assert_eq!(all, (0..10_000).collect::<Vec<_>>());
}
