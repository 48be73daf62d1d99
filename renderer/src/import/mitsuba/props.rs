//! A Mitsuba plugin element read as Mitsuba reads it: typed properties (`float`, `integer`,
//! `boolean`, `string`, `rgb`, `spectrum`, `point`, `vector`, `transform`), named child objects
//! and `<ref>`s, and unnamed child objects. Every property a converter reads is marked; what is
//! left unread at the end is an unsupported parameter (Mitsuba itself refuses unreferenced
//! properties), reported with its file and line.

use std::cell::Cell;

use glam::{DMat4, DVec3};

use super::super::diag::{Loc, Report};
use super::xml::{is_object_tag, Tree};
use crate::scene::SceneError;

/// A property's value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum PValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
    Rgb([f64; 3]),
    /// `<spectrum value="...">`: a constant, or anything else (wavelength pairs, a file).
    Spectrum(Option<f64>, String),
    Vec3([f64; 3]),
    Transform(DMat4),
    /// A child object or a `<ref>` (the referenced node).
    Object(usize),
}

impl PValue {
    fn kind(&self) -> &'static str {
        match self {
            PValue::Float(_) => "a float",
            PValue::Int(_) => "an integer",
            PValue::Bool(_) => "a boolean",
            PValue::Str(_) => "a string",
            PValue::Rgb(_) => "an rgb value",
            PValue::Spectrum(..) => "a spectrum",
            PValue::Vec3(_) => "a point or vector",
            PValue::Transform(_) => "a transform",
            PValue::Object(_) => "an object",
        }
    }
}

#[derive(Debug)]
struct Prop {
    name: String,
    value: PValue,
    loc: Loc,
    used: Cell<bool>,
}

/// A colour-or-texture parameter.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ColorSrc {
    Const([f64; 3]),
    /// A texture object (node).
    Texture(usize),
}

/// One plugin element.
#[derive(Debug)]
pub(crate) struct Plugin<'t> {
    pub tree: &'t Tree,
    pub node: usize,
    /// The element (`bsdf`, `shape`, ...).
    pub tag: String,
    /// The plugin (`diffuse`, `obj`, ...).
    pub ty: String,
    pub loc: Loc,
    props: Vec<Prop>,
    /// Child objects without a name, in order.
    unnamed: Vec<(usize, Cell<bool>)>,
}

impl<'t> Plugin<'t> {
    /// Reads the element `node`.
    pub fn new(tree: &'t Tree, node: usize) -> Result<Self, SceneError> {
        let n = &tree.nodes[node];
        let mut p = Plugin {
            tree,
            node,
            tag: n.tag.clone(),
            ty: n.attr("type").unwrap_or("").to_string(),
            loc: n.loc.clone(),
            props: Vec::new(),
            unnamed: Vec::new(),
        };
        for &c in &n.children {
            let child = &tree.nodes[c];
            let name = child.attr("name").map(str::to_string);
            let value = if is_object_tag(&child.tag)
                || (child.tag == "spectrum" && child.attr("type").is_some())
            {
                PValue::Object(c)
            } else if child.tag == "ref" {
                let id = child
                    .attr("id")
                    .ok_or_else(|| child.loc.error("<ref> needs an \"id\""))?;
                let target = *tree.ids.get(id).ok_or_else(|| {
                    child.loc.error(format!(
                        "unresolved reference to \"{id}\": no object has id=\"{id}\""
                    ))
                })?;
                PValue::Object(target)
            } else {
                value_of(tree, c)?
            };
            match (name, value) {
                (None, PValue::Object(o)) => p.unnamed.push((o, Cell::new(false))),
                (None, _) => {
                    return Err(child.loc.error(format!("<{}> needs a \"name\"", child.tag)))
                }
                (Some(name), value) => {
                    if p.props.iter().any(|q| q.name == name) {
                        return Err(child
                            .loc
                            .error(format!("property \"{name}\" is given twice")));
                    }
                    p.props.push(Prop {
                        name,
                        value,
                        loc: child.loc.clone(),
                        used: Cell::new(false),
                    });
                }
            }
        }
        Ok(p)
    }

    /// What this is, for messages: `bsdf "diffuse"`.
    pub fn what(&self) -> String {
        format!("{} \"{}\"", self.tag, self.ty)
    }

