//! Where a construct came from in a source file, and the error policy shared by every importer:
//! something the importer cannot express exactly is an error naming the file, the line (when the
//! format has lines) and the construct; with `lenient` it becomes a warning and is skipped.

use std::fmt;
use std::sync::Arc;

use crate::scene::SceneError;

/// A place in a source file: its name as shown to the user and a 1-based line when known.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Loc {
    pub file: Arc<str>,
    pub line: Option<usize>,
}

impl Loc {
    /// `file` at `line`.
    pub fn new(file: &Arc<str>, line: Option<usize>) -> Self {
        Loc {
            file: file.clone(),
            line,
        }
    }

    /// The whole file (no line).
    pub fn file(file: &Arc<str>) -> Self {
        Loc::new(file, None)
    }

    /// An error at this place.
    pub fn error(&self, msg: impl Into<String>) -> SceneError {
        SceneError::Import {
            file: self.file.to_string(),
            line: self.line,
            msg: msg.into(),
        }
    }
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}", self.file),
            None => write!(f, "{}", self.file),
        }
    }
}

/// A warning (or, in strict mode, the text of an error) about a construct at a place.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    pub loc: Loc,
    pub msg: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.loc, self.msg)
    }
}

/// The error policy and the warnings collected so far.
#[derive(Debug, Default)]
pub(crate) struct Report {
    pub lenient: bool,
    pub warnings: Vec<Diagnostic>,
}

impl Report {
    pub fn new(lenient: bool) -> Self {
        Report {
            lenient,
            warnings: Vec::new(),
        }
    }

    /// A construct candela cannot express. Strict: an error `what (use --lenient to ...)`;
    /// lenient: a warning `what: instead` and `Ok(())`, after which the caller does `instead`.
    pub fn unsupported(&mut self, loc: &Loc, what: &str, instead: &str) -> Result<(), SceneError> {
        if self.lenient {
            self.warn(loc, format!("{what}: {instead}"));
            Ok(())
        } else {
            Err(loc.error(format!(
                "{what} (with --lenient it is {})",
                lenient_phrase(instead)
            )))
        }
    }

    /// A warning that does not depend on the policy (an approximation the docs name).
    pub fn warn(&mut self, loc: &Loc, msg: impl Into<String>) {
        let d = Diagnostic {
            loc: loc.clone(),
            msg: msg.into(),
        };
        tracing::debug!("import: {d}");
        if !self.warnings.contains(&d) {
            self.warnings.push(d);
        }
    }
}

/// "skipped" stays "skipped"; "uses X instead" reads "replaced: uses X instead".
fn lenient_phrase(instead: &str) -> String {
    if instead == "skipped" || instead == "ignored" {
        instead.to_string()
    } else {
        format!("replaced: {instead}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strict_errors_and_lenient_warnings() {
        let file: Arc<str> = Arc::from("scene.xml");
        let loc = Loc::new(&file, Some(12));
        let mut strict = Report::new(false);
        let e = strict
            .unsupported(&loc, "bsdf \"hair\" is not supported", "skipped")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "scene.xml:12: bsdf \"hair\" is not supported (with --lenient it is skipped)"
        );
        let mut lenient = Report::new(true);
        lenient
            .unsupported(&loc, "bsdf \"hair\" is not supported", "uses diffuse 0.5")
            .unwrap();
        lenient
            .unsupported(&loc, "bsdf \"hair\" is not supported", "uses diffuse 0.5")
            .unwrap();
        assert_eq!(lenient.warnings.len(), 1, "repeated warnings are kept once");
        assert_eq!(
            lenient.warnings[0].to_string(),
            "scene.xml:12: bsdf \"hair\" is not supported: uses diffuse 0.5"
        );
        assert_eq!(Loc::file(&file).to_string(), "scene.xml");
    }
}
