//! Quality targets: `candela render --until-rel-mse X` and jobs with `"until": {"rel_mse": X}`
//! stop once the estimated relMSE (no reference) reaches X, before their spp cap, and say so;
//! the estimate they check is computed on the GPU (renderer/src/render/estimate_gpu.rs) and
//! equals the CPU's definition; they stop at a check point (renderer/src/render/until.rs).

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{gpu, run_candela, run_json, scene_path, scratch};
use renderer::compile::compile;
use renderer::integrators::IntegratorOptions;
use renderer::render::{next_check, render_until, Budget, RenderSession, UNTIL_CHECK_GROWTH};
use serde_json::json;

/// An easy target for the Cornell box at 16×16 with nee (its estimate is about 0.1 at 8 spp
/// and falls as 1/spp): reached after tens of samples, far below the cap.
const TARGET: f64 = 0.02;
const CAP: u32 = 100_000;

#[test]
fn cli_render_stops_at_the_target_before_the_cap() {
    let dir = scratch("until_cli");
    let out = dir.join("until.exr");
    let report = run_json(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        &CAP.to_string(),
        "--until-rel-mse",
        &TARGET.to_string(),
        "--json",
        "--no-accel-cache",
    ]);
    println!(
        "stopped by {} at {} spp, estimate {}",
        report["stopped_by"], report["spp"], report["rel_mse_estimate"]
    );
    assert_eq!(report["stopped_by"], "rel_mse", "{report}");
    let spp = report["spp"].as_u64().unwrap();
    assert!((8..CAP as u64).contains(&spp), "{report}");
    let estimate = report["rel_mse_estimate"].as_f64().unwrap();
    assert!(estimate > 0.0 && estimate <= TARGET, "{report}");
    // The checks (GPU estimates at the check points up to the stop) and what they took.
    let checks = &report["estimate_checks"];
    assert!(
        checks["checks"].as_u64().is_some_and(|n| n >= 1),
        "{report}"
    );
    assert!(checks["gpu_ms"].as_f64().is_some(), "{report}");
    assert!(checks["wait_ms"].as_f64().is_some(), "{report}");

    // Without a target: the cap ends it, and the estimate is still reported.
    let report = run_json(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "8",
        "--json",
        "--no-accel-cache",
    ]);
    assert_eq!(report["stopped_by"], "spp", "{report}");
    assert!(report.get("estimate_checks").is_none(), "{report}");
    assert!(
        report["rel_mse_estimate"].as_f64().is_some_and(|e| e > 0.0),
        "{report}"
    );

    // A target must be a positive number.
    let o = run_candela(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--until-rel-mse",
        "0",
    ]);
    candela_tests::assert_bad_input(&o, &["--until-rel-mse"]);
}

#[test]
fn job_with_until_completes_at_its_target() {
    let dir = scratch("until_server");
    let s = Server::start(&dir.join("data"), &["--snapshot-interval", "0.2"]);
    let (status, body) = s.post(
        "/api/jobs",
        &json!({"scene_name": "cornell", "spp": 16, "until": {"rel_mse": -1}}),
    );
    assert_eq!(status, 422, "{body}");
    assert_eq!(body["error"]["path"], "until.rel_mse", "{body}");
    let (status, body) = s.post(
        "/api/jobs",
        &json!({"scene_name": "cornell", "spp": 16, "until": {"relmse": 1}}),
    );
    assert_eq!(status, 422, "{body}");

    let job = s.submit(&json!({
        "scene_name": "cornell", "integrator": "nee", "spp": CAP, "width": 16, "height": 16,
        "until": {"rel_mse": TARGET},
    }));
    let id = job["id"].as_i64().unwrap();
    let done = s.wait_job(id, Duration::from_secs(300), |j| j["state"] == "done");
    let stats = &done["stats"];
    println!(
        "job: stopped by {} at {} spp, estimate {}",
        stats["stopped_by"], stats["spp"], stats["rel_mse_estimate"]
    );
    assert_eq!(stats["stopped_by"], "rel_mse", "{done}");
    let spp = stats["spp"].as_u64().unwrap();
    assert!((8..CAP as u64).contains(&spp), "{done}");
    assert!(
        stats["rel_mse_estimate"]
            .as_f64()
            .is_some_and(|e| e > 0.0 && e <= TARGET),
        "{done}"
    );
    assert_eq!(done["settings"]["until_rel_mse"], TARGET, "{done}");
    assert!(
        stats["estimate_checks"]["checks"]
            .as_u64()
            .is_some_and(|n| n >= 1),
        "{done}"
    );
    // Its progress events carry the estimate, and the last one has reached the target.
    let events = s.events(id, Some(0)).collect_all();
    let estimates: Vec<f64> = events
        .iter()
        .filter(|e| e.event == "progress")
        .filter_map(|e| e.data["rel_mse_estimate"].as_f64())
        .collect();
    println!("progress estimates: {estimates:?}");
    assert!(
        !estimates.is_empty(),
        "no progress event carried rel_mse_estimate"
    );
    assert!(*estimates.last().unwrap() <= TARGET, "{estimates:?}");
}