    /// The place of property `name` (else of the plugin).
    pub fn loc_of(&self, name: &str) -> Loc {
        self.props
            .iter()
            .find(|p| p.name == name)
            .map_or_else(|| self.loc.clone(), |p| p.loc.clone())
    }

    /// Whether property `name` is given (does not mark it read).
    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    /// The raw value of `name`, marked read.
    pub fn get(&self, name: &str) -> Option<&PValue> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(&p.value)
    }

    fn wrong(&self, name: &str, expected: &str, got: &PValue) -> SceneError {
        self.loc_of(name).error(format!(
            "{}: property \"{name}\" must be {expected}, got {}",
            self.what(),
            got.kind()
        ))
    }

    /// A float (integers accepted).
    pub fn float(&self, name: &str) -> Result<Option<f64>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Float(x)) => Ok(Some(*x)),
            Some(PValue::Int(i)) => Ok(Some(*i as f64)),
            Some(v) => Err(self.wrong(name, "a float", v)),
        }
    }

    /// An integer.
    pub fn int(&self, name: &str) -> Result<Option<i64>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Int(i)) => Ok(Some(*i)),
            Some(v) => Err(self.wrong(name, "an integer", v)),
        }
    }

    /// A boolean.
    pub fn bool(&self, name: &str) -> Result<Option<bool>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Bool(b)) => Ok(Some(*b)),
            Some(v) => Err(self.wrong(name, "a boolean", v)),
        }
    }

    /// A string.
    pub fn string(&self, name: &str) -> Result<Option<String>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Str(s)) => Ok(Some(s.clone())),
            Some(v) => Err(self.wrong(name, "a string", v)),
        }
    }

    /// A point or vector.
    pub fn vec3(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Vec3(v)) => Ok(Some(DVec3::from_array(*v))),
            Some(v) => Err(self.wrong(name, "a point or vector", v)),
        }
    }

    /// A transform (default identity).
    pub fn transform(&self, name: &str) -> Result<DMat4, SceneError> {
        match self.get(name) {
            None => Ok(DMat4::IDENTITY),
            Some(PValue::Transform(m)) => Ok(*m),
            Some(v) => Err(self.wrong(name, "a <transform>", v)),
        }
    }

    /// A colour: rgb, a float or a constant spectrum (grey), or a texture object.
    pub fn color(&self, name: &str) -> Result<Option<ColorSrc>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Rgb(c)) => Ok(Some(ColorSrc::Const(*c))),
            Some(PValue::Float(x)) => Ok(Some(ColorSrc::Const([*x; 3]))),
            Some(PValue::Int(i)) => Ok(Some(ColorSrc::Const([*i as f64; 3]))),
            Some(PValue::Spectrum(Some(x), _)) => Ok(Some(ColorSrc::Const([*x; 3]))),
            Some(PValue::Spectrum(None, text)) => Err(self.loc_of(name).error(format!(
                "{}: spectrum \"{text}\" for \"{name}\" is not supported (only constant spectra: candela renders RGB)",
                self.what()
            ))),
            Some(PValue::Object(o)) => Ok(Some(ColorSrc::Texture(*o))),
            Some(v) => Err(self.wrong(name, "a colour or texture", v)),
        }
    }

    /// A named child object (or `<ref name=...>`).
    pub fn object(&self, name: &str) -> Result<Option<usize>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(PValue::Object(o)) => Ok(Some(*o)),
            Some(v) => Err(self.wrong(name, "an object", v)),
        }
    }

    /// The unnamed child objects with element `tag` (`bsdf`, `emitter`, ...), marked read.
    pub fn children(&self, tag: &str) -> Vec<usize> {
        self.unnamed
            .iter()
            .filter(|(o, _)| self.tree.nodes[*o].tag == tag)
            .map(|(o, used)| {
                used.set(true);
                *o
            })
            .collect()
    }

    /// Marks parameters that do not change the image (sampling strategies, file formats).
    pub fn ignore(&self, names: &[&str]) {
        for p in &self.props {
            if names.contains(&p.name.as_str()) {
                p.used.set(true);
            }
        }
    }

    /// Reports every property and child object nobody read: unsupported (strict) or ignored.
    pub fn finish(&self, report: &mut Report) -> Result<(), SceneError> {
        for p in self.props.iter().filter(|p| !p.used.get()) {
            report.unsupported(
                &p.loc,
                &format!("{}: parameter \"{}\" is not supported", self.what(), p.name),
                "ignored",
            )?;
        }
        for (o, used) in &self.unnamed {
            if !used.get() {
                let n = &self.tree.nodes[*o];
                report.unsupported(
                    &n.loc,
                    &format!(
                        "{}: a nested <{}> is not supported here",
                        self.what(),
                        n.tag
                    ),
                    "ignored",
                )?;
            }
        }
        Ok(())
    }
}

