//! pbrt parameter lists (`"float fov" [45]`, `"rgb L" [1 1 1]`, `"texture reflectance" "wood"`),
//! read after a directive's own arguments, with typed access. Every parameter read is marked;
//! those left unread are unsupported parameters, reported with their line.

use std::cell::Cell;

use super::tokens::{Tok, Tokens};
use crate::import::diag::{Loc, Report};
use crate::scene::SceneError;

/// One value of a parameter.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum PV {
    Num(f64),
    Str(String),
    Bool(bool),
}

/// One parameter.
#[derive(Debug)]
pub(crate) struct Param {
    pub ty: String,
    pub name: String,
    pub values: Vec<PV>,
    pub loc: Loc,
    used: Cell<bool>,
}

/// A spectrum-valued parameter.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Spectrum {
    Rgb([f64; 3]),
    /// A named spectrum (`"metal-Cu-eta"`, `"glass-BK7"`).
    Named(String),
    /// A texture by name.
    Texture(String),
    /// What is not supported: blackbody, tabulated spectra that vary, files.
    Other(String),
}

/// A directive's parameters.
#[derive(Debug, Default)]
pub(crate) struct Params {
    pub list: Vec<Param>,
}

/// Reads parameters until the next directive.
pub(crate) fn read(t: &mut Tokens) -> Result<Params, SceneError> {
    let mut list: Vec<Param> = Vec::new();
    while let Some(tok) = t.peek()? {
        let Tok::Str(decl) = &tok.tok else { break };
        let (decl, line) = (decl.clone(), tok.line);
        t.next()?;
        let loc = t.loc(line);
        let mut parts = decl.split_whitespace();
        let (Some(ty), Some(name), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(loc.error(format!("parameter \"{decl}\" must be \"TYPE NAME\"")));
        };
        let mut values = Vec::new();
        let one = |tok: Tok, loc: &Loc| -> Result<PV, SceneError> {
            Ok(match tok {
                Tok::Str(s) => PV::Str(s),
                Tok::Word(w) if w == "true" => PV::Bool(true),
                Tok::Word(w) if w == "false" => PV::Bool(false),
                Tok::Word(w) => PV::Num(
                    w.parse()
                        .map_err(|_| loc.error(format!("\"{w}\" is not a number")))?,
                ),
                _ => return Err(loc.error("unexpected bracket")),
            })
        };
        match t.next()? {
            Some(tok) if tok.tok == Tok::Open => loop {
                match t.next()? {
                    None => return Err(loc.error(format!("unterminated [ in \"{decl}\""))),
                    Some(x) if x.tok == Tok::Close => break,
                    Some(x) => values.push(one(x.tok, &t.loc(x.line))?),
                }
            },
            Some(tok) => values.push(one(tok.tok, &t.loc(tok.line))?),
            None => return Err(loc.error(format!("\"{decl}\" has no value"))),
        }
        // "bool" values may be written as strings.
        if ty == "bool" {
            for v in &mut values {
                if let PV::Str(s) = v {
                    *v = match s.as_str() {
                        "true" => PV::Bool(true),
                        "false" => PV::Bool(false),
                        _ => return Err(loc.error(format!("\"{s}\" is not true or false"))),
                    };
                }
            }
        }
        if list.iter().any(|p| p.name == name) {
            return Err(loc.error(format!("parameter \"{name}\" is given twice")));
        }
        list.push(Param {
            ty: ty.to_string(),
            name: name.to_string(),
            values,
            loc,
            used: Cell::new(false),
        });
    }
    Ok(Params { list })
}

impl Params {
    fn find(&self, name: &str) -> Option<&Param> {
        let p = self.list.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    /// The place of `name`, else `fallback`.
    pub fn loc(&self, name: &str, fallback: &Loc) -> Loc {
        self.list
            .iter()
            .find(|p| p.name == name)
            .map_or_else(|| fallback.clone(), |p| p.loc.clone())
    }

    /// Whether `name` is given (not marked read).
    pub fn has(&self, name: &str) -> bool {
        self.list.iter().any(|p| p.name == name)
    }

    /// Numbers of `name` (integers and floats).
    pub fn nums(&self, name: &str) -> Result<Option<Vec<f64>>, SceneError> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        p.values
            .iter()
            .map(|v| match v {
                PV::Num(x) => Ok(*x),
                _ => Err(p.loc.error(format!("\"{name}\" must hold numbers"))),
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
    }

    /// One number.
    pub fn num(&self, name: &str) -> Result<Option<f64>, SceneError> {
        let Some(p) = self.list.iter().find(|p| p.name == name) else {
            return Ok(None);
        };
        match self.nums(name)? {
            Some(v) if v.len() == 1 => Ok(Some(v[0])),
            v => Err(p.loc.error(format!(
                "\"{name}\" must be one number, got {}",
                v.map_or(0, |v| v.len())
            ))),
        }
    }

    /// One string.
    pub fn string(&self, name: &str) -> Result<Option<String>, SceneError> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match p.values.as_slice() {
            [PV::Str(s)] => Ok(Some(s.clone())),
            _ => Err(p.loc.error(format!("\"{name}\" must be one string"))),
        }
    }

    /// One boolean.
    pub fn bool(&self, name: &str) -> Result<Option<bool>, SceneError> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match p.values.as_slice() {
            [PV::Bool(b)] => Ok(Some(*b)),
            _ => Err(p.loc.error(format!("\"{name}\" must be true or false"))),
        }
    }