/// Passes the session waits for itself (a checkpoint's read of the accumulation between passes)
/// still come back from `complete_oldest`, in order, a check pass with its GPU estimate: a
/// worker that lost a check pass's estimate this way would wait for it for ever.
#[test]
fn passes_waited_for_by_an_accumulation_read_are_still_handed_back() {
    let ctx = gpu();
    let loaded = renderer::scene::load_file(&scene_path("cornell.json")).unwrap();
    let compiled = compile(&loaded, 16, 16).unwrap();
    let options = IntegratorOptions::from_name("nee").unwrap();
    let mut s = RenderSession::new(&ctx, &compiled, &options, Some(3), 5).unwrap();
    assert!(s.submit_pass_with(2, false, false).unwrap().is_empty());
    assert!(s.submit_pass_with(6, false, true).unwrap().is_empty());
    let acc = s.accumulation().unwrap();
    assert_eq!(acc.len(), s.accumulation_len());
    assert_eq!(s.spp(), 8);
    assert_eq!(
        s.in_flight(),
        2,
        "passes not yet handed back count as in flight"
    );
    let first = s.complete_oldest().unwrap().expect("the first pass");
    assert_eq!((first.stats.spp, first.estimate), (2, None));
    let check = s.complete_oldest().unwrap().expect("the check pass");
    assert_eq!(check.stats.spp, 6);
    let e = check.estimate.expect("the check pass's estimate");
    assert_eq!(e.spp, 8);
    assert!(e.rel_mse.is_some_and(|x| x > 0.0), "{e:?}");
    assert!(s.complete_oldest().unwrap().is_none());
    assert_eq!(s.in_flight(), 0);
    ctx.check_validation().unwrap();
}

/// A job whose checkpoints fall between its passes (one every pass here, with passes of about
/// a millisecond, so that several are queued between check points) completes with its spp.
#[test]
fn until_job_with_checkpoints_between_passes_completes() {
    let dir = scratch("until_checkpoints");
    let s = Server::start(
        &dir.join("data"),
        &[
            "--checkpoint-interval",
            "0.001",
            "--snapshot-interval",
            "0.05",
            // One-sample passes: several in flight between check points.
            "--pass-ms",
            "1",
        ],
    );
    let job = s.submit(&json!({
        "scene_name": "cornell", "integrator": "nee", "spp": 64, "width": 64, "height": 64,
        "until": {"rel_mse": 1e-9},
    }));
    let id = job["id"].as_i64().unwrap();
    let done = s.wait_job(id, Duration::from_secs(120), |j| j["state"] == "done");
    let stats = &done["stats"];
    println!(
        "job: stopped by {} at {} spp after {} checks",
        stats["stopped_by"], stats["spp"], stats["estimate_checks"]["checks"]
    );
    assert_eq!(stats["stopped_by"], "spp", "{done}");
    assert_eq!(stats["spp"], 64, "{done}");
    assert!(
        stats["estimate_checks"]["checks"]
            .as_u64()
            .is_some_and(|n| n >= 8),
        "{done}"
    );
}

