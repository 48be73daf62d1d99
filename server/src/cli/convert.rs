//! `candela convert IN OUT`: a scene file of any format (docs/import.md) written as candela JSON
//! (`OUT.json`, meshes and images the source holds inline written beside it in `OUT_assets/`),
//! or a candela JSON scene written as Mitsuba 3 XML (`OUT.xml`, for rendering the same scene
//! with Mitsuba). The written scene is loaded back before the command succeeds.

use std::path::PathBuf;

use clap::Args;
use renderer::import::{convert, mitsuba, Format};

use super::scene_file::{print_warnings, scene_error, ImportArgs};
use super::CliError;

/// Arguments of `candela convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// The scene: .json, .xml (Mitsuba 3), .gltf / .glb, .pbrt or .scn.
    pub input: PathBuf,
    /// The output: .json (candela's format) or .xml (Mitsuba 3, from a candela JSON scene).
    pub output: PathBuf,
    #[command(flatten)]
    pub import: ImportArgs,
}

/// Runs `candela convert`.
pub fn run(a: ConvertArgs) -> Result<(), CliError> {
    let opts = a.import.options()?;
    // Step 1: what is asked, before any work.
    let out_format = Format::from_extension(&a.output);
    let in_format = renderer::import::detect_file(&a.input)
        .map_err(|e| CliError::input(scene_error(&a.input, &e)))?;
    match (out_format, in_format) {
        (Some(Format::Json), _) | (Some(Format::Mitsuba), Format::Json) => {}
        (Some(Format::Mitsuba), other) => {
            return Err(CliError::input(format!(
                "{}: Mitsuba XML is written from candela JSON scenes; convert the {} scene to .json first",
                a.input.display(),
                other.name()
            )))
        }
        _ => {
            return Err(CliError::input(format!(
                "{}: the output must end in .json (candela) or .xml (Mitsuba 3)",
                a.output.display()
            )))
        }
    }
    let imported = renderer::import::import_file(&a.input, &opts)
        .map_err(|e| CliError::input(scene_error(&a.input, &e)))?;
    print_warnings(&imported.warnings);
    let written = match out_format {
        Some(Format::Json) => {
            // Step 1: the scene must load before anything is written.
            imported
                .load(&opts.limits)
                .map_err(|e| CliError::input(scene_error(&a.input, &e)))?;
            let written = convert::write_json(&imported, &a.output)
                .map_err(|e| CliError::failure(e.to_string()))?;
            // Step 2: and the written JSON must load the same way.
            renderer::scene::load_file(&a.output).map_err(|e| {
                CliError::failure(format!(
                    "{}: the written scene does not load: {e}",
                    a.output.display()
                ))
            })?;
            written
        }
        _ => mitsuba::export::write_xml(&imported, &a.output)
            .map_err(|e| CliError::input(scene_error(&a.input, &e)))?,
    };
    for path in written {
        println!("wrote {}", path.display());
    }
    Ok(())
}
