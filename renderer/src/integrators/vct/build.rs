//! Building the volume on the GPU, in named steps ([`build`]): (1) [`Builder::new`]: the grid
//! and the parameter buffers; (2) [`Builder::voxelize`]: conservative voxelization into a
//! fragment list (a counting pass, one readback of the count, the emitting pass); (3)
//! [`Builder::octree`] or [`Builder::dense`]: the storage — the sparse voxel octree level by
//! level (flag / alloc / mark per depth, all recorded in one submission: no CPU round trip per
//! level; one readback of the level ranges at the end, repeated with a larger pool in the rare
//! case the node-pool estimate was too small) or the dense grid; (4) [`Builder::attributes`]:
//! per-voxel attributes averaged from the fragments; (5) [`Builder::filtered_storage`]: the
//! buffers of the filtered levels. Lighting (injection, filtering, bounces) is in light.rs.

use std::sync::Arc;

use super::gpu::{self, bindings, groups_1d, pipeline, push, Set, VctInfo, VctParams, ACC_WORDS};
use super::options::{Settings, VctStorage};
use super::volume::{fit_grid, StageTimes, Volume};
use crate::compile::CompiledScene;
use crate::error::RenderError;
use crate::gpu::{Binding, Buffer, BufferUsage, GpuContext, ShaderDefines};

/// Rows of the primitive's second-longest axis one voxelization thread covers, and voxels of
/// its shortest (before [`voxel_tiles`] grows them to fit a launch).
const VOX_ROWS: u32 = 4;
const VOX_DEPTH: u32 = 8;
/// Most threads one voxelization launch numbers (LINEAR_GID is a 32-bit index).
const VOX_MAX_THREADS: u64 = 1 << 32;

fn storage_buffer(ctx: &Arc<GpuContext>, name: &str, bytes: u64) -> Result<Buffer, RenderError> {
    Ok(Buffer::new(ctx, name, bytes, BufferUsage::Storage)?)
}

fn sum_ms(t: &[crate::gpu::DispatchTiming]) -> f64 {
    t.iter().map(|d| d.gpu_ms).sum()
}

/// Largest resolution whose octree gets an occupancy mask (shaders/vct/common.glsl,
/// `occupancy_place`; read by the leak guard): r³/8 bytes after the node pool, 128 MiB at 1024³
/// (every resolution vct accepts; the mask pays most there: +40% on an H200, bench/RESULTS.md).
pub const MASK_MAX_RESOLUTION: u32 = 1024;

/// 64-bit words of the occupancy mask at resolution `r` (one per 4×4×4 brick), 0 above
/// [`MASK_MAX_RESOLUTION`].
fn mask_words(r: u32) -> u64 {
    if r > MASK_MAX_RESOLUTION {
        return 0;
    }
    (r as u64 / 4).pow(3)
}

/// Octree node-pool estimate for `frags` fragments: depth k+1 gets a tile of 8 per flagged
/// depth-k node, and a surface touches about a quarter as many cells per level up.
fn node_capacity(frags: u64, levels: u32) -> u64 {
    let mut cap = 1u64;
    for k in 0..levels.saturating_sub(1) {
        let full = 8u64.saturating_pow(k);
        let surface = (frags >> (2 * (levels - 1 - k))).max(1) * 2;
        cap += 8 * full.min(surface).min(frags.max(1));
    }
    cap
}

