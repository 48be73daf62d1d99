//! Which acceleration structure a scene gets (`AccelOptions`), and `build_accel`: look the
//! structure up in the cache, else build it (binary BVH, compressed 8-wide BVH or uniform grid)
//! and store it.

use std::path::Path;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::cwbvh::{self, Cwbvh};
use super::estimate::{self, Costs};
use super::grid::{self, Grid};
use super::{build, cache, parents, Phases, PrimBounds, STACK_DEPTH};
use crate::layout::{GpuBvhNode, GpuPrim};

/// The acceleration structure kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AccelKind {
    /// Binary BVH (obvhs PLOC), shaders/common/traverse.glsl. The default.
    #[default]
    Bvh = 0,
    /// Uniform grid with 3D-DDA traversal, shaders/common/grid.glsl (`#define ACCEL_GRID`).
    Grid = 1,
    /// Compressed 8-wide BVH (Ylitie et al. 2017, built by obvhs), renderer/src/accel/cwbvh.rs
    /// and shaders/common/traverse_cwbvh.glsl (`#define ACCEL_CWBVH`).
    Cwbvh = 2,
}

impl AccelKind {
    /// Every kind's name, as scenes, the CLI and jobs spell it.
    pub const NAMES: [&'static str; 3] = ["bvh", "grid", "cwbvh"];

    /// Parses one of [`AccelKind::NAMES`].
    pub fn from_name(name: &str) -> Option<AccelKind> {
        match name {
            "bvh" => Some(AccelKind::Bvh),
            "grid" => Some(AccelKind::Grid),
            "cwbvh" => Some(AccelKind::Cwbvh),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

/// How to accelerate ray queries.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct AccelOptions {
    pub kind: AccelKind,
    /// Grid only: cells along the scene box's longest axis (the others get cells of about the
    /// same size); None: about λ = 3 cells per primitive. Capped at `grid::MAX_AXIS` per axis.
    pub grid_resolution: Option<u32>,
    /// Grid only, a testing aid: store the primitives in the order the BVH would (costs a BVH
    /// build), so grid and BVH renders number primitives and lights identically and can be
    /// compared pixel for pixel. Off: input order.
    pub grid_bvh_order: bool,
    /// BVH only, a testing aid: keep obvhs's tree as built even where it is deeper than the
    /// traversal's short stack (`STACK_DEPTH`), so the shader's stackless fallback runs. Off:
    /// too-deep subtrees are rebuilt balanced.
    pub bvh_keep_deep: bool,
    /// CWBVH only, a testing aid: store the primitives in the binary BVH's order (costs a binary
    /// build; the leaves reach them through their index buffer), so CWBVH and BVH renders number
    /// primitives and lights identically and can be compared pixel for pixel. Off: the CWBVH's
    /// own leaf order.
    pub cwbvh_bvh_order: bool,
    /// `"auto"` on a scene below [`AUTO_CWBVH_TRIANGLES`] without instances: `build_accel`
    /// builds (or loads) the binary BVH and the CWBVH and keeps the one of lower estimated cost
    /// per ray ([`super::estimate`]); `kind` is then the binary BVH until built.
    pub by_estimate: bool,
}

/// Whether the structure came from the cache.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CacheStatus {
    /// No cache directory was given.
    #[default]
    Off,
    /// Loaded from the cache; nothing was built.
    Hit,
    /// Built (and written to the cache).
    Miss,
}

/// What `build_accel` did, for the render statistics.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AccelInfo {
    pub kind: AccelKind,
    /// Time to obtain the structure: the build, or loading it on a cache hit.
    pub build_time: Duration,
    /// Bytes of the structure's GPU buffers (BVH nodes, CWBVH nodes + primitive indices, or
    /// grid info + cells + references).
    pub bytes: u64,
    /// Grid only: cells along x, y, z.
    pub grid_resolution: Option<[u32; 3]>,
    /// Grid only: primitive references (a primitive counts once per cell it overlaps).
    pub grid_refs: Option<u64>,
    pub cache: CacheStatus,
    /// Both trees' estimated costs per ray when `"auto"` chose by them (`by_estimate`).
    pub estimate: Option<Costs>,
    /// Instances (`instance` objects; 0 without), and bytes of their GPU records and of the
    /// top-level BVH over them (`bytes` already counts the prototypes' own BVHs).
    pub instances: u64,
    pub instance_bytes: u64,
    /// Triangles as rendered through instances (each instance counts its prototype's).
    pub instanced_triangles: u64,
    /// Seconds of each step: cache key, then the cache read on a hit, else the builder's steps
    /// and the cache write.
    pub phases: Phases,
}

/// A built acceleration structure.
#[derive(Debug, Clone)]
pub struct Accel {
    /// `order[i]` = the input index of the primitive stored at slot i.
    pub order: Vec<u32>,
    /// BVH nodes (empty for the grid), in the frame of the bounds given to `build_accel`.
    pub nodes: Vec<GpuBvhNode>,
    /// Each node's parent, for the stackless fallback walk; only when `depth` exceeds
    /// `STACK_DEPTH` (empty otherwise: the short stack never overflows).
    pub parents: Vec<u32>,
    pub depth: usize,
    pub grid: Option<Grid>,
    /// The compressed wide BVH when the kind is "cwbvh" (then `nodes` is empty), in the frame of
    /// `bvh_bounds` like `nodes`.
    pub cwbvh: Option<Cwbvh>,
    pub info: AccelInfo,
}

/// Builds (or loads from `cache_dir`) the structure over `prims` (input order, camera-relative)
/// with camera-relative bounds `bounds` (the grid's input) and `bvh_bounds`, the same boxes in
/// a frame that does not move with the camera (the BVH's input; its nodes come back in that
/// frame). Cache failures never fail the build: an unreadable file is rebuilt, an unwritable
/// directory is reported in the log.
pub fn build_accel(
    opts: &AccelOptions,
    prims: &[GpuPrim],
    bounds: &[PrimBounds],
    bvh_bounds: &[PrimBounds],
    cache_dir: Option<&Path>,
) -> Accel {
    let start = Instant::now();
    if opts.by_estimate {
        return by_estimate(|kind| {
            let one = AccelOptions {
                kind,
                by_estimate: false,
                ..*opts
            };
            build_accel(&one, prims, bounds, bvh_bounds, cache_dir)
        });
    }
    let mut ph = Phases::default();
    // Step 1: the cache.
    let key = cache_dir.map(|_| {
        ph.time("cache_key", || match opts.kind {
            AccelKind::Bvh | AccelKind::Cwbvh => cache::bvh_key(opts, bvh_bounds),
            AccelKind::Grid => cache::key(opts, prims, bounds),
        })
    });
    if let (Some(dir), Some(key)) = (cache_dir, key) {
        if let Some(e) = ph.time("cache_load", || cache::load(dir, opts.kind, key)) {
            if let Some(a) = from_entry(opts, e, prims.len()) {
                let mut a = a;
                a.info.build_time = start.elapsed();
                a.info.cache = CacheStatus::Hit;
                a.info.phases = ph;
                return a;
            }
        }
    }
    // Step 2: build.
    let mut a = match opts.kind {
        AccelKind::Bvh => {
            let bvh = build(bvh_bounds, opts.bvh_keep_deep);
            ph.0.extend(bvh.phases.0);
            Accel {
                info: AccelInfo {
                    kind: AccelKind::Bvh,
                    bytes: (bvh.nodes.len() * std::mem::size_of::<GpuBvhNode>()) as u64,
                    ..Default::default()
                },
                order: bvh.order,
                parents: if bvh.depth > STACK_DEPTH {
                    parents(&bvh.nodes)
                } else {
                    Vec::new()
                },
                nodes: bvh.nodes,
                depth: bvh.depth,
                grid: None,
                cwbvh: None,
            }
        }
        AccelKind::Cwbvh => {
            let built = cwbvh::build(bvh_bounds);
            ph.0.extend(built.phases.0.iter().copied());
            let (order, prims) = if opts.cwbvh_bvh_order {
                let order = build(bvh_bounds, false).order;
                let mut slot = vec![0u32; order.len()];
                for (s, &i) in order.iter().enumerate() {
                    slot[i as usize] = s as u32;
                }
                let prims = built.order.iter().map(|&i| slot[i as usize]).collect();
                (order, prims)
            } else {
                (built.order, Vec::new()) // the identity: no index buffer
            };
            cwbvh_accel(
                order,
                Cwbvh {
                    nodes: built.nodes,
                    prims,
                },
                built.depth,
            )
        }
        AccelKind::Grid => {
            let order: Vec<u32> = if opts.grid_bvh_order {
                // The BVH's own input (scene-frame boxes), so the order is exactly the BVH's.
                build(bvh_bounds, false).order
            } else {
                (0..prims.len() as u32).collect()
            };
            let sorted: Vec<GpuPrim> = order.iter().map(|&i| prims[i as usize]).collect();
            let sorted_bounds: Vec<PrimBounds> =
                order.iter().map(|&i| bounds[i as usize]).collect();
            let g = grid::build(&sorted, &sorted_bounds, opts.grid_resolution);
            grid_accel(order, g)
        }
    };
    // The build time leaves out the cache write (timed among the phases).
    a.info.build_time = start.elapsed();
    // Step 3: store.
    if let (Some(dir), Some(key)) = (cache_dir, key) {
        let store = Instant::now();
        a.info.cache = CacheStatus::Miss;
        let e = cache::Entry {
            order: a.order.clone(),
            nodes: a.nodes.clone(),
            depth: a.depth as u32,
            grid: a
                .grid
                .as_ref()
                .map(|g| (g.info, g.cells.clone(), g.prims.clone())),
            cwbvh: a.cwbvh.as_ref().map(|c| (c.nodes.clone(), c.prims.clone())),
        };
        if let Err(err) = cache::store(dir, opts.kind, key, &e) {
            tracing::warn!("accel cache {}: not written: {err}", dir.display());
        }
        ph.0.push(("cache_store", store.elapsed().as_secs_f64()));
    }
    tracing::debug!("accel {} phases: {:?}", opts.kind.name(), ph.0);
    a.info.phases = ph;
    a
}

/// `"auto"` on a small scene: both BVHs (each from the cache or built by `one`), and the one of
/// lower estimated cost per ray kept. Its phases are the binary BVH's, then `cwbvh` (all of the
/// CWBVH's) and `estimate` (the two trees are built side by side, so their phases overlap in
/// time and sum to more than the build time); it is a cache hit only if both were.
fn by_estimate(one: impl Fn(AccelKind) -> Accel + Sync) -> Accel {
    let start = Instant::now();
    // (Side by side: each build is parallel, but not all through.)
    let (bvh, wide) = rayon::join(|| one(AccelKind::Bvh), || one(AccelKind::Cwbvh));
    let t = Instant::now();
    let costs = Costs::of(
        &estimate::of_bvh(&bvh.nodes),
        &estimate::of_cwbvh(&wide.cwbvh.as_ref().map_or(&[][..], |c| &c.nodes)),
    );
    let estimate_s = t.elapsed().as_secs_f64();
    let cache = match (bvh.info.cache, wide.info.cache) {
        (CacheStatus::Hit, CacheStatus::Hit) => CacheStatus::Hit,
        (CacheStatus::Off, _) => CacheStatus::Off,
        _ => CacheStatus::Miss,
    };
    let mut phases = bvh.info.phases.0.clone();
    phases.push(("cwbvh", wide.info.phases.0.iter().map(|p| p.1).sum()));
    phases.push(("estimate", estimate_s));
    let mut kept = if costs.prefer_cwbvh() { wide } else { bvh };
    kept.info.estimate = Some(costs);
    kept.info.cache = cache;
    kept.info.phases = Phases(phases);
    kept.info.build_time = start.elapsed();
    kept
}

fn grid_accel(order: Vec<u32>, g: Grid) -> Accel {
    Accel {
        info: AccelInfo {
            kind: AccelKind::Grid,
            bytes: g.bytes(),
            grid_resolution: Some(g.resolution()),
            grid_refs: Some(g.prims.len() as u64),
            ..Default::default()
        },
        order,
        nodes: Vec::new(),
        parents: Vec::new(),
        depth: 0,
        grid: Some(g),
        cwbvh: None,
    }
}

fn cwbvh_accel(order: Vec<u32>, c: Cwbvh, depth: usize) -> Accel {
    Accel {
        info: AccelInfo {
            kind: AccelKind::Cwbvh,
            bytes: c.bytes(),
            ..Default::default()
        },
        order,
        nodes: Vec::new(),
        parents: Vec::new(),
        depth,
        grid: None,
        cwbvh: Some(c),
    }
}

/// A cache entry as an `Accel`, after checking it is consistent with the scene (every index in
/// range, the right amount of cells); None when it is not.
fn from_entry(opts: &AccelOptions, mut e: cache::Entry, n: usize) -> Option<Accel> {
    let mut seen = vec![false; n];
    if e.order.len() != n {
        return None;
    }
    for &i in &e.order {
        if i as usize >= n || std::mem::replace(&mut seen[i as usize], true) {
            return None;
        }
    }
    match opts.kind {
        AccelKind::Bvh => {
            if e.grid.is_some() || e.nodes.is_empty() {
                return None;
            }
            // The depth decides whether the fallback's parent pointers are uploaded: recompute
            // it rather than trust the file (this also rejects anything but a tree).
            e.depth = super::flatten::depth_of(&e.nodes)? as u32;
            let m = e.nodes.len() as u32;
            for node in &e.nodes {
                for (c, count) in [(node.left, node.l_count), (node.right, node.r_count)] {
                    let ok = if count == 0 {
                        c < m
                    } else {
                        c as u64 + count as u64 <= n as u64
                    };
                    if !ok && n > 0 {
                        return None;
                    }
                }
            }
            Some(Accel {
                info: AccelInfo {
                    kind: AccelKind::Bvh,
                    bytes: (e.nodes.len() * std::mem::size_of::<GpuBvhNode>()) as u64,
                    ..Default::default()
                },
                order: e.order,
                parents: if e.depth as usize > STACK_DEPTH {
                    parents(&e.nodes)
                } else {
                    Vec::new()
                },
                nodes: e.nodes,
                depth: e.depth as usize,
                grid: None,
                cwbvh: None,
            })
        }
        AccelKind::Cwbvh => {
            let (nodes, prims) = e.cwbvh.take()?;
            let direct = prims.is_empty();
            if e.grid.is_some() || !e.nodes.is_empty() || (!direct && prims.len() != n) {
                return None;
            }
            // The depth bounds the traversal's stack: recompute it (this also rejects anything
            // but a tree), and check every leaf's primitives are in range.
            let depth = cwbvh::depth_of(&nodes)?;
            if depth > cwbvh::STACK_DEPTH || !cwbvh::leaves_in_range(&nodes, n) {
                return None;
            }
            if prims.iter().any(|&p| p as usize >= n) {
                return None;
            }
            Some(cwbvh_accel(e.order, Cwbvh { nodes, prims }, depth))
        }
        AccelKind::Grid => {
            let g = e.take_grid()?;
            let cells = [g.info.nx, g.info.ny, g.info.nz]
                .iter()
                .map(|&r| r as u64)
                .product::<u64>();
            let ok = g.cells.len() as u64 == cells + 1
                && g.cells.first() == Some(&0)
                && g.cells.windows(2).all(|w| w[0] <= w[1])
                && *g.cells.last()? as usize == g.prims.len()
                && g.info.prim_refs as usize == g.prims.len()
                && g.prims.iter().all(|&p| (p as usize) < n);
            ok.then(|| grid_accel(e.order, g))
        }
    }
}

/// What a request may name: a structure of [`AccelKind::NAMES`], or "auto", the default, which
/// [`auto_choice`] turns into one from the scene.
pub const REQUEST_NAMES: [&str; 4] = ["auto", "bvh", "cwbvh", "grid"];

/// A request's structure name: None for "auto", else the structure; Err names the value and
/// every accepted name (the one check for scenes, the CLI and jobs).
pub fn parse_request(name: &str) -> Result<Option<AccelKind>, String> {
    if name == "auto" {
        return Ok(None);
    }
    AccelKind::from_name(name).map(Some).ok_or_else(|| {
        format!(
            "unknown acceleration structure \"{name}\", expected one of {}",
            REQUEST_NAMES.join(", ")
        )
    })
}

/// Scenes of at least this many triangles of their own (no instances) get the CWBVH under
/// "auto". Measured (bench/RESULTS.md, "accel auto"; nee / pt / whitted / deferred, cwbvh
/// against bvh): ×1.12 / 1.04 / 1.67 / 0.95 at 1M triangles, ×1.15 / 1.04 / 1.74 / 1.00 at 2M,
/// nee ×1.15–1.17 at 8M and 30M. Below it, where small scenes split by their geometry (×0.63 to
/// ×1.72), "auto" builds both trees and keeps the one of lower estimated cost
/// ([`AutoChoice::ByEstimate`]).
pub const AUTO_CWBVH_TRIANGLES: u64 = 1_000_000;

/// What "auto" looks at in a scene (`Scene::accel_size`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneSize {
    /// Triangles of the scene's own meshes (instances' not counted).
    pub triangles: u64,
    pub instances: usize,
}