/// Numbers separated by spaces and/or commas.
fn numbers(s: &str, loc: &Loc, what: &str) -> Result<Vec<f64>, SceneError> {
    s.split([' ', ',', '\t', '\n', '\r'])
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| loc.error(format!("could not parse {what} value \"{t}\"")))
        })
        .collect()
}

/// Reads a property element.
fn value_of(tree: &Tree, node: usize) -> Result<PValue, SceneError> {
    let n = &tree.nodes[node];
    let loc = &n.loc;
    let value = || {
        n.attr("value")
            .ok_or_else(|| loc.error(format!("<{}> needs a \"value\"", n.tag)))
    };
    Ok(match n.tag.as_str() {
        "float" => {
            let v = value()?;
            PValue::Float(v.trim().parse().map_err(|_| {
                loc.error(format!("could not parse floating point value \"{v}\""))
            })?)
        }
        "integer" => {
            let v = value()?;
            PValue::Int(v.trim().parse().map_err(|_| {
                loc.error(format!("could not parse integer value \"{v}\""))
            })?)
        }
        "boolean" => {
            let v = value()?;
            match v.trim().to_ascii_lowercase().as_str() {
                "true" => PValue::Bool(true),
                "false" => PValue::Bool(false),
                _ => {
                    return Err(loc.error(format!(
                        "could not parse boolean value \"{v}\" (must be \"true\" or \"false\")"
                    )))
                }
            }
        }
        "string" => PValue::Str(value()?.to_string()),
        "rgb" => {
            let v = numbers(value()?, loc, "RGB")?;
            match v.as_slice() {
                [x] => PValue::Rgb([*x; 3]),
                [r, g, b] => PValue::Rgb([*r, *g, *b]),
                _ => {
                    return Err(loc.error(format!(
                        "<rgb> needs one or three values, got {}",
                        v.len()
                    )))
                }
            }
        }
        "spectrum" => match (n.attr("value"), n.attr("filename")) {
            (Some(v), None) => match v.trim().parse::<f64>() {
                Ok(x) => PValue::Spectrum(Some(x), v.to_string()),
                Err(_) => PValue::Spectrum(None, v.to_string()),
            },
            (None, Some(f)) => PValue::Spectrum(None, format!("file {f}")),
            _ => {
                return Err(loc.error(
                    "<spectrum> needs either \"value\" or \"filename\" (not both)",
                ))
            }
        },
        "point" | "vector" => PValue::Vec3(xyz(n, 0.0)?),
        "transform" => PValue::Transform(transform(tree, node)?),
        "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
            return Err(loc.error(format!(
                "transform operation <{}> can only appear inside a <transform>",
                n.tag
            )))
        }
        "path" => {
            return Err(loc.error(
                "<path> (extra search folders) is not supported: give file names relative to the scene's folder",
            ))
        }
        other => return Err(loc.error(format!("unsupported XML element <{other}>"))),
    })
}

/// `value="x y z"` (one value: all three) or `x`, `y`, `z` attributes (missing: `default`).
fn xyz(n: &super::xml::Node, default: f64) -> Result<[f64; 3], SceneError> {
    if let Some(v) = n.attr("value") {
        if n.attr("x").is_some() || n.attr("y").is_some() || n.attr("z").is_some() {
            return Err(n.loc.error("cannot mix \"value\" and \"x\"/\"y\"/\"z\""));
        }
        let v = numbers(v, &n.loc, "vector")?;
        return match v.as_slice() {
            [x] => Ok([*x; 3]),
            [x, y, z] => Ok([*x, *y, *z]),
            _ => Err(n.loc.error("\"value\" must have exactly 1 or 3 elements")),
        };
    }
    let mut out = [default; 3];
    for (i, k) in ["x", "y", "z"].iter().enumerate() {
        if let Some(s) = n.attr(k) {
            out[i] = s.trim().parse().map_err(|_| {
                n.loc
                    .error(format!("could not parse floating point value \"{s}\""))
            })?;
        }
    }
    Ok(out)
}