    /// A spectrum-valued parameter (`rgb`, `spectrum`, `blackbody`, `float`, `texture`).
    pub fn spectrum(&self, name: &str) -> Result<Option<Spectrum>, SceneError> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        let nums: Vec<f64> = p
            .values
            .iter()
            .filter_map(|v| if let PV::Num(x) = v { Some(*x) } else { None })
            .collect();
        let bad = || {
            p.loc
                .error(format!("\"{} {name}\": unexpected values", p.ty))
        };
        Ok(Some(match (p.ty.as_str(), p.values.as_slice()) {
            ("rgb" | "color", _) if nums.len() == 3 => Spectrum::Rgb([nums[0], nums[1], nums[2]]),
            ("float", _) if nums.len() == 1 => Spectrum::Rgb([nums[0]; 3]),
            ("texture", [PV::Str(s)]) => Spectrum::Texture(s.clone()),
            ("spectrum", [PV::Str(s)]) => Spectrum::Named(s.clone()),
            ("spectrum", _) if nums.len() >= 2 && nums.len().is_multiple_of(2) => {
                let values: Vec<f64> = nums.chunks(2).map(|c| c[1]).collect();
                if values.iter().all(|&v| v == values[0]) {
                    Spectrum::Rgb([values[0]; 3])
                } else {
                    Spectrum::Other("a tabulated spectrum that varies with wavelength".into())
                }
            }
            ("blackbody", _) if nums.len() == 1 => {
                Spectrum::Other(format!("blackbody {} K", nums[0]))
            }
            _ => return Err(bad()),
        }))
    }

    /// Marks parameters that do not change the image.
    pub fn ignore(&self, names: &[&str]) {
        for p in &self.list {
            if names.contains(&p.name.as_str()) {
                p.used.set(true);
            }
        }
    }

    /// Marks every parameter read (a construct skipped as a whole).
    pub fn ignore_all(&self) {
        for p in &self.list {
            p.used.set(true);
        }
    }

    /// Reports every parameter nobody read (unsupported; ignored under --lenient).
    pub fn finish(&self, report: &mut Report, what: &str) -> Result<(), SceneError> {
        for p in self.list.iter().filter(|p| !p.used.get()) {
            report.unsupported(
                &p.loc,
                &format!("{what}: parameter \"{} {}\" is not supported", p.ty, p.name),
                "ignored",
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn params(text: &str) -> Params {
        let mut t = Tokens::new(text.as_bytes().to_vec(), Arc::from("p.pbrt"));
        read(&mut t).unwrap()
    }

    #[test]
    fn typed_values() {
        let p = params("\"float fov\" [45] \"rgb L\" [1 2 3] \"bool twosided\" \"true\" \"spectrum eta\" \"glass-BK7\" \"integer indices\" [0 1 2] \"spectrum k\" [400 2 700 2] Shape");
        assert_eq!(p.num("fov").unwrap(), Some(45.0));
        assert_eq!(
            p.spectrum("L").unwrap(),
            Some(Spectrum::Rgb([1.0, 2.0, 3.0]))
        );
        assert_eq!(p.bool("twosided").unwrap(), Some(true));
        assert_eq!(
            p.spectrum("eta").unwrap(),
            Some(Spectrum::Named("glass-BK7".into()))
        );
        assert_eq!(p.nums("indices").unwrap(), Some(vec![0.0, 1.0, 2.0]));
        assert_eq!(p.spectrum("k").unwrap(), Some(Spectrum::Rgb([2.0; 3])));
        let mut t = Tokens::new(b"\"blah\" 2".to_vec(), Arc::from("p.pbrt"));
        assert!(read(&mut t)
            .unwrap_err()
            .to_string()
            .contains("must be \"TYPE NAME\""));
        let mut r = Report::new(false);
        let p = params("\"float a\" [1] \"float b\" 2");
        p.num("a").unwrap();
        let e = p
            .finish(&mut r, "shape \"sphere\"")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("p.pbrt:1: shape \"sphere\": parameter \"float b\" is not supported"),
            "{e}"
        );
    }
}