/// Builds the volume for `scene` (everything but the lighting).
pub fn build(
    ctx: &Arc<GpuContext>,
    scene: &CompiledScene,
    shared: &[Binding<'_>],
    defines: &ShaderDefines,
    s: &Settings,
) -> Result<Volume, RenderError> {
    // Step 1: the grid and the parameters.
    let mut b = Builder::new(ctx, scene, shared, defines, s)?;
    // Step 2: the fragments.
    let (frags, frag_count) = b.voxelize()?;
    // Step 3: the storage.
    let (nodes, info, slots, nodes_used) = match s.storage {
        VctStorage::Octree => b.octree(&frags, frag_count)?,
        VctStorage::Dense => b.dense()?,
    };
    // Step 4: the voxels' attributes (the fragments are freed after).
    let attrs = b.attributes(frags, frag_count, &nodes, slots)?;
    // Step 5: the filtered levels' storage.
    let (mip, leaf) = b.filtered_storage(&info)?;
    let r = s.resolution;
    Ok(Volume {
        world_min: [0, 1, 2].map(|i| b.params.grid[i] as f64 + scene.camera_position[i]),
        params: b.params,
        params_buf: b.params_buf,
        info_buf: b.info_buf,
        dummy: b.dummy,
        nodes,
        attr: attrs.attr,
        emit: attrs.emit,
        rad: attrs.rad,
        mip,
        leaf,
        bounce: None,
        storage: s.storage,
        resolution: r,
        levels: r.trailing_zeros(),
        fragments: frag_count,
        nodes_used,
        slots,
        voxels: attrs.info.voxel_count,
        info: attrs.info,
        build_peak_bytes: attrs.peak_bytes,
        build_times: b.times,
        light_times: StageTimes::default(),
        lights_key: None,
    })
}

/// What the build keeps between its steps.
struct Builder<'a> {
    ctx: &'a Arc<GpuContext>,
    scene: &'a CompiledScene,
    shared: &'a [Binding<'a>],
    defines: &'a ShaderDefines,
    params: VctParams,
    params_buf: Buffer,
    info_buf: Buffer,
    dummy: Buffer,
    times: StageTimes,
}

/// The per-voxel buffers made by [`Builder::attributes`].
struct Attributes {
    attr: Buffer,
    emit: Buffer,
    rad: Buffer,
    info: VctInfo,
    peak_bytes: u64,
}

