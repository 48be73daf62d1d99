//! `candela bench` end to end on a tiny Cornell box (16×16, budgets 0.05/0.2/0.8 s, 2 repeats,
//! a 256 spp reference): the real binary writes results.csv (right columns and rows), results.json
//! (parses, all runs), chart.svg (well-formed XML, one median polyline per integrator) and
//! summary.md, and error falls as time grows. Bad input exits 2 with one line.

use candela_tests::{assert_bad_input, run_candela as run, scene_path, scratch, text};
use std::collections::{HashMap, HashSet};
use std::path::Path;

const COLUMNS: &[&str] = &[
    "scene",
    "integrator",
    "budget_s",
    "repeat",
    "seed",
    "time_s",
    "gpu_time_s",
    "spp",
    "passes",
    "msamples_per_s",
    "mse",
    "rmse",
    "rel_mse",
    "psnr_db",
    "ssim",
    "flip",
    "nan_fraction",
    "dropped_samples",
    "width",
    "height",
    "device",
    "commit",
];

#[test]
fn bench_writes_results_and_error_falls_with_time() {
    let dir = scratch("bench_cli");
    let scene = scene_path("cornell.json");
    let o = run(&[
        "bench",
        scene.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--integrators",
        "pt,nee",
        "--times",
        "0.05,0.2,0.8",
        "--repeats",
        "2",
        "--reference-spp",
        "256",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert!(o.status.success(), "stderr: {stderr}");
    eprintln!("{stderr}{stdout}");
    assert!(stderr.contains("[12/12]"), "progress lines: {stderr}");
    assert!(stdout.contains("time to relMSE <= 0.01 and FLIP <= 0.05"));
    assert!(
        stdout.contains("256 spp"),
        "the reference spp is stated: {stdout}"
    );

    // results.csv: header, 2 integrators × 3 budgets × 2 repeats rows, distinct seeds.
    let rows = parse_csv(&std::fs::read_to_string(dir.join("results.csv")).unwrap());
    assert_eq!(rows[0], COLUMNS, "CSV header");
    let rows = &rows[1..];
    assert_eq!(rows.len(), 12);
    let col = |name: &str| COLUMNS.iter().position(|c| *c == name).unwrap();
    let num = |row: &Vec<String>, name: &str| -> f64 {
        row[col(name)]
            .parse()
            .unwrap_or_else(|_| panic!("{name} = {:?}", row[col(name)]))
    };
    let mut seeds = HashSet::new();
    let mut rel: HashMap<(String, String), Vec<f64>> = HashMap::new();
    for row in rows {
        assert_eq!(row.len(), COLUMNS.len(), "{row:?}");
        assert_eq!(row[col("scene")], "cornell");
        assert!(["pt", "nee"].contains(&row[col("integrator")].as_str()));
        assert!(["0.05", "0.2", "0.8"].contains(&row[col("budget_s")].as_str()));
        assert!(num(row, "time_s") >= num(row, "budget_s"));
        assert!(num(row, "spp") >= 1.0 && num(row, "msamples_per_s") > 0.0);
        for m in ["mse", "rmse", "rel_mse", "psnr_db", "ssim", "flip"] {
            assert!(num(row, m).is_finite(), "{m} in {row:?}");
        }
        assert_eq!(num(row, "nan_fraction"), 0.0);
        assert_eq!((num(row, "width"), num(row, "height")), (16.0, 16.0));
        assert!(!row[col("device")].is_empty());
        assert!(seeds.insert(row[col("seed")].clone()), "seeds repeat");
        rel.entry((row[col("integrator")].clone(), row[col("budget_s")].clone()))
            .or_default()
            .push(num(row, "rel_mse"));
    }
    assert_eq!(rel.len(), 6);
    assert!(rel.values().all(|v| v.len() == 2));

    // Error falls as time grows: median relMSE at 0.8 s below that at 0.05 s.
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        0.5 * (v[(v.len() - 1) / 2] + v[v.len() / 2])
    };
    for integrator in ["pt", "nee"] {
        let first = median(&rel[&(integrator.to_string(), "0.05".to_string())]);
        let last = median(&rel[&(integrator.to_string(), "0.8".to_string())]);
        eprintln!("{integrator}: median relMSE {first:.4e} at 0.05 s, {last:.4e} at 0.8 s");
        assert!(
            last < first,
            "{integrator}: {last} at 0.8 s vs {first} at 0.05 s"
        );
    }

    // results.json: all runs, the reference, the summary.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap())
            .expect("results.json parses");
    let runs = json["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 12);
    for key in [
        "scene",
        "integrator",
        "budget_s",
        "time_s",
        "spp",
        "msamples_per_s",
        "rel_mse",
        "flip",
        "ssim",
        "psnr_db",
        "nan_fraction",
        "device",
    ] {
        assert!(runs[0].get(key).is_some(), "run lacks {key}: {}", runs[0]);
    }
    assert_eq!(json["reference"]["source"], "rendered");
    assert_eq!(json["reference"]["spp"], 256);
    assert!(!seeds.contains(&json["reference"]["seed"].to_string()));
    assert_eq!(json["summary"].as_array().unwrap().len(), 2);
    assert!(json["notes"]["rel_mse"]
        .as_str()
        .unwrap()
        .contains("r^2+0.01"));
    assert!(json["device"]["name"].is_string());

    // chart.svg: well-formed, one median polyline per integrator.
    for chart in ["chart.svg", "chart_flip.svg"] {
        let svg = std::fs::read_to_string(dir.join(chart)).unwrap();
        let elements = check_xml(&svg).unwrap_or_else(|e| panic!("{chart} is not XML: {e}"));
        assert_eq!(elements[0].0, "svg");
        let lines: Vec<_> = elements.iter().filter(|(n, _)| n == "polyline").collect();
        assert_eq!(lines.len(), 2, "{chart}: one polyline per integrator");
        for integrator in ["pt", "nee"] {
            assert_eq!(
                lines
                    .iter()
                    .filter(
                        |(_, a)| a.get("data-integrator").map(String::as_str) == Some(integrator)
                    )
                    .count(),
                1,
                "{chart}: {integrator}"
            );
        }
        for (_, a) in lines {
            assert_eq!(a["points"].split_whitespace().count(), 3, "{a:?}");
        }
    }

    // summary.md: the time-to-quality table names each integrator.
    let md = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(md.contains("## Time to quality"));
    assert!(md.contains("| pt |") && md.contains("| nee |"), "{md}");
    assert!(dir.join("reference.exr").exists());

    // A given reference is used as it is (and a wrong size is bad input).
    let reference = dir.join("reference.exr");
    let again = scratch("bench_cli_given_reference");
    let o = run(&[
        "bench",
        scene.to_str().unwrap(),
        "--reference",
        reference.to_str().unwrap(),
        "--integrators",
        "nee",
        "--times",
        "0.05",
        "--repeats",
        "1",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(again.join("results.json")).unwrap())
            .unwrap();
    assert_eq!(json["reference"]["source"], "file");
    assert_eq!(
        (json["width"].as_u64(), json["height"].as_u64()),
        (Some(16), Some(16))
    );
    assert!(!again.join("reference.exr").exists());
    let o = run(&[
        "bench",
        scene.to_str().unwrap(),
        "--reference",
        reference.to_str().unwrap(),
        "--width",
        "8",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_bad_input(&o, &["reference.exr", "16x16", "8x16"]);
}

#[test]
fn bench_bad_input_exits_2() {
    let scene = scene_path("cornell.json");
    let scene = scene.to_str().unwrap();
    let out = scratch("bench_cli_bad");
    let out = out.to_str().unwrap();
    assert_bad_input(
        &run(&["bench", scene, "--integrators", "pt,xyz", "--out", out]),
        &["--integrators", "\"xyz\"", "pt, nee"],
    );
    assert_bad_input(
        &run(&["bench", scene, "--times", "0.1,abc", "--out", out]),
        &["--times", "abc"],
    );
    assert_bad_input(
        &run(&["bench", scene, "--times", "0.1,-1", "--out", out]),
        &["--times", "-1"],
    );
    assert_bad_input(
        &run(&["bench", scene, "--repeats", "0", "--out", out]),
        &["--repeats"],
    );
    assert_bad_input(
        &run(&["bench", "scenes/nope.json", "--out", out]),
        &["nope.json"],
    );
    let not_exr = Path::new(out).join("not.exr");
    std::fs::write(&not_exr, "plain text").unwrap();
    assert_bad_input(
        &run(&[
            "bench",
            scene,
            "--reference",
            not_exr.to_str().unwrap(),
            "--out",
            out,
        ]),
        &["not.exr"],
    );
}

/// Parses RFC 4180 CSV (quoted fields with doubled quotes), one Vec per line.
fn parse_csv(s: &str) -> Vec<Vec<String>> {
    let mut rows = Vec::new();
    let mut row = Vec::new();
    let mut field = String::new();
    let mut chars = s.chars().peekable();
    let mut quoted = false;
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                chars.next();
                field.push('"');
            }
            (true, '"') => quoted = false,
            (true, c) => field.push(c),
            (false, '"') if field.is_empty() => quoted = true,
            (false, ',') => row.push(std::mem::take(&mut field)),
            (false, '\n') => {
                row.push(std::mem::take(&mut field));
                rows.push(std::mem::take(&mut row));
            }
            (false, c) => field.push(c),
        }
    }
    assert!(!quoted, "unterminated quote");
    if !field.is_empty() || !row.is_empty() {
        row.push(field);
        rows.push(row);
    }
    rows
}

/// Element name and attributes.
type Element = (String, HashMap<String, String>);

/// A small XML well-formedness check (elements nest and match, one root, attributes quoted and
/// unique, `&` only in known entity or character references, comments and a prolog allowed).
/// Returns every element in document order.
fn check_xml(s: &str) -> Result<Vec<Element>, String> {
    let mut stack: Vec<String> = Vec::new();
    let mut elements = Vec::new();
    let mut roots = 0;
    let mut rest = s.trim_start();
    if rest.starts_with("<?xml") {
        rest = &rest[rest.find("?>").ok_or("unterminated prolog")? + 2..];
    }
    while !rest.is_empty() {
        let lt = rest.find('<').unwrap_or(rest.len());
        let chars = &rest[..lt];
        if stack.is_empty() && !chars.trim().is_empty() {
            return Err(format!("text outside the root: {chars:?}"));
        }
        check_entities(chars)?;
        rest = &rest[lt..];
        if rest.is_empty() {
            break;
        }
        if let Some(r) = rest.strip_prefix("<!--") {
            rest = &r[r.find("-->").ok_or("unterminated comment")? + 3..];
            continue;
        }
        let gt = rest.find('>').ok_or("unterminated tag")?;
        let tag = &rest[1..gt];
        rest = &rest[gt + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack.pop().ok_or(format!("</{name}> closes nothing"))?;
            if open != name.trim() {
                return Err(format!("<{open}> closed by </{name}>"));
            }
            continue;
        }
        let (tag, empty) = match tag.strip_suffix('/') {
            Some(t) => (t, true),
            None => (tag, false),
        };
        let name_end = tag.find(char::is_whitespace).unwrap_or(tag.len());
        let name = &tag[..name_end];
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_alphanumeric() || "-_:.".contains(c))
        {
            return Err(format!("bad element name {name:?}"));
        }
        if stack.is_empty() {
            roots += 1;
        }
        elements.push((name.to_string(), parse_attributes(&tag[name_end..])?));
        if !empty {
            stack.push(name.to_string());
        }
    }
    match (stack.last(), roots) {
        (Some(open), _) => Err(format!("<{open}> never closed")),
        (None, 1) => Ok(elements),
        (None, n) => Err(format!("{n} root elements")),
    }
}

/// `name="value"` pairs separated by whitespace; names unique.
fn parse_attributes(mut s: &str) -> Result<HashMap<String, String>, String> {
    let mut attrs = HashMap::new();
    loop {
        s = s.trim_start();
        if s.is_empty() {
            return Ok(attrs);
        }
        let eq = s
            .find('=')
            .ok_or(format!("attribute without value: {s:?}"))?;
        let name = s[..eq].trim();
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(format!("bad attribute name {name:?}"));
        }
        let after = s[eq + 1..].trim_start();
        let quote = after.chars().next().ok_or("missing attribute value")?;
        if quote != '"' && quote != '\'' {
            return Err(format!("unquoted attribute {name}"));
        }
        let end = after[1..].find(quote).ok_or("unterminated attribute")? + 1;
        let value = &after[1..end];
        if value.contains('<') {
            return Err(format!("'<' in attribute {name}"));
        }
        check_entities(value)?;
        if attrs.insert(name.to_string(), value.to_string()).is_some() {
            return Err(format!("duplicate attribute {name}"));
        }
        s = &after[end + 1..];
        if !s.is_empty() && !s.starts_with(char::is_whitespace) {
            return Err(format!("no space after attribute {name}"));
        }
    }
}

/// Every `&` starts a known entity or a character reference.
fn check_entities(s: &str) -> Result<(), String> {
    for (i, _) in s.match_indices('&') {
        let r = &s[i + 1..];
        let end = r.find(';').ok_or("unterminated entity")?;
        let e = &r[..end];
        let ok =
            ["amp", "lt", "gt", "quot", "apos"].contains(&e) || (e.starts_with('#') && e.len() > 1);
        if !ok {
            return Err(format!("unknown entity &{e};"));
        }
    }
    Ok(())
}

#[test]
fn xml_checker_rejects_broken_documents() {
    assert!(check_xml(r#"<svg a="1"><g><line/></g></svg>"#).is_ok());
    assert!(check_xml(r#"<svg><g></svg>"#).is_err());
    assert!(check_xml(r#"<svg a=1/>"#).is_err());
    assert!(check_xml(r#"<svg a="1" a="2"/>"#).is_err());
    assert!(check_xml(r#"<svg>a & b</svg>"#).is_err());
    assert!(check_xml(r#"<svg/><svg/>"#).is_err());
    assert!(check_xml(r#"<svg>"#).is_err());
}
