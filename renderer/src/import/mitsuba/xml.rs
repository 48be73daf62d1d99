//! Mitsuba 3 XML as a tree of elements with their file and line, after the parser's own
//! passes (Mitsuba's `src/core/parser.cpp`): `$name` substitution in attribute values (longest
//! name first, `\$` escapes), `<default>` parameters (used unless given), `<include>` (an included
//! `<scene>`'s children are spliced in place), `<alias>`, ids registered across files
//! (duplicates are errors) and the version < 2.0 upgrade (property names camelCase →
//! snake_case; `diffuse_reflectance` → `reflectance` on `diffuse`).
//!
//! Files named by `<include>` (and every other file name) resolve against the including file's
//! folder, then the scene's folder, and must stay inside the scene's folder.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::super::diag::Loc;
use super::super::files::{resolve_in, to_slash};
use crate::scene::SceneError;

/// Deepest `<include>` nesting accepted (Mitsuba's default limit is 15).
const MAX_INCLUDE_DEPTH: usize = 15;

/// One XML element.
#[derive(Debug, Clone)]
pub(crate) struct Node {
    pub tag: String,
    /// Attributes after `$` substitution.
    pub attrs: Vec<(String, String)>,
    pub loc: Loc,
    pub children: Vec<usize>,
    /// The folder of the file it was written in, relative to the scene's folder.
    pub dir: PathBuf,
}

impl Node {
    /// An attribute's value.
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The parsed scene.
#[derive(Debug)]
pub(crate) struct Tree {
    pub nodes: Vec<Node>,
    /// id → node.
    pub ids: HashMap<String, usize>,
    /// The `<scene>` element.
    pub root: usize,
    /// The scene's folder (everything must stay inside it).
    pub scene_dir: PathBuf,
}

impl Tree {
    /// Resolves a file name written at `node`: against its file's folder, then the scene's
    /// folder; returns the path relative to the scene's folder. Absolute names and names that
    /// leave the scene's folder are errors.
    pub fn resolve(&self, node: usize, name: &str) -> Result<String, SceneError> {
        let n = &self.nodes[node];
        resolve_in(&self.scene_dir, &n.dir, name)
            .map(|p| to_slash(&p))
            .map_err(|msg| n.loc.error(msg))
    }
}

/// Parses `path` (the scene file) with `params` (`-D name=value`).
pub(crate) fn parse(path: &Path, params: &[(String, String)]) -> Result<Tree, SceneError> {
    let scene_dir = super::super::folder_of(path);
    let mut b = Builder {
        nodes: Vec::new(),
        ids: HashMap::new(),
        params: params
            .iter()
            .map(|(k, v)| (format!("${k}"), v.clone()))
            .collect(),
        scene_dir: scene_dir.clone(),
        shown_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
    };
    let text = read_text(path, &Loc::file(&Arc::from(path.display().to_string())))?;
    let shown: Arc<str> = Arc::from(path.display().to_string());
    let top = b.file(&text, &shown, Path::new(""), 0)?;
    let root = match top {
        Parsed::Scene(root) => root,
        Parsed::Element(i) => {
            return Err(b.nodes[i]
                .loc
                .error("the root element must be <scene version=\"...\">"))
        }
    };
    Ok(Tree {
        nodes: b.nodes,
        ids: b.ids,
        root,
        scene_dir,
    })
}

fn read_text(path: &Path, loc: &Loc) -> Result<String, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| {
        loc.error(format!(
            "cannot read \"{}\": {}",
            path.display(),
            crate::scene::io_message(&e)
        ))
    })?;
    String::from_utf8(bytes).map_err(|_| loc.error("not UTF-8 text"))
}

/// What a file's root element became.
enum Parsed {
    /// A `<scene>`: its node (children are what an include splices in).
    Scene(usize),
    /// Any other element.
    Element(usize),
}

struct Builder {
    nodes: Vec<Node>,
    ids: HashMap<String, usize>,
    /// `$name` → value, kept longest name first.
    params: Vec<(String, String)>,
    scene_dir: PathBuf,
    /// How the scene's folder is shown in messages (the path as the user gave it).
    shown_dir: PathBuf,
}