/// Three numbers from an attribute (`origin="0, 0, 5"`).
fn vec_attr(n: &super::xml::Node, key: &str) -> Result<Option<DVec3>, SceneError> {
    let Some(s) = n.attr(key) else {
        return Ok(None);
    };
    match numbers(s, &n.loc, "vector")?.as_slice() {
        [x, y, z] => Ok(Some(DVec3::new(*x, *y, *z))),
        v => Err(n
            .loc
            .error(format!("expected 3 values in \"{key}\", got {}", v.len()))),
    }
}

/// A `<transform>`: each operation applied after the ones before (Mitsuba: `T = op · T`).
fn transform(tree: &Tree, node: usize) -> Result<DMat4, SceneError> {
    let mut m = DMat4::IDENTITY;
    for &c in &tree.nodes[node].children {
        let n = &tree.nodes[c];
        let op = match n.tag.as_str() {
            "translate" => DMat4::from_translation(DVec3::from_array(xyz(n, 0.0)?)),
            "scale" => DMat4::from_scale(DVec3::from_array(xyz(n, 1.0)?)),
            "rotate" => {
                let axis = DVec3::from_array(xyz(n, 0.0)?);
                let angle: f64 = n
                    .attr("angle")
                    .ok_or_else(|| n.loc.error("<rotate> needs an \"angle\""))?
                    .trim()
                    .parse()
                    .map_err(|_| n.loc.error("could not parse the angle"))?;
                if axis == DVec3::ZERO || !axis.is_finite() {
                    return Err(n.loc.error("rotation axis cannot be zero"));
                }
                DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = numbers(
                    n.attr("value")
                        .ok_or_else(|| n.loc.error("<matrix> needs a \"value\""))?,
                    &n.loc,
                    "matrix",
                )?;
                let k = match v.len() {
                    16 => 4,
                    9 => 3,
                    len => {
                        return Err(n
                            .loc
                            .error(format!("matrix must have 9 or 16 values, got {len}")))
                    }
                };
                let mut rows = DMat4::IDENTITY.transpose().to_cols_array_2d();
                for i in 0..k {
                    for j in 0..k {
                        rows[i][j] = v[i * k + j];
                    }
                }
                DMat4::from_cols_array_2d(&rows).transpose()
            }
            "lookat" => {
                let origin = vec_attr(n, "origin")?
                    .ok_or_else(|| n.loc.error("<lookat> needs \"origin\""))?;
                let target = vec_attr(n, "target")?
                    .ok_or_else(|| n.loc.error("<lookat> needs \"target\""))?;
                let up = vec_attr(n, "up")?.unwrap_or(DVec3::ZERO);
                look_at(origin, target, up)
                    .ok_or_else(|| n.loc.error("invalid lookat transformation"))?
            }
            other => {
                return Err(n
                    .loc
                    .error(format!("unexpected <{other}> element inside <transform>")))
            }
        };
        m = op * m;
    }
    if !m.is_finite() {
        return Err(tree.nodes[node].loc.error("the transform is not finite"));
    }
    Ok(m)
}

/// Mitsuba's `look_at`: columns (left, up', dir, origin) with left = up × dir; a zero `up` is
/// replaced by a vector perpendicular to dir (`coordinate_system`).
pub(crate) fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let up = if up == DVec3::ZERO {
        coordinate_system(dir)
    } else {
        up.try_normalize()?
    };
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// The first tangent of Mitsuba's `coordinate_system(n)` (Duff et al. 2017).
fn coordinate_system(n: DVec3) -> DVec3 {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_matches_mitsuba() {
        let m = look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y).unwrap();
        // Mitsuba: ScalarTransform4f().look_at([0,0,5],[0,0,0],[0,1,0]) = [[-1,0,0,0],[0,1,0,0],[0,0,-1,5],[0,0,0,1]].
        assert_eq!(m.col(0).truncate(), DVec3::new(-1.0, 0.0, 0.0));
        assert_eq!(m.col(2).truncate(), DVec3::new(0.0, 0.0, -1.0));
        assert_eq!(m.col(3).truncate(), DVec3::new(0.0, 0.0, 5.0));
        assert!(look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_none());
        assert!(look_at(DVec3::ZERO, DVec3::Z, DVec3::ZERO).is_some());
    }
}