/// How "auto" chooses for a scene of `size`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutoChoice {
    /// This structure: the binary BVH for scenes with instances (it alone traces them through a
    /// second level), the CWBVH for scenes of at least [`AUTO_CWBVH_TRIANGLES`] triangles.
    Kind(AccelKind),
    /// Smaller scenes: both BVHs are built and the one of lower estimated cost per ray kept
    /// ([`super::estimate`]; measured on the project scenes and random ones, bench/RESULTS.md,
    /// "`auto` by the trees' estimates").
    ByEstimate,
}

/// What "auto" does for a scene of `size` ([`AutoChoice`]).
pub fn auto_choice(size: SceneSize) -> AutoChoice {
    if size.instances > 0 {
        AutoChoice::Kind(AccelKind::Bvh)
    } else if size.triangles >= AUTO_CWBVH_TRIANGLES {
        AutoChoice::Kind(AccelKind::Cwbvh)
    } else {
        AutoChoice::ByEstimate
    }
}

/// An acceleration-structure request as written in one place (a scene's `render` block, CLI
/// flags, a job's settings): a kind name and a grid resolution, each optional.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AccelRequest<'a> {
    pub kind: Option<&'a str>,
    pub grid_resolution: Option<u32>,
}

impl AccelOptions {
    /// The options of `request` (a CLI flag, a job's settings) falling back, field by field, on
    /// the scene's `render` block (already validated), then on the defaults ("auto":
    /// [`auto_choice`] for the scene's `size`; automatic grid resolution). Unknown names are an
    /// error naming the value.
    pub fn resolve(
        request: AccelRequest<'_>,
        scene: AccelRequest<'_>,
        size: SceneSize,
    ) -> Result<AccelOptions, String> {
        let name = request.kind.or(scene.kind).unwrap_or("auto");
        let choice = parse_request(name)?.map_or_else(|| auto_choice(size), AutoChoice::Kind);
        let (kind, by_estimate) = match choice {
            AutoChoice::Kind(k) => (k, false),
            AutoChoice::ByEstimate => (AccelKind::Bvh, true),
        };
        let res = request.grid_resolution.or(scene.grid_resolution);
        if let Some(r) = res {
            grid::check_resolution(r.into()).map_err(|e| format!("grid resolution {e}"))?;
        }
        Ok(AccelOptions {
            kind,
            grid_resolution: res,
            grid_bvh_order: false,
            bvh_keep_deep: false,
            cwbvh_bvh_order: false,
            by_estimate,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn request_names_are_auto_and_every_structure() {
        let mut names: Vec<&str> = AccelKind::NAMES.to_vec();
        names.push("auto");
        names.sort();
        let mut request = REQUEST_NAMES.to_vec();
        request.sort();
        assert_eq!(names, request);
        for n in REQUEST_NAMES {
            assert!(parse_request(n).is_ok(), "{n}");
        }
        assert_eq!(parse_request("auto"), Ok(None));
        let e = parse_request("kd-tree").unwrap_err();
        assert!(
            e.contains("\"kd-tree\"") && e.contains("auto, bvh, cwbvh, grid"),
            "{e}"
        );
    }
}
