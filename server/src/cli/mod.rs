//! Command-line interface: argument definitions and dispatch to the subcommands.

mod bench;
mod compare;
mod convert;
mod gc;
mod multi_device;
mod render;
mod scene_file;
mod serve;
mod users;
mod worker;

use clap::{Parser, Subcommand};

/// A failure with its exit code: 2 for bad input, 1 for everything else.
#[derive(Debug)]
pub struct CliError {
    pub code: u8,
    pub message: String,
}

impl CliError {
    pub fn input(message: impl Into<String>) -> Self {
        CliError {
            code: 2,
            message: message.into(),
        }
    }
    pub fn failure(message: impl Into<String>) -> Self {
        CliError {
            code: 1,
            message: message.into(),
        }
    }
}

/// A per-user cache folder: $XDG_CACHE_HOME/candela/NAME, else ~/.cache/candela/NAME; None when
/// neither variable is set.
pub fn user_cache(name: &str) -> Option<std::path::PathBuf> {
    let nonempty = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(std::path::PathBuf::from)
    };
    nonempty("XDG_CACHE_HOME")
        .or_else(|| nonempty("HOME").map(|h| h.join(".cache")))
        .map(|c| c.join("candela").join(name))
}

/// Where compiled kernels and the driver's pipeline cache are kept (the one-shot commands).
#[derive(Debug, Clone, clap::Args)]
pub struct KernelCacheArgs {
    /// Keep compiled kernels and the driver's pipeline cache in DIR (default:
    /// $XDG_CACHE_HOME/candela/kernels or ~/.cache/candela/kernels).
    #[arg(long, value_name = "DIR", conflicts_with = "no_kernel_cache")]
    pub kernel_cache: Option<std::path::PathBuf>,
    /// Compile every kernel afresh; read and write no kernel cache.
    #[arg(long)]
    pub no_kernel_cache: bool,
}

impl KernelCacheArgs {
    /// The folder to use, if any.
    pub fn dir(&self) -> Option<std::path::PathBuf> {
        match (&self.kernel_cache, self.no_kernel_cache) {
            (_, true) => None,
            (Some(d), false) => Some(d.clone()),
            (None, false) => user_cache("kernels"),
        }
    }
}

/// The Vulkan device: the first whose name contains `filter`, else the best one, with the
/// kernel cache in `kernel_cache`. A filter that matches nothing is bad input (exit 2); no
/// device at all is a failure.
pub fn open_device(
    filter: Option<&str>,
    kernel_cache: Option<std::path::PathBuf>,
) -> Result<std::sync::Arc<renderer::gpu::GpuContext>, CliError> {
    use renderer::gpu::{GpuContext, GpuError, GpuOptions};
    GpuContext::new(&GpuOptions {
        device: filter.map(String::from),
        index: None,
        validation: false,
        kernel_cache,
    })
    .map(std::sync::Arc::new)
    .map_err(|e| match e {
        GpuError::NoDevice(_) if filter.is_some() => CliError::input(format!("--device: {e}")),
        e => CliError::failure(e.to_string()),
    })
}

/// The integrator registry as help text: one line per integrator with its summary, whether it
/// is unbiased, and its options.
pub fn integrator_help(intro: &str) -> String {
    use renderer::integrators::{DEFAULT_INTEGRATOR, INTEGRATORS};
    let mut s = format!("{intro} (default: {DEFAULT_INTEGRATOR})\n");
    for i in INTEGRATORS {
        let options: Vec<&str> = i.options.iter().map(|o| o.name).collect();
        s.push_str(&format!(
            "\n  {:<9}{}{}\n           options: {}",
            i.name,
            i.summary,
            if i.unbiased { " Unbiased." } else { "" },
            options.join(", ")
        ));
    }
    s
}

/// `--kernels specialized|generic`.
pub fn parse_kernels(s: &str) -> Result<renderer::compile::KernelMode, String> {
    renderer::compile::KernelMode::from_name(s).ok_or_else(|| {
        format!(
            "unknown kernel mode \"{s}\", expected one of {}",
            renderer::compile::KernelMode::NAMES.join(", ")
        )
    })
}

#[derive(Debug, Parser)]
#[command(
    name = "candela",
    version,
    about = "GPU render server: path tracing, NEE, BDPT, VCT, Whitted, deferred"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene file to an EXR or PNG image.
    Render(render::RenderArgs),
    /// Serve the HTTP API and web viewer, rendering queued jobs on the GPU.
    Serve(serve::ServeArgs),
    /// Render jobs of a shared (PostgreSQL) store, without an HTTP server: a farm's render
    /// process (the serve flags that concern rendering apply; --bind and --token are unused).
    Worker(serve::ServeArgs),
    /// Measure error against a reference over time for several integrators.
    Bench(bench::BenchArgs),
    /// Compare two images (EXR) with MSE, relMSE, PSNR, SSIM and FLIP.
    Compare(compare::CompareArgs),
    /// Convert a scene: any format to candela JSON, or candela JSON to Mitsuba 3 XML.
    Convert(convert::ConvertArgs),
    /// Remove finished jobs and prune event logs of a server's data directory, by hand.
    Gc(gc::GcArgs),
    /// Manage the named tokens (users and their roles) of a server's data directory.
    Users(users::UsersArgs),
    /// List the Vulkan devices candela can use.
    Devices {
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Serve(a) => serve::run(a),
        Command::Worker(a) => worker::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Convert(a) => convert::run(a),
        Command::Gc(a) => gc::run(a),
        Command::Users(a) => users::run(a),
        Command::Devices { json } => {
            let devices =
                renderer::gpu::list_devices().map_err(|e| CliError::failure(e.to_string()))?;
            if json {
                println!("{}", serde_json::to_string(&devices).unwrap_or_default());
            } else {
                for (i, d) in devices.iter().enumerate() {
                    println!(
                        "{i}: {} ({}, Vulkan {}, {})",
                        d.name, d.kind, d.api_version, d.driver
                    );
                }
            }
            Ok(())
        }
    }
}
