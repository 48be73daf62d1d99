//! Fuzz targets for everything that reads user bytes: the scene JSON loader, OBJ and PLY meshes,
//! textures (PNG, JPEG, HDR, EXR) and every importer (Mitsuba XML, glTF/GLB, pbrt-v4, .scn).
//! Each target takes arbitrary bytes and must return: an error is the right answer to bad input,
//! a panic, a hang or an allocation beyond the [`LIMITS`] is a bug.
//!
//! Two drivers use them: `fuzz/` (cargo-fuzz, libFuzzer, nightly; long runs, see
//! docs/fuzzing.md) and [`run`], a small deterministic mutation fuzzer on the stable toolchain that
//! the test suite runs for a few seconds per target after replaying the corpus (fuzz/corpus/*:
//! seeds; fuzz/regressions/*: inputs that once failed). The server's archive extraction has its
//! own target in the server crate, driven by the same [`run`].

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};

use crate::import::{self, ImportOptions};
use crate::scene::{self, Limits, MemoryAssets};

/// Small limits, so that a header claiming billions of elements is refused quickly instead of
/// allocating (the loader's own checks are what is under test).
pub const LIMITS: Limits = Limits {
    max_width: 4096,
    max_height: 4096,
    max_triangles: 200_000,
    max_texture_pixels: 1 << 20,
};

/// A fuzz target: a name (its corpus folder) and the function.
pub type Target = (&'static str, fn(&[u8]));

/// Every target of the renderer.
pub const TARGETS: &[Target] = &[
    ("scene_json", scene_json),
    ("obj", obj),
    ("ply", ply),
    ("texture", texture),
    ("mitsuba_xml", mitsuba_xml),
    ("gltf", gltf),
    ("pbrt", pbrt),
    ("scn", scn),
];

/// A scene document naming one mesh and one texture held in memory.
fn scene_with(mesh: Option<&str>, texture: Option<&str>) -> String {
    let reflectance = match texture {
        Some(t) => format!(r#"{{"texture": "{t}"}}"#),
        None => "0.5".into(),
    };
    let object = match mesh {
        Some(m) => format!(r#"{{"type": "mesh", "file": "{m}", "material": "m"}}"#),
        None => r#"{"type": "quad", "origin": [0,0,0], "edge_u": [1,0,0], "edge_v": [0,1,0], "material": "m"}"#
            .into(),
    };
    format!(
        r#"{{"version": 1, "camera": {{"position": [0,0,3], "look_at": [0,0,0]}},
        "film": {{"width": 8, "height": 8}},
        "materials": {{"m": {{"type": "diffuse", "reflectance": {reflectance}}}}},
        "objects": [{object}]}}"#
    )
}

fn load_with(json: &str, name: &str, data: &[u8]) {
    let assets: MemoryAssets = BTreeMap::from([(name.to_string(), data.to_vec())]);
    let _ = scene::load_str_with_assets(json, None, &assets, &LIMITS);
}

/// The scene JSON loader (any bytes as the document).
pub fn scene_json(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = scene::load_str_with_limits(text, None, &LIMITS);
    }
}

/// An OBJ mesh.
pub fn obj(data: &[u8]) {
    load_with(&scene_with(Some("m.obj"), None), "m.obj", data);
}

/// A PLY mesh (ASCII or binary).
pub fn ply(data: &[u8]) {
    load_with(&scene_with(Some("m.ply"), None), "m.ply", data);
}

/// A texture; the first byte picks the format the name claims (decoders must cope with a wrong
/// claim too).
pub fn texture(data: &[u8]) {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let name = ["t.png", "t.jpg", "t.hdr", "t.exr"][pick as usize % 4];
    load_with(&scene_with(None, Some(name)), name, rest);
}

