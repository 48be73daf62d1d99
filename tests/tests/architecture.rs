//! The code's shape, checked: the top-level modules of the renderer and server crates, and the web
//! viewer's ES modules, depend on each other in one direction only (no cycles), so each layer can
//! be read, tested and replaced below the ones that use it.
//!
//! Rust: a module depends on another when any of its files names `crate::other` outside a
//! comment. JavaScript: when it imports `./other.js`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use candela_tests::repo_root;

/// Module → the modules it uses.
type Graph = BTreeMap<String, BTreeSet<String>>;

/// Every file under `dir`, recursively, with the given extension.
fn files(dir: &Path, ext: &str, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, ext, out);
        } else if p.extension().and_then(|e| e.to_str()) == Some(ext) {
            out.push(p);
        }
    }
}

/// `text` without `//` comments (line and doc comments; string literals holding `//` are rare
/// enough in this code base to ignore).
fn strip_comments(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level module graph of the crate whose sources are in `src`.
fn rust_graph(src: &Path) -> Graph {
    let mut graph = Graph::new();
    let mut all = Vec::new();
    files(src, "rs", &mut all);
    for f in all {
        let rel = f.strip_prefix(src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "lib" || module == "main" {
            continue;
        }
        let text = strip_comments(&std::fs::read_to_string(&f).unwrap());
        let deps = graph.entry(module.clone()).or_default();
        let mut rest = text.as_str();
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + "crate::".len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() && name != module {
                deps.insert(name);
            }
        }
    }
    graph
}

/// The web viewer's import graph (module file stem → imported stems).
fn js_graph(dir: &Path) -> Graph {
    let mut graph = Graph::new();
    let mut all = Vec::new();
    files(dir, "js", &mut all);
    for f in all {
        let stem = f.file_stem().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&f).unwrap();
        let deps = graph.entry(stem).or_default();
        for line in text
            .lines()
            .filter(|l| l.trim_start().starts_with("import "))
        {
            if let Some(i) = line.find("'./") {
                let name = &line[i + 3..];
                if let Some(j) = name.find(".js'") {
                    deps.insert(name[..j].to_string());
                }
            }
        }
    }
    graph
}

/// A cycle in `graph`, if there is one, as the path of modules around it.
fn find_cycle(graph: &Graph) -> Option<Vec<String>> {
    // Depth-first search with three colours; the grey path is the stack.
    fn visit(
        n: &str,
        graph: &Graph,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for d in graph.get(n).into_iter().flatten() {
            match state.get(d.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = path.iter().position(|p| p == d).unwrap();
                    let mut cycle = path[start..].to_vec();
                    cycle.push(d.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(d, graph, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(n, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

fn assert_acyclic(what: &str, graph: &Graph) {
    println!("{what}:");
    for (m, deps) in graph {
        println!(
            "  {m} -> {}",
            deps.iter().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    if let Some(c) = find_cycle(graph) {
        panic!("{what}: module cycle {}", c.join(" -> "));
    }
}

#[test]
fn renderer_modules_have_no_cycles() {
    assert_acyclic("renderer", &rust_graph(&repo_root().join("renderer/src")));
}

#[test]
fn server_modules_have_no_cycles() {
    assert_acyclic("server", &rust_graph(&repo_root().join("server/src")));
}

#[test]
fn web_modules_import_in_one_direction() {
    assert_acyclic("web", &js_graph(&repo_root().join("web")));
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let g: Graph = [
        ("a", vec!["b"]),
        ("b", vec!["c"]),
        ("c", vec!["a", "d"]),
        ("d", vec![]),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.into_iter().map(String::from).collect()))
    .collect();
    assert_eq!(find_cycle(&g).unwrap(), ["a", "b", "c", "a"]);
    let mut acyclic = g.clone();
    acyclic.get_mut("c").unwrap().remove("a");
    assert_eq!(find_cycle(&acyclic), None);
}
