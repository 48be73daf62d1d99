//! tmp
#[test]
fn probe() {
    let base = r#"{"version": 1, "camera": {"position": [0,0,5], "look_at": [0,0,0]}, "materials": {"red": {"type": "diffuse"}}, "objects": []}"#;
    let cases = [
        base.replace(r#""look_at": [0,0,0]"#, r#""look_at": [0,0,0], "fov": 3"#),
        base.replace(r#""objects""#, r#""object""#),
        base.replace(r#""version": 1"#, r#""version": 2"#),
        base.replace(r#""version": 1,"#, r#""#),
        base.replace(r#""look_at": [0,0,0]"#, r#""look_at": [0,0,0], "fov_y": 1e400"#),
        base.replace(r#""look_at": [0,0,0]"#, r#""look_at": [0,0,0], "fov_y": 1e400"#).replace("\"diffuse\"}", "\"diffuse\", \"reflectance\": [1e999, 0, 0]}"),
        base.replace(r#"{"type": "diffuse"}"#, r#"{"type": "diffuse", "reflectance": [1e999, 0, 0]}"#),
        base.replace(r#""objects": []"#, "\"objects\": [\n {\"type\": \"quad\", \"material\": \"red\", \"origin\": [0,0,0], \"edge_u\": [1,0,0], \"edge_v\": [0,1,0], \"radius\": 1}]"),
        base.replace(r#""objects": []"#, "\"objects\": [\n {\"type\": \"sphere\", \"material\": \"red\", \"center\": [0,0,0], \"radius\": 1e400}]"),
        base.replace(r#""objects": []"#, "\"objects\": [\n {\"type\": \"sphere\" \"material\": \"red\"}]"),
        base.replace(r#""materials": {"red""#, r#""materials": {"red": {"type": "phong"}, "red""#),
        base.to_string() + " x",
        base.replace(r#""objects": []"#, r#""film": {"width": "big"}, "objects": []"#),
        base.replace(r#""objects": []"#, r#""film": {"width": -3}, "objects": []"#),
        base.replace(r#""objects": []"#, r#""film": {"width": 512.5}, "objects": []"#),
        base.replace(r#""objects": []"#, r#""film": {"width": 1e400}, "objects": []"#),
        base.replace(r#""objects": []"#, r#""film": {"tonemap": "filmic"}, "objects": []"#),
        base.replace(r#""objects": []"#, r#""objects": [{"type": "sphere", "center": [0,0,0], "radius": 1}]"#),
        base.replace(r#""objects": []"#, r#""objects": [{"center": [0,0,0], "radius": 1}]"#),
        base.replace(r#""objects": []"#, r#""objects": [{"type": "triangles", "positions": [0,0,"x"], "indices": []}]"#),
        "[1,2]".to_string(),
        "".to_string(),
    ];
    for c in cases {
        match super::load_str(&c, None) {
            Ok(_) => println!("OK"),
            Err(e) => println!("{e}   | path={:?}", e.path()),
        }
    }
}