/// An importer: the bytes as a file of that extension in a fresh folder, imported and loaded.
fn import_bytes(ext: &str, data: &[u8]) {
    let dir = std::env::temp_dir().join(format!(
        "candela-fuzz-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let path = dir.join(format!("scene.{ext}"));
    if std::fs::write(&path, data).is_err() {
        return;
    }
    for lenient in [false, true] {
        let opts = ImportOptions {
            lenient,
            params: Vec::new(),
            limits: LIMITS,
        };
        let _ = import::load_file(&path, &opts);
    }
    let _ = std::fs::remove_file(&path);
}

/// The Mitsuba 3 XML importer.
pub fn mitsuba_xml(data: &[u8]) {
    import_bytes("xml", data);
}

/// The glTF 2.0 importer (JSON or binary GLB, by the first byte).
pub fn gltf(data: &[u8]) {
    let ext = if data.starts_with(b"glTF") {
        "glb"
    } else {
        "gltf"
    };
    import_bytes(ext, data);
}

/// The pbrt-v4 importer.
pub fn pbrt(data: &[u8]) {
    import_bytes("pbrt", data);
}

/// The vkraytracing .scn importer.
pub fn scn(data: &[u8]) {
    import_bytes("scn", data);
}

/// A failure found by [`run`]: the input and what happened.
#[derive(Debug, Clone)]
pub struct Failure {
    pub input: Vec<u8>,
    pub message: String,
}

/// What [`run`] did.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub executions: u64,
    pub failures: Vec<Failure>,
}

/// Runs `target` on every seed, then on mutations of them (deterministic from `seed`) until
/// `budget` has passed; a panic is a failure. An input that runs longer than `hang` is reported
/// too (it cannot be stopped, so that is the last input tried).
pub fn run(
    target: fn(&[u8]),
    seeds: &[Vec<u8>],
    seed: u64,
    budget: Duration,
    hang: Duration,
) -> Report {
    let mut report = Report::default();
    let start = Instant::now();
    let mut rng = Rng(seed | 1);
    let try_one = |input: &[u8], report: &mut Report| {
        let t = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| target(input)));
        report.executions += 1;
        let message = match outcome {
            Err(e) => Some(format!(
                "panicked: {}",
                e.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            )),
            Ok(()) if t.elapsed() > hang => Some(format!("ran {:?}", t.elapsed())),
            Ok(()) => None,
        };
        if let Some(message) = message {
            report.failures.push(Failure {
                input: input.to_vec(),
                message,
            });
        }
    };
    // Step 1: the corpus as it is.
    for s in seeds {
        try_one(s, &mut report);
    }
    // Step 2: mutations, until the budget is spent.
    let pool: Vec<Vec<u8>> = if seeds.is_empty() {
        vec![Vec::new()]
    } else {
        seeds.to_vec()
    };
    while start.elapsed() < budget && report.failures.len() < 8 {
        let mut input = pool[rng.below(pool.len())].clone();
        let donor = &pool[rng.below(pool.len())];
        for _ in 0..1 + rng.below(4) {
            mutate(&mut input, donor, &mut rng);
        }
        try_one(&input, &mut report);
    }
    report
}

/// A xorshift generator: enough for choosing mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Bytes that often matter to parsers: delimiters, digits, signs, huge and odd numbers.
const DICTIONARY: &[&[u8]] = &[
    b"{",
    b"}",
    b"[",
    b"]",
    b"\"",
    b",",
    b":",
    b"<",
    b">",
    b"/>",
    b"\n",
    b" ",
    b"0",
    b"-1",
    b"1e308",
    b"-1e-308",
    b"NaN",
    b"inf",
    b"4294967295",
    b"2147483648",
    b"9999999999",
    b"null",
    b"true",
    b"\"type\"",
    b"element vertex ",
    b"property float x",
    b"end_header",
    b"f 1 2 3",
    b"v 0 0 0",
    b"vt ",
    b"vn ",
    b"usemtl ",
    b"Shape \"trianglemesh\"",
    b"Include ",
    b"<ref id=",
    b"$",
];

/// One random edit of `data`: flip, set, insert or delete bytes, insert a dictionary token, or
/// splice in a piece of `donor`.
fn mutate(data: &mut Vec<u8>, donor: &[u8], rng: &mut Rng) {
    let len = data.len();
    match rng.below(7) {
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
            let i = rng.below(len);
            data[i] = [0u8, 0xff, 0x7f, 0x80, b'9', b'-'][rng.below(6)];
        }
        2 => {
            let i = rng.below(len + 1);
            data.insert(i, rng.next() as u8);
        }
        3 if len > 0 => {
            let i = rng.below(len);
            let n = 1 + rng.below((len - i).min(64));
            data.drain(i..i + n);
        }
        4 => {
            let i = rng.below(len + 1);
            let word = DICTIONARY[rng.below(DICTIONARY.len())];
            data.splice(i..i, word.iter().copied());
        }
        5 if !donor.is_empty() => {
            let a = rng.below(donor.len());
            let b = a + 1 + rng.below((donor.len() - a).min(256));
            let i = rng.below(len + 1);
            data.splice(i..i, donor[a..b].iter().copied());
        }
        _ if len > 1 => {
            // Duplicate a run (repetition exercises counts and nesting).
            let a = rng.below(len);
            let b = a + 1 + rng.below((len - a).min(128));
            let piece: Vec<u8> = data[a..b].to_vec();
            data.splice(a..a, piece);
        }
        _ => data.push(rng.next() as u8),
    }
    data.truncate(1 << 20);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_driver_reports_panics_and_counts_executions() {
        fn fragile(d: &[u8]) {
            assert!(!d.contains(&b'!'), "found it");
        }
        let r = run(
            fragile,
            &[b"hello".to_vec()],
            7,
            Duration::from_millis(200),
            Duration::from_secs(5),
        );
        assert!(r.executions > 10);
        assert!(r.failures.iter().all(|f| f.input.contains(&b'!')));
        let r = run(
            fragile,
            &[b"a!".to_vec()],
            7,
            Duration::ZERO,
            Duration::from_secs(5),
        );
        assert_eq!(r.failures.len(), 1);
        assert!(r.failures[0].message.contains("found it"));
    }
}
