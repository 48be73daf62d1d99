//! `candela render --integrator auto` (renderer/src/auto.rs): a pilot of every unbiased
//! integrator, the cheapest by estimated relMSE × time continues to the budget, and the report
//! says what was chosen and why.

use candela_tests::{run_candela, scratch, text};
use serde_json::Value;

#[test]
fn auto_pilots_every_unbiased_integrator_and_keeps_the_cheapest() {
    let out = scratch("auto").join("auto.exr");
    let o = run_candela(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "auto",
        "--spp",
        "64",
        "--width",
        "16",
        "--height",
        "16",
        "--json",
        "--no-accel-cache",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let auto = &report["auto"];
    println!("{auto}");
    let pilots = auto["pilots"].as_array().expect("pilots");
    let names: Vec<&str> = pilots
        .iter()
        .map(|p| p["integrator"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["pt", "nee", "bdpt"], "{auto}");
    for p in pilots {
        assert!(p["spp"].as_u64().unwrap() >= 8, "{p}");
        assert!(p["cost"].as_f64().is_some_and(|c| c > 0.0), "{p}");
    }
    // The choice is the cheapest pilot, renders the image, and reaches the budget.
    let cheapest = pilots
        .iter()
        .min_by(|a, b| {
            a["cost"]
                .as_f64()
                .unwrap()
                .total_cmp(&b["cost"].as_f64().unwrap())
        })
        .unwrap();
    assert_eq!(auto["choice"], cheapest["integrator"], "{auto}");
    assert_eq!(report["integrator"], auto["choice"], "{report}");
    assert_eq!(report["spp"], 64, "{report}");
    // On the diffuse Cornell box path tracing without light sampling is far behind.
    assert_ne!(auto["choice"], "pt", "{auto}");
}
