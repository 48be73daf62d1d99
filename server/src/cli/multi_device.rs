//! `candela render --devices all|0,1`: one render split across several Vulkan devices by sample
//! index (renderer/src/render/shards.rs). One GpuContext and one session per listed device,
//! each built and driven on its own thread; `--spp` is the total over the devices, `--time` the
//! time of each. The same index may be listed twice (two contexts on one device), which is how
//! the tests exercise the split on lavapipe.

use std::sync::Arc;

use renderer::gpu::{list_devices, GpuContext, GpuError, GpuOptions};
use renderer::integrators::IntegratorOptions;
use renderer::prepare::PreparedScene;
use renderer::render::{render_split, Budget, RenderSession, SplitRender};

use super::CliError;

/// Device indices (positions in `candela devices`) from `--devices`: `all` (every device of the
/// best kind present: discrete GPUs, else integrated, else virtual, else the rest, so a GPU
/// host does not also render on lavapipe) or a comma-separated list such as `0,1` (`0` alone:
/// one device; an index may repeat).
pub fn parse_devices(spec: &str) -> Result<Vec<usize>, CliError> {
    let bad = |why: String| CliError::input(format!("--devices: {why}"));
    let spec = spec.trim();
    let available = list_devices().map_err(|e| CliError::failure(e.to_string()))?;
    if available.is_empty() {
        return Err(CliError::failure("no Vulkan device found"));
    }
    if spec.eq_ignore_ascii_case("all") {
        let rank = |kind: &str| match kind {
            "discrete" => 0,
            "integrated" => 1,
            "virtual" => 2,
            _ => 3,
        };
        let best = available.iter().map(|d| rank(&d.kind)).min().unwrap_or(3);
        return Ok((0..available.len())
            .filter(|&i| rank(&available[i].kind) == best)
            .collect());
    }
    let mut out = Vec::new();
    for part in spec.split(',') {
        let i: usize = part.trim().parse().map_err(|_| {
            bad(format!(
                "expected \"all\" or device indices such as 0,1, got \"{spec}\""
            ))
        })?;
        if i >= available.len() {
            let names: Vec<String> = available
                .iter()
                .enumerate()
                .map(|(i, d)| format!("{i}: {}", d.name))
                .collect();
            return Err(bad(format!(
                "no device {i} ({} available: {})",
                available.len(),
                names.join(", ")
            )));
        }
        out.push(i);
    }
    if out.len() > 64 {
        return Err(bad(format!("at most 64 devices, got {}", out.len())));
    }
    Ok(out)
}

/// One session per device index, each device opened and its session built on its own thread.
pub fn open_sessions(
    indices: &[usize],
    prepared: &PreparedScene,
    options: &IntegratorOptions,
    seed: u64,
    kernel_cache: Option<std::path::PathBuf>,
) -> Result<Vec<RenderSession>, CliError> {
    std::thread::scope(|scope| {
        let handles: Vec<_> = indices
            .iter()
            .map(|&index| {
                let cache = kernel_cache.clone();
                scope.spawn(move || -> Result<RenderSession, CliError> {
                    let ctx = GpuContext::new(&GpuOptions {
                        device: None,
                        index: Some(index),
                        validation: false,
                        kernel_cache: cache,
                    })
                    .map(Arc::new)
                    .map_err(|e| match e {
                        GpuError::NoDevice(_) => CliError::input(format!("--devices: {e}")),
                        e => CliError::failure(format!("device {index}: {e}")),
                    })?;
                    prepared
                        .session(&ctx, options, seed)
                        .map_err(|e| CliError::failure(format!("device {index}: {e}")))
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(CliError::failure("a device thread panicked")))
            })
            .collect()
    })
}

/// Renders on every session to `budget` (after an untimed, discarded warm-up of `warmup`
/// seconds on each, when asked).
pub fn render_on_devices(
    sessions: &mut [RenderSession],
    budget: Budget,
    warmup: Option<f64>,
    seed: u64,
) -> Result<SplitRender, CliError> {
    if let Some(w) = warmup {
        render_split(sessions, Budget::Time(w))
            .map_err(|e| CliError::failure(format!("warm-up: {e}")))?;
        for s in sessions.iter_mut() {
            s.reset(seed)
                .map_err(|e| CliError::failure(format!("warm-up: {e}")))?;
        }
    }
    render_split(sessions, budget).map_err(|e| CliError::failure(e.to_string()))
}

/// The per-device lines of the report: index, name, spp, passes, time and Msamples/s.
pub fn device_lines(indices: &[usize], split: &SplitRender) -> Vec<String> {
    indices
        .iter()
        .zip(&split.shards)
        .map(|(i, s)| {
            format!(
                "device {i}    {} : {} spp in {} passes, {:.3} s, {:.2} Msamples/s",
                s.device.name, s.spp, s.passes, s.time_s, s.msamples_per_s
            )
        })
        .collect()
}

/// The per-device part of the JSON report.
pub fn device_json(indices: &[usize], split: &SplitRender) -> serde_json::Value {
    serde_json::Value::Array(
        indices
            .iter()
            .zip(&split.shards)
            .map(|(i, s)| {
                let mut d = serde_json::json!({
                    "index": i,
                    "name": s.device.name,
                    "spp": s.spp,
                    "passes": s.passes,
                    "time_s": s.time_s,
                    "gpu_time_s": s.gpu_time_s,
                    "msamples_per_s": s.msamples_per_s,
                    "rays": s.rays,
                });
                if let Some(details) = &s.details {
                    d["details"] = details.clone();
                }
                d
            })
            .collect(),
    )
}
