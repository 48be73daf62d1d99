//! Scene files of any format on the command line (docs/import.md): the `--lenient` and `-D`
//! flags shared by `render`, `bench` and `convert`, loading through `renderer::import` with the
//! importer's warnings printed on stderr, and error messages that name the file once.

use std::path::Path;

use clap::Args;
use renderer::import::{Diagnostic, ImportOptions};
use renderer::scene::{Scene, SceneError};

use super::CliError;

/// How scene files of other formats (Mitsuba XML, glTF, pbrt, .scn) are imported.
#[derive(Debug, Clone, Default, Args)]
pub struct ImportArgs {
    /// Import what candela cannot express as warnings (printed on stderr) and skip it, instead
    /// of refusing the scene.
    #[arg(long)]
    pub lenient: bool,
    /// A Mitsuba XML parameter `$NAME` (as `mitsuba -D NAME=VALUE`); may be repeated.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE")]
    pub define: Vec<String>,
}

impl ImportArgs {
    /// The importer's options.
    pub fn options(&self) -> Result<ImportOptions, CliError> {
        let mut params = Vec::new();
        for d in &self.define {
            match d.split_once('=') {
                Some((k, v)) if !k.is_empty() => params.push((k.to_string(), v.to_string())),
                _ => return Err(CliError::input(format!("-D {d}: expected NAME=VALUE"))),
            }
        }
        Ok(ImportOptions {
            lenient: self.lenient,
            params,
            ..Default::default()
        })
    }
}

/// One line for a scene error: `FILE: error`, unless the error names its file already.
pub fn scene_error(path: &Path, e: &SceneError) -> String {
    match e {
        SceneError::Import { .. } => e.to_string(),
        _ => format!("{}: {e}", path.display()),
    }
}

/// Prints the importer's warnings on stderr.
pub fn print_warnings(warnings: &[Diagnostic]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// Loads a scene file of any format (bad input: exit 2), printing the importer's warnings.
pub fn load_scene(path: &Path, args: &ImportArgs) -> Result<Scene, CliError> {
    let opts = args.options()?;
    let loaded = renderer::import::load_file(path, &opts)
        .map_err(|e| CliError::input(scene_error(path, &e)))?;
    print_warnings(&loaded.warnings);
    Ok(loaded.scene)
}