/// The GPU estimate (computed by a pass, estimate_gpu.rs) equals the CPU one
/// (metrics/estimate.rs via render/halves.rs, read back after the same pass) within float
/// rounding, for each resolver: the mean (pt, nee) and bdpt's splats as floats and as 64-bit
/// fixed point. Cornell box, 40×20 (not square, 3×2 workgroups of 16×16 partly outside the film),
/// max_depth 3, after 1, 8 and 11 spp (1 spp: the odd half is empty, so both say None).
#[test]
fn gpu_estimate_equals_the_cpu_estimate() {
    let ctx = gpu();
    let loaded = renderer::scene::load_file(&scene_path("cornell.json")).unwrap();
    let compiled = compile(&loaded, 40, 20).unwrap();
    for json in [
        r#"{"type":"pt"}"#,
        r#"{"type":"nee"}"#,
        r#"{"type":"bdpt"}"#,
        r#"{"type":"bdpt","fixed_point_splats":true}"#,
    ] {
        let options: IntegratorOptions = serde_json::from_str(json).unwrap();
        let mut s = RenderSession::new(&ctx, &compiled, &options, Some(3), 5).unwrap();
        for pass in [1u32, 7, 3] {
            s.submit_pass_with(pass, false, true).unwrap();
            let done = s.drain().unwrap();
            let e = done[0].estimate.expect("the pass's estimate");
            assert_eq!(e.spp, s.spp());
            let cpu = s.rel_mse_estimate().unwrap();
            println!("{json} {} spp: GPU {:?}, CPU {cpu:?}", s.spp(), e.rel_mse);
            match (e.rel_mse, cpu) {
                (None, None) => assert_eq!(s.spp(), 1),
                (Some(g), Some(c)) => {
                    assert!(c > 0.0, "{json}: {c}");
                    assert!(
                        (g - c).abs() <= 1e-4 * c,
                        "{json} {} spp: {g} vs {c}",
                        s.spp()
                    );
                }
                other => panic!("{json}: {other:?}"),
            }
        }
        ctx.check_validation().unwrap();
    }
}

/// A render with a target stops at the first check point whose estimate reaches it, so at most
/// `UNTIL_CHECK_GROWTH` (12.5%, rounded up) past the check point before, which had not; the
/// same seed gives the same spp and image again.
#[test]
fn render_stops_at_a_check_point_with_bounded_overshoot() {
    let ctx = gpu();
    let loaded = renderer::scene::load_file(&scene_path("cornell.json")).unwrap();
    let compiled = compile(&loaded, 16, 16).unwrap();
    let options: IntegratorOptions = serde_json::from_str(r#"{"type":"nee"}"#).unwrap();
    let run = || {
        let mut s = RenderSession::new(&ctx, &compiled, &options, Some(3), 3).unwrap();
        render_until(&mut s, Budget::Spp(100_000), Some(TARGET)).unwrap()
    };
    let (image, stats) = run();
    let checks = stats.estimate_checks.expect("the checks' report");
    println!(
        "stopped by {:?} at {} spp after {} passes, {} checks ({:.1} ms GPU, {:?} ms waiting), \
         estimate {:?}",
        stats.stopped_by,
        stats.spp,
        stats.passes,
        checks.checks,
        checks.gpu_ms,
        checks.wait_ms,
        stats.rel_mse_estimate
    );
    assert_eq!(stats.stopped_by.map(|r| r.name()), Some("rel_mse"));
    // Stopped at a check point: the one after the check before it.
    let mut points = vec![next_check(0)];
    while *points.last().unwrap() < stats.spp {
        points.push(next_check(*points.last().unwrap()));
    }
    assert_eq!(*points.last().unwrap(), stats.spp, "{points:?}");
    assert_eq!(checks.checks as usize, points.len(), "one check per point");
    if let [.., before, stop] = points[..] {
        assert!(
            stop as f64 <= (before as f64 * (1.0 + UNTIL_CHECK_GROWTH)).ceil(),
            "{before} → {stop}"
        );
    }
    // The estimate the render reports (CPU, at the stop) reached the target.
    // (The stop was decided by the GPU's f32 estimate: the CPU's may differ in the last digits.)
    assert!(stats
        .rel_mse_estimate
        .is_some_and(|e| e <= TARGET * (1.0 + 1e-3)));
    // The check before the stop had not reached it: a render capped there ends by spp with
    // an estimate above the target.
    if points.len() >= 2 {
        let before = points[points.len() - 2];
        let mut s = RenderSession::new(&ctx, &compiled, &options, Some(3), 3).unwrap();
        let (_, capped) = render_until(&mut s, Budget::Spp(before), Some(TARGET)).unwrap();
        assert_eq!(capped.stopped_by.map(|r| r.name()), Some("spp"));
        assert!(capped
            .rel_mse_estimate
            .is_some_and(|e| e > TARGET * (1.0 - 1e-3)));
    }
    // Deterministic: the same spp and image again.
    let (again, stats2) = run();
    assert_eq!(stats2.spp, stats.spp);
    assert_eq!(again.pixels, image.pixels);
    ctx.check_validation().unwrap();
}
