//! Embeds every file under `shaders/` into the binary (a table of path → source), so kernels are
//! compiled in-process from the sources the binary was built with and no files are needed at run
//! time.

use std::fmt::Write;
use std::path::Path;

fn walk(dir: &Path, root: &Path, out: &mut Vec<(String, String)>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = rd.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            walk(&p, root, out);
        } else if matches!(
            p.extension().and_then(|e| e.to_str()),
            Some("glsl" | "comp")
        ) {
            let rel = p
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            out.push((
                rel,
                p.canonicalize().unwrap().to_string_lossy().into_owned(),
            ));
        }
    }
}

/// The versions of glslang and its native library in the workspace's Cargo.lock ("unknown"
/// outside the workspace): part of the kernel cache key, so a compiler upgrade recompiles.
fn glslang_version() -> String {
    let lock = Path::new(env!("CARGO_MANIFEST_DIR")).join("../Cargo.lock");
    println!("cargo:rerun-if-changed={}", lock.display());
    let Ok(text) = std::fs::read_to_string(&lock) else {
        return "unknown".into();
    };
    let mut found = Vec::new();
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        if l == "name = \"glslang\"" || l == "name = \"glslang-sys\"" {
            if let Some(v) = lines.next().and_then(|v| v.strip_prefix("version = ")) {
                let name = l.trim_start_matches("name = ").trim_matches('"');
                found.push(format!("{name}={}", v.trim_matches('"')));
            }
        }
    }
    if found.is_empty() {
        "unknown".into()
    } else {
        found.join(",")
    }
}

fn main() {
    println!(
        "cargo:rustc-env=CANDELA_GLSLANG_VERSION={}",
        glslang_version()
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files = Vec::new();
    walk(&root, &root, &mut files);
    let mut src = String::from("/// Every shader source under shaders/, by path relative to it.\npub static SHADERS: &[(&str, &str)] = &[\n");
    for (rel, abs) in &files {
        println!("cargo:rerun-if-changed={abs}");
        writeln!(src, "    ({rel:?}, include_str!({abs:?})),").unwrap();
    }
    src.push_str("];\n");
    let out = Path::new(&std::env::var("OUT_DIR").unwrap()).join("shaders.rs");
    std::fs::write(out, src).unwrap();
}