/// Per-file state.
struct FileCtx<'a> {
    shown: &'a Arc<str>,
    dir: &'a Path,
    version: (u32, u32, u32),
    depth: usize,
    doc: &'a roxmltree::Document<'a>,
}

impl Builder {
    /// Parses one file's text; `dir` is its folder relative to the scene's.
    fn file(
        &mut self,
        text: &str,
        shown: &Arc<str>,
        dir: &Path,
        depth: usize,
    ) -> Result<Parsed, SceneError> {
        let opts = roxmltree::ParsingOptions {
            allow_dtd: true,
            ..Default::default()
        };
        let doc = roxmltree::Document::parse_with_options(text, opts).map_err(|e| {
            Loc::new(shown, Some(e.pos().row as usize)).error(format!("XML syntax error: {e}"))
        })?;
        let root = doc.root_element();
        let loc = Loc::new(
            shown,
            Some(doc.text_pos_at(root.range().start).row as usize),
        );
        let version = match root.attribute("version") {
            Some(v) => parse_version(v).ok_or_else(|| {
                loc.error(format!(
                    "invalid version number \"{v}\" in <{}>",
                    root.tag_name().name()
                ))
            })?,
            None => {
                return Err(loc.error(format!(
                    "missing version attribute in the root element <{}>",
                    root.tag_name().name()
                )))
            }
        };
        let ctx = FileCtx {
            shown,
            dir,
            version,
            depth,
            doc: &doc,
        };
        let is_scene = root.tag_name().name() == "scene";
        let ids = self.element(&ctx, root, None)?;
        let i = ids
            .first()
            .copied()
            .ok_or_else(|| loc.error("empty root element"))?;
        Ok(if is_scene {
            Parsed::Scene(i)
        } else {
            Parsed::Element(i)
        })
    }

    /// Converts one element (and its subtree); returns the nodes that take its place in the
    /// parent (none for `<default>` and `<alias>`, several for an included scene).
    fn element(
        &mut self,
        ctx: &FileCtx<'_>,
        x: roxmltree::Node<'_, '_>,
        parent_type: Option<&str>,
    ) -> Result<Vec<usize>, SceneError> {
        let line = ctx.doc.text_pos_at(x.range().start).row as usize;
        let loc = Loc::new(ctx.shown, Some(line));
        let tag = x.tag_name().name().to_string();
        // Step 1: attributes, with parameters substituted.
        let mut attrs = Vec::new();
        for a in x.attributes() {
            let v = self.substitute(a.value(), &loc)?;
            attrs.push((a.name().to_string(), v));
        }
        let get = |k: &str| attrs.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
        // Step 2: the parser's own elements.
        match tag.as_str() {
            "default" => {
                let (Some(name), Some(value)) = (get("name"), get("value")) else {
                    return Err(loc.error("<default> needs \"name\" and \"value\""));
                };
                let key = format!("${name}");
                if !self.params.iter().any(|(k, _)| *k == key) {
                    self.params.push((key, value));
                    self.params.sort_by_key(|(k, _)| std::cmp::Reverse(k.len()));
                }
                return Ok(Vec::new());
            }
            "alias" => {
                let (Some(id), Some(alias)) = (get("id"), get("as")) else {
                    return Err(loc.error("<alias> needs \"id\" and \"as\""));
                };
                let Some(&target) = self.ids.get(&id) else {
                    return Err(loc.error(format!("alias source id \"{id}\" not found")));
                };
                if self.ids.insert(alias.clone(), target).is_some() {
                    return Err(
                        loc.error(format!("alias destination id \"{alias}\" already exists"))
                    );
                }
                return Ok(Vec::new());
            }
            "include" => return self.include(ctx, &loc, get("filename")),
            _ => {}
        }
        // Step 3: a node, its name upgraded for old files, its children.
        if ctx.version.0 < 2 {
            for (k, v) in &mut attrs {
                if k == "name" {
                    *v = camel_to_snake(v);
                    if parent_type == Some("diffuse") && v == "diffuse_reflectance" {
                        *v = "reflectance".into();
                    }
                }
            }
        }
        let index = self.nodes.len();
        let ty = attrs
            .iter()
            .find(|(k, _)| k == "type")
            .map(|(_, v)| v.clone());
        if let Some(id) = attrs
            .iter()
            .find(|(k, _)| k == "id")
            .map(|(_, v)| v.clone())
        {
            if is_object_tag(&tag) || tag == "scene" {
                if let Some(&prev) = self.ids.get(&id) {
                    return Err(loc.error(format!(
                        "duplicate id \"{id}\" (previous at {})",
                        self.nodes[prev].loc
                    )));
                }
                self.ids.insert(id, index);
            }
        }
        self.nodes.push(Node {
            tag,
            attrs,
            loc,
            children: Vec::new(),
            dir: ctx.dir.to_path_buf(),
        });
        let mut children = Vec::new();
        for c in x.children().filter(|c| c.is_element()) {
            children.extend(self.element(ctx, c, ty.as_deref())?);
        }
        self.nodes[index].children = children;
        Ok(vec![index])
    }