impl<'a> Builder<'a> {
    /// The grid fitted to the scene and the parameter, info and placeholder buffers.
    fn new(
        ctx: &'a Arc<GpuContext>,
        scene: &'a CompiledScene,
        shared: &'a [Binding<'a>],
        defines: &'a ShaderDefines,
        s: &Settings,
    ) -> Result<Self, RenderError> {
        let r = s.resolution;
        let (min, voxel) = fit_grid(scene, r);
        let tan_half = (0.5 * s.cone_aperture_deg).to_radians().tan();
        let side = voxel * r as f32;
        let ao_voxels = s.ao_distance.unwrap_or(side / 8.0) / voxel;
        let params = VctParams {
            grid: [min[0], min[1], min[2], voxel],
            dims: [
                r,
                r.trailing_zeros(),
                (s.storage == VctStorage::Octree) as u32,
                s.max_level,
            ],
            cone: [tan_half, s.cones as f32, s.step, ao_voxels],
            mode: [
                s.ao as u32,
                (s.shadows == super::VctShadows::Cone) as u32,
                s.inject_samples,
                s.cones_per_sample,
            ],
            caps: [0; 4],
            mip_offset: [0; gpu::LEVELS_MAX],
        };
        let size = |n: usize| n as u64;
        let params_buf = storage_buffer(ctx, "vct params", size(std::mem::size_of::<VctParams>()))?;
        let info_buf = storage_buffer(ctx, "vct info", size(std::mem::size_of::<VctInfo>()))?;
        let dummy = storage_buffer(ctx, "vct placeholder", 16)?;
        ctx.fill_zero(&info_buf)?;
        ctx.fill_zero(&dummy)?;
        let b = Builder {
            ctx,
            scene,
            shared,
            defines,
            params,
            params_buf,
            info_buf,
            dummy,
            times: StageTimes::default(),
        };
        b.upload_params()?;
        Ok(b)
    }

    fn upload_params(&self) -> Result<(), RenderError> {
        Ok(self
            .ctx
            .upload(&self.params_buf, 0, bytemuck::bytes_of(&self.params))?)
    }

    fn read_info(&self) -> Result<VctInfo, RenderError> {
        Ok(self.ctx.download_vec::<VctInfo>(&self.info_buf, 1)?[0])
    }

    /// The pipeline of `kernel` bound to the session's buffers, the parameters and `set`.
    fn pipeline(
        &self,
        kernel: &str,
        set: &Set<'_>,
    ) -> Result<crate::gpu::ComputePipeline, RenderError> {
        let b = bindings(
            self.shared,
            &self.params_buf,
            &self.info_buf,
            &self.dummy,
            set,
        );
        pipeline(self.ctx, kernel, self.defines, &b)
    }

    /// Conservative voxelization, counting then emitting (thread = one tile of a primitive's
    /// voxel box: a slice along its longest axis × VOX_ROWS rows of the second × VOX_DEPTH
    /// voxels of the shortest, grown when a scene has too many tiles for one launch;
    /// [`voxel_tiles`]). Returns the fragment list and its length.
    fn voxelize(&mut self) -> Result<(Buffer, u32), RenderError> {
        let t = voxel_tiles(&self.scene.prims, &self.params)?;
        let (total, groups) = (t.total, t.groups);
        // The kernel's binary search reads exactly the primitives' entries (the buffer may be
        // padded past them).
        let push = push(t.tiles.len() as u32, total, t.rows | t.depth << 16);
        let tiles = Buffer::from_slice(self.ctx, "vct voxelization tiles", &t.tiles)?;
        let mut frag_count = 0u32;
        if total > 0 {
            let set = Set {
                tiles: Some(&tiles),
                ..Default::default()
            };
            let count = self.pipeline("vct/voxelize.comp", &set)?;
            let t = self.ctx.record(1, |rec| {
                rec.dispatch(
                    &count,
                    bytemuck::bytes_of(&push),
                    groups,
                    "vct voxelize count",
                )
            })?;
            self.times.voxelize_ms += sum_ms(&t);
            frag_count = self.read_info()?.frag_count;
        }
        let frags = storage_buffer(self.ctx, "vct fragments", frag_count as u64 * 8)?;
        if frag_count > 0 {
            self.ctx.fill_zero(&self.info_buf)?;
            self.params.caps[0] = frag_count;
            self.upload_params()?;
            let set = Set {
                frags: Some(&frags),
                tiles: Some(&tiles),
                ..Default::default()
            };
            let emit = self.pipeline("vct/voxelize.comp", &set)?;
            let t = self.ctx.record(1, |rec| {
                rec.dispatch(&emit, bytemuck::bytes_of(&push), groups, "vct voxelize")
            })?;
            self.times.voxelize_ms += sum_ms(&t);
        }
        Ok((frags, frag_count))
    }

    /// The octree, level by level on the GPU; returns the node pool, the level ranges, the
    /// slots (8 per leaf-parent node) and the nodes used.
    fn octree(
        &mut self,
        frags: &Buffer,
        frag_count: u32,
    ) -> Result<(Buffer, VctInfo, u32, u32), RenderError> {
        let levels = self.params.dims[1];
        let mask = mask_words(self.params.dims[0]);
        let mut node_cap = node_capacity(frag_count as u64, levels);
        loop {
            if node_cap > u32::MAX as u64 / 2 {
                return Err(RenderError::Invalid(format!(
                    "vct: the octree needs more than {} nodes; lower integrator.resolution",
                    u32::MAX / 2
                )));
            }
            // The node pool, then the occupancy mask (zero until normalize.comp sets its bits).
            let nodes = storage_buffer(self.ctx, "vct nodes", (node_cap + mask) * 8)?;
            self.ctx.fill_zero(&nodes)?;
            self.params.caps[1] = node_cap as u32;
            self.upload_params()?;
            let set = Set {
                frags: Some(frags),
                nodes: Some(&nodes),
                ..Default::default()
            };
            let pipe = self.pipeline("vct/octree.comp", &set)?;
            let t = self.ctx.record(1 + 3 * levels, |rec| {
                let init = push(0, 0, 0);
                rec.dispatch(
                    &pipe,
                    bytemuck::bytes_of(&init),
                    [1, 1, 1],
                    "vct octree init",
                )?;
                for k in 0..levels - 1 {
                    let flag = push(k, frag_count, 1);
                    let groups = groups_1d(frag_count as u64);
                    rec.dispatch(&pipe, bytemuck::bytes_of(&flag), groups, "vct octree flag")?;
                    let n = 8u64.saturating_pow(k).min(node_cap);
                    let alloc = push(k, 0, 2);
                    rec.dispatch(
                        &pipe,
                        bytemuck::bytes_of(&alloc),
                        groups_1d(n),
                        "vct octree alloc",
                    )?;
                    let mark = push(k, 0, 3);
                    rec.dispatch(
                        &pipe,
                        bytemuck::bytes_of(&mark),
                        [1, 1, 1],
                        "vct octree mark",
                    )?;
                }
                Ok(())
            })?;
            self.times.build_ms += sum_ms(&t);
            let info = self.read_info()?;
            if info.overflow != 0 {
                node_cap *= 4;
                continue;
            }
            // normalize.comp fills the mask and the cones read it from here on.
            self.params.caps[3] = if mask > 0 { node_cap as u32 } else { 0 };
            let k = (levels - 1) as usize;
            let slots = 8 * (info.level_end[k] - info.level_start[k]);
            let used = info.node_count.min(node_cap as u32);
            return Ok((nodes, info, slots, used));
        }
    }

    /// Dense storage: every voxel of the grid has a slot.
    fn dense(&mut self) -> Result<(Buffer, VctInfo, u32, u32), RenderError> {
        let r = self.params.dims[0];
        let nodes = storage_buffer(self.ctx, "vct nodes (unused)", 16)?;
        Ok((nodes, self.read_info()?, r * r * r, 0))
    }

    /// Per-voxel attributes: fixed-point sums from the fragments, then averages; the fragments
    /// and the sums are freed after.
    fn attributes(
        &mut self,
        frags: Buffer,
        frag_count: u32,
        nodes: &Buffer,
        slots: u32,
    ) -> Result<Attributes, RenderError> {
        let n = slots as u64;
        let acc = storage_buffer(self.ctx, "vct build sums", n * ACC_WORDS * 4)?;
        self.ctx.fill_zero(&acc)?;
        let attr = storage_buffer(self.ctx, "vct attributes", n * 16)?;
        let emit = storage_buffer(self.ctx, "vct emission", n * 8)?;
        let rad = storage_buffer(self.ctx, "vct radiance", n * 16)?;
        self.ctx.fill_zero(&rad)?;
        self.params.caps[2] = slots;
        self.upload_params()?;
        let set = Set {
            frags: Some(&frags),
            nodes: Some(nodes),
            acc: Some(&acc),
            attr: Some(&attr),
            emit: Some(&emit),
            ..Default::default()
        };
        let attributes = self.pipeline("vct/attributes.comp", &set)?;
        let normalize = self.pipeline("vct/normalize.comp", &set)?;
        let t = self.ctx.record(2, |rec| {
            if frag_count > 0 {
                let p = push(0, frag_count, 0);
                let groups = groups_1d(frag_count as u64);
                rec.dispatch(
                    &attributes,
                    bytemuck::bytes_of(&p),
                    groups,
                    "vct attributes",
                )?;
            }
            let p = push(0, slots, 0);
            rec.dispatch(
                &normalize,
                bytemuck::bytes_of(&p),
                groups_1d(n),
                "vct normalize",
            )
        })?;
        self.times.build_ms += sum_ms(&t);
        let info = self.read_info()?;
        let peak_bytes = frags.size + acc.size;
        Ok(Attributes {
            attr,
            emit,
            rad,
            info,
            peak_bytes,
        })
    }

    /// The filtered levels' buffers: the octree's brick pools, or the dense mip chain (whose
    /// level offsets go into the parameters).
    fn filtered_storage(&mut self, info: &VctInfo) -> Result<(Buffer, Buffer), RenderError> {
        let (r, levels) = (self.params.dims[0], self.params.dims[1]);
        if self.params.dims[2] == 1 {
            let k = (levels - 1) as usize;
            let inner = info.level_start[k] as u64;
            let leaves = (info.level_end[k] - info.level_start[k]) as u64;
            return Ok((
                storage_buffer(self.ctx, "vct brick pool", inner * 27 * 6 * 8)?,
                storage_buffer(self.ctx, "vct leaf bricks", leaves * 27 * 4)?,
            ));
        }
        let mut off = 0u32;
        for m in 1..levels {
            self.params.mip_offset[m as usize] = off;
            off += (r >> m).pow(3);
        }
        self.upload_params()?;
        Ok((
            storage_buffer(self.ctx, "vct mip levels", off as u64 * 6 * 8)?,
            storage_buffer(self.ctx, "vct leaf bricks (unused)", 16)?,
        ))
    }
}

