//! glTF, pbrt-v4 and .scn imports render exactly like their hand-written candela JSON
//! equivalents (tests/import/*/): the same loaded scene gives the same image for the same seed
//! (a small render on top of the renderer crate's scene-data comparisons). Also `candela
//! convert` of each format writes a JSON scene (meshes beside it) that renders the same again.

use candela_tests::{gpu, render_loaded, repo_root, run_candela, scratch, text};
use renderer::film::Image;
use renderer::import::{load_file, ImportOptions};

const SIZE: u32 = 16;
const SPP: u32 = 16;

fn render(path: &std::path::Path) -> Image {
    let loaded = load_file(path, &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    render_loaded(&loaded.scene, "nee", SPP, SIZE, SIZE, 7, None).0
}

fn max_difference(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f32::max)
}

#[test]
fn imports_render_like_their_json_equivalents_and_convert_round_trips() {
    let _ = gpu();
    for (source, json) in [
        (
            "tests/import/gltf/scene.gltf",
            "tests/import/gltf/scene.json",
        ),
        (
            "tests/import/pbrt/scene.pbrt",
            "tests/import/pbrt/scene.json",
        ),
        (
            "tests/import/scn/cornell.scn",
            "tests/import/scn/cornell.json",
        ),
    ] {
        let (src, reference) = (repo_root().join(source), repo_root().join(json));
        let a = render(&src);
        let b = render(&reference);
        let mean = a.mean();
        assert!(
            mean.iter().sum::<f64>() > 1e-2,
            "{source}: a black image {mean:?}"
        );
        let d = max_difference(&a, &b);
        println!("{source}: {SIZE}x{SIZE} {SPP} spp nee: largest pixel difference to {json}: {d:e} (means {mean:.4?})");
        assert_eq!(d, 0.0, "{source} renders unlike {json}");
        // `candela convert` writes JSON (meshes in <stem>_assets/) that renders the same.
        let dir = scratch(&format!(
            "convert_{}",
            src.file_stem().unwrap().to_string_lossy()
        ));
        let out = dir.join("converted.json");
        let o = run_candela(&["convert", src.to_str().unwrap(), out.to_str().unwrap()]);
        assert!(o.status.success(), "convert {source}: {}", text(&o.stderr));
        assert!(text(&o.stdout).contains("wrote"), "{}", text(&o.stdout));
        let c = render(&out);
        assert_eq!(
            max_difference(&a, &c),
            0.0,
            "{source}: the converted JSON renders differently"
        );
    }
}