    /// `<include filename="..."/>`.
    fn include(
        &mut self,
        ctx: &FileCtx<'_>,
        loc: &Loc,
        filename: Option<String>,
    ) -> Result<Vec<usize>, SceneError> {
        let Some(name) = filename else {
            return Err(loc.error("<include> needs \"filename\""));
        };
        if ctx.depth + 1 > MAX_INCLUDE_DEPTH {
            return Err(loc.error(format!(
                "<include> nested more than {MAX_INCLUDE_DEPTH} deep (a cycle?)"
            )));
        }
        let rel = resolve_in(&self.scene_dir, ctx.dir, &name).map_err(|m| loc.error(m))?;
        let full = self.scene_dir.join(&rel);
        if !full.is_file() {
            return Err(loc.error(format!("included file \"{name}\" not found")));
        }
        let text = read_text(&full, loc)?;
        let shown: Arc<str> = Arc::from(self.shown_dir.join(&rel).display().to_string());
        let dir = rel.parent().map(Path::to_path_buf).unwrap_or_default();
        match self.file(&text, &shown, &dir, ctx.depth + 1)? {
            Parsed::Scene(i) => Ok(std::mem::take(&mut self.nodes[i].children)),
            Parsed::Element(i) => Ok(vec![i]),
        }
    }

    /// Replaces `$name` by its value (longest names first); an undefined one is an error.
    fn substitute(&self, value: &str, loc: &Loc) -> Result<String, SceneError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut v = value.to_string();
        for (key, val) in &self.params {
            let mut pos = 0;
            while let Some(found) = v[pos..].find(key.as_str()) {
                let at = pos + found;
                if at > 0 && v.as_bytes()[at - 1] == b'\\' {
                    pos = at + key.len();
                } else {
                    v.replace_range(at..at + key.len(), val);
                    pos = at + val.len();
                }
            }
        }
        let bytes = v.as_bytes();
        for (i, &c) in bytes.iter().enumerate() {
            if c == b'$' && (i == 0 || bytes[i - 1] != b'\\') {
                let name: String = v[i + 1..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                return Err(loc.error(format!("undefined parameter ${name}")));
            }
        }
        Ok(v.replace("\\$", "$"))
    }
}

/// The tags that make objects (Mitsuba's `interpret_tag`).
pub(crate) fn is_object_tag(tag: &str) -> bool {
    matches!(
        tag,
        "bsdf"
            | "emitter"
            | "film"
            | "integrator"
            | "medium"
            | "phase"
            | "rfilter"
            | "sampler"
            | "sensor"
            | "shape"
            | "texture"
            | "volume"
            | "field"
    )
}

/// `"3.0.0"`, `"2.1"`, `"0.5.0"` → (major, minor, patch).
fn parse_version(s: &str) -> Option<(u32, u32, u32)> {
    let mut parts = s.trim().split('.').map(|p| p.parse::<u32>());
    let major = parts.next()?.ok()?;
    let minor = parts.next().unwrap_or(Ok(0)).ok()?;
    let patch = parts.next().unwrap_or(Ok(0)).ok()?;
    parts.next().is_none().then_some((major, minor, patch))
}