/// The voxelization's work list ([`voxel_tiles`]).
struct VoxelTiles {
    /// Per primitive: its first tile and its tile grid (row blocks | depth blocks << 16).
    tiles: Vec<[u32; 2]>,
    /// Tiles in all (threads with work).
    total: u32,
    /// Rows and depth of a tile.
    rows: u32,
    depth: u32,
    /// The launch.
    groups: [u32; 3],
}

/// The voxelization's work list: each primitive's voxel box cut into tiles (one per thread) of
/// one slice along its longest axis, VOX_ROWS rows of the second longest and VOX_DEPTH voxels
/// of the shortest, numbered consecutively primitive after primitive, so that the threads of a
/// warp work on one primitive and a large primitive is spread over many threads (a launch over
/// primitive × the largest box instead made every warp as slow as its largest primitive).
/// Per primitive: its first tile and its tile grid, from box extents padded so that they cover
/// the kernel's (which adds a slack of 1e-3 voxel each side); tiles past the kernel's own
/// extents do nothing. When the tiles would need more threads than one launch can number,
/// tiles grow (rows and depth doubled) until they fit.
fn voxel_tiles(
    prims: &[crate::layout::GpuPrim],
    params: &VctParams,
) -> Result<VoxelTiles, RenderError> {
    let (min, voxel, r) = (
        [params.grid[0], params.grid[1], params.grid[2]],
        params.grid[3],
        params.dims[0],
    );
    // Step 1: each primitive's box extents, longest first, with a voxel to spare each side.
    let extents: Vec<[u32; 3]> = prims
        .iter()
        .map(|p| {
            let sphere = p.a[3].to_bits() & crate::layout::PRIM_SPHERE != 0;
            let (lo, hi) = if sphere {
                (
                    [0, 1, 2].map(|i| p.a[i] - p.b[0]),
                    [0, 1, 2].map(|i| p.a[i] + p.b[0]),
                )
            } else {
                (
                    [0, 1, 2].map(|i| p.a[i].min(p.b[i]).min(p.c[i])),
                    [0, 1, 2].map(|i| p.a[i].max(p.b[i]).max(p.c[i])),
                )
            };
            let mut ext = [0u32; 3];
            for i in 0..3 {
                let cell = |x: f32| ((x - min[i]) / voxel).floor().clamp(0.0, (r - 1) as f32);
                ext[i] = ((cell(hi[i]) - cell(lo[i])) as u32 + 3).min(r);
            }
            ext.sort_unstable_by(|a, b| b.cmp(a));
            ext
        })
        .collect();
    // Step 2: number the tiles, growing them until one launch numbers them all.
    let mut scale = 1u32;
    loop {
        let (rows, depth) = (VOX_ROWS * scale, VOX_DEPTH * scale);
        let mut tiles = Vec::with_capacity(prims.len());
        let mut total = 0u64;
        for ext in &extents {
            let (nr, nd) = (ext[1].div_ceil(rows), ext[2].div_ceil(depth));
            debug_assert!(nr < 1 << 16 && nd < 1 << 16, "tile grid {nr} x {nd}");
            tiles.push([total.min(u32::MAX as u64) as u32, nr | nd << 16]);
            total += ext[0] as u64 * nr as u64 * nd as u64;
        }
        let groups = groups_1d(total);
        let threads = groups[0] as u64 * groups[1] as u64 * 64;
        if total <= u32::MAX as u64 && threads <= VOX_MAX_THREADS {
            return Ok(VoxelTiles {
                tiles,
                total: total as u32,
                rows,
                depth,
                groups,
            });
        }
        if depth >= r {
            return Err(RenderError::Invalid(format!(
                "vct: voxelizing the scene at resolution {r} needs more than {VOX_MAX_THREADS} \
                 threads; lower integrator.resolution"
            )));
        }
        scale *= 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::GpuPrim;
    use bytemuck::Zeroable;

    /// The voxel box voxelize.comp computes for a triangle (Step 2), as voxel counts per axis.
    fn kernel_box(p: &GpuPrim, params: &VctParams) -> [i32; 3] {
        let (r, v) = (params.dims[0] as f32, params.grid[3]);
        [0, 1, 2].map(|i| {
            let g = |x: f32| (x - params.grid[i]) / v;
            let (a, b, c) = (g(p.a[i]), g(p.b[i]), g(p.c[i]));
            let lo = (a.min(b).min(c) - 1e-3).floor().clamp(0.0, r - 1.0);
            let hi = (a.max(b).max(c) + 1e-3).floor().clamp(0.0, r - 1.0);
            (hi - lo) as i32 + 1
        })
    }

    /// Every voxel of the kernel's box of every primitive falls in one of its tiles: the tile
    /// grid (slices × row blocks × depth blocks) covers the box's extents sorted longest first,
    /// for triangles of every size and orientation, on and off the grid's edges; and the tiles
    /// are numbered consecutively.
    #[test]
    fn tiles_cover_every_voxel_the_kernel_tests() {
        let r = 64u32;
        let mut params = VctParams::zeroed();
        params.grid = [-1.5, 0.25, -3.0, 0.0625]; // 64 voxels of 1/16
        params.dims[0] = r;
        let mut seed = 0x9e3779b97f4a7c15u64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut prims = Vec::new();
        for k in 0..2000 {
            // Sizes from a hair to past the grid, anywhere (partly outside too).
            let size = [0.001f32, 0.05, 0.5, 6.0][k % 4];
            let centre = [0, 1, 2].map(|i| params.grid[i] - 0.5 + 5.0 * rnd());
            let vertex = |rnd: &mut dyn FnMut() -> f32| {
                let mut v = [0f32; 4];
                for i in 0..3 {
                    v[i] = centre[i] + size * (rnd() - 0.5);
                }
                v
            };
            prims.push(GpuPrim {
                a: vertex(&mut rnd),
                b: vertex(&mut rnd),
                c: vertex(&mut rnd),
            });
        }
        let t = voxel_tiles(&prims, &params).unwrap();
        assert_eq!((t.rows, t.depth), (VOX_ROWS, VOX_DEPTH));
        covers(&prims, &params, &t);
    }

    /// Asserts that `t` covers every voxel the kernel tests for each of `prims`.
    fn covers(prims: &[GpuPrim], params: &VctParams, t: &VoxelTiles) {
        for (i, p) in prims.iter().enumerate() {
            let mut ext = kernel_box(p, params);
            ext.sort_unstable_by(|a, b| b.cmp(a));
            let (rows, depth) = (t.tiles[i][1] & 0xffff, t.tiles[i][1] >> 16);
            let end = t.tiles.get(i + 1).map_or(t.total, |t| t[0]);
            let slices = (end - t.tiles[i][0]) / (rows * depth);
            assert_eq!(slices * rows * depth, end - t.tiles[i][0], "prim {i}");
            assert!(
                ext[0] <= slices as i32
                    && ext[1] <= (rows * t.rows) as i32
                    && ext[2] <= (depth * t.depth) as i32,
                "prim {i}: box {ext:?}, tiles {slices} x {rows} x {depth}"
            );
        }
    }

    /// A scene with more tiles than one launch numbers (600 triangles spanning a 1024³ grid
    /// on all three axes: 1024 × 256 × 128 tiles each at the start) gets larger tiles, still
    /// covering every voxel, and a launch of at most 2³² threads.
    #[test]
    fn tiles_grow_to_fit_one_launch() {
        let mut params = VctParams::zeroed();
        params.grid = [0.0, 0.0, 0.0, 1.0];
        params.dims[0] = 1024;
        let prims: Vec<GpuPrim> = (0..600)
            .map(|k| {
                let o = k as f32 * 0.001;
                GpuPrim {
                    a: [o, 0.0, 1023.9, 0.0],
                    b: [1023.9, o, 0.0, 0.0],
                    c: [0.0, 1023.9, o, 0.0],
                }
            })
            .collect();
        let t = voxel_tiles(&prims, &params).unwrap();
        assert!(
            t.rows > VOX_ROWS && t.depth > VOX_DEPTH,
            "{} {}",
            t.rows,
            t.depth
        );
        assert!(t.groups[0] as u64 * t.groups[1] as u64 * 64 <= VOX_MAX_THREADS);
        covers(&prims, &params, &t);
    }
}