/// Mitsuba's `camel_to_underscore_case`: `maxDepth` → `max_depth`, `intIOR` → `int_ior`.
fn camel_to_snake(s: &str) -> String {
    let chars: Vec<char> = s.chars().collect();
    let mut out = String::with_capacity(s.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::paths::tests::temp_dir;

    #[test]
    fn names_and_versions() {
        assert_eq!(camel_to_snake("maxDepth"), "max_depth");
        assert_eq!(camel_to_snake("intIOR"), "int_ior");
        assert_eq!(camel_to_snake("sampleCount"), "sample_count");
        assert_eq!(camel_to_snake("to_world"), "to_world");
        assert_eq!(parse_version("3.0.0"), Some((3, 0, 0)));
        assert_eq!(parse_version("0.5"), Some((0, 5, 0)));
        assert_eq!(parse_version("x"), None);
    }

    #[test]
    fn params_defaults_includes_and_ids() {
        let dir = temp_dir("mi_xml");
        std::fs::create_dir_all(dir.join("parts")).unwrap();
        std::fs::write(
            dir.join("parts/mat.xml"),
            "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"white\"/>\n</scene>\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("s.xml"),
            "<scene version=\"3.0.0\">\n<default name=\"spp\" value=\"16\"/>\n\
             <include filename=\"parts/mat.xml\"/>\n\
             <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>\n\
             <string name=\"x\" value=\"a\\$b\"/>\n</scene>\n",
        )
        .unwrap();
        let t = parse(&dir.join("s.xml"), &[]).unwrap();
        let root = &t.nodes[t.root];
        assert_eq!(root.children.len(), 3);
        let white = t.ids["white"];
        assert_eq!(t.nodes[white].loc.line, Some(2));
        assert!(t.nodes[white].loc.file.ends_with("parts/mat.xml"));
        let sampler = &t.nodes[root.children[1]];
        assert_eq!(t.nodes[sampler.children[0]].attr("value"), Some("16"));
        assert_eq!(t.nodes[root.children[2]].attr("value"), Some("a$b"));
        let t = parse(&dir.join("s.xml"), &[("spp".into(), "64".into())]).unwrap();
        let sampler = &t.nodes[t.nodes[t.root].children[1]];
        assert_eq!(
            t.nodes[sampler.children[0]].attr("value"),
            Some("64"),
            "-D wins"
        );

        std::fs::write(
            dir.join("u.xml"),
            "<scene version=\"3.0.0\">\n\n<float name=\"a\" value=\"$nope\"/></scene>",
        )
        .unwrap();
        let e = parse(&dir.join("u.xml"), &[]).unwrap_err().to_string();
        assert!(e.ends_with("u.xml:3: undefined parameter $nope"), "{e}");
        std::fs::write(dir.join("d.xml"), "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/></scene>").unwrap();
        let e = parse(&dir.join("d.xml"), &[]).unwrap_err().to_string();
        assert!(e.contains("d.xml:2: duplicate id \"a\""), "{e}");
        std::fs::write(
            dir.join("esc.xml"),
            "<scene version=\"3.0.0\"><include filename=\"../x.xml\"/></scene>",
        )
        .unwrap();
        let e = parse(&dir.join("esc.xml"), &[]).unwrap_err().to_string();
        assert!(e.contains("leaves the scene folder"), "{e}");
        std::fs::write(
            dir.join("cyc.xml"),
            "<scene version=\"3.0.0\"><include filename=\"cyc.xml\"/></scene>",
        )
        .unwrap();
        let e = parse(&dir.join("cyc.xml"), &[]).unwrap_err().to_string();
        assert!(e.contains("nested more than"), "{e}");
        std::fs::write(
            dir.join("bad.xml"),
            "<scene version=\"3.0.0\">\n<bsdf>\n</scene>",
        )
        .unwrap();
        let e = parse(&dir.join("bad.xml"), &[]).unwrap_err().to_string();
        assert!(e.contains("bad.xml:3: XML syntax error"), "{e}");
        std::fs::write(dir.join("old.xml"), "<scene version=\"0.5.0\"><integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator></scene>").unwrap();
        let t = parse(&dir.join("old.xml"), &[]).unwrap();
        let integ = &t.nodes[t.nodes[t.root].children[0]];
        assert_eq!(t.nodes[integ.children[0]].attr("name"), Some("max_depth"));
    }
}
