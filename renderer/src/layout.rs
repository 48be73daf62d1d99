//! The GPU-side scene layout: `#[repr(C)]` bytemuck structs, mirrored field for field in
//! `shaders/common/types.glsl` (scalar block layout). This file and that one are the single
//! source of truth; `tests` below and the GPU layout test check sizes and offsets.
//!
//! The constants (bindings, primitive and material flags, light kinds, push-constant flags) are
//! declared here only: [`glsl_constants`] writes them as the `#define`s of the virtual shader
//! include `common/constants.glsl`, which types.glsl and bsdf.glsl include.
//!
//! Positions are camera-relative f32 (the host composes transforms in f64 and subtracts the
//! camera position before rounding), so a scene far from the origin renders like one at it.

use bytemuck::{Pod, Zeroable};

/// Descriptor binding indices (set 0), `B_*` in the shaders. 0–15 and 50–59 belong to the
/// session (scene, film, acceleration structure, light sampler); integrators' own stages take
/// their own ranges: vct 16–29 (renderer/src/integrators/vct/gpu.rs), deferred 30–39
/// (renderer/src/integrators/deferred/stages.rs), bdpt 40–49 (below).
pub mod binding {
    pub const GLOBALS: u32 = 0;
    pub const BVH_NODES: u32 = 1;
    pub const PRIMS: u32 = 2;
    pub const TRI_SHADING: u32 = 3;
    pub const MATERIALS: u32 = 4;
    pub const TEXTURES: u32 = 5;
    pub const TEXELS: u32 = 6;
    pub const LIGHTS: u32 = 7;
    pub const LIGHT_ALIAS: u32 = 8;
    pub const ENV_DIST: u32 = 9;
    pub const ACCUM: u32 = 10;
    pub const STATS: u32 = 11;
    /// bdpt: light-tracing splats (t = 1), per pixel; see shaders/bdpt/splat.glsl.
    pub const SPLAT: u32 = 12;
    /// Uniform grid (`accel: "grid"` only; see renderer/src/accel/grid.rs): its `GpuGridInfo`,
    /// the cells' offsets into the reference list (cells + 1 entries) and the list itself.
    pub const GRID: u32 = 13;
    pub const GRID_CELLS: u32 = 14;
    pub const GRID_PRIMS: u32 = 15;
    /// bdpt's split design (renderer/src/integrators/bdpt.rs): the light subpaths' vertices of
    /// the band being rendered, and each path's vertex count.
    pub const BDPT_LIGHT_VERTICES: u32 = 40;
    pub const BDPT_LIGHT_COUNTS: u32 = 41;
    /// bdpt with float splats: the odd-indexed samples' splats of the pass being rendered,
    /// merged into SPLAT and SPLAT_ODD at its end (shaders/bdpt/splat_merge.comp).
    pub const BDPT_SPLAT_NEW: u32 = 42;
    /// The session's second range (50–59). Each BVH node's parent (u32, NONE for the root),
    /// read only by the traversal's stackless fallback for trees deeper than its short stack
    /// (`accel::STACK_DEPTH`); one placeholder word otherwise. See shaders/common/traverse.glsl.
    pub const BVH_PARENTS: u32 = 50;
    /// The odd-indexed samples' share of ACCUM, per pixel (Σr, Σg, Σb, samples kept): the second
    /// half of the error estimate (shaders/common/film.glsl, renderer/src/metrics/estimate.rs).
    pub const ACCUM_ODD: u32 = 51;
    /// The light BVH (`render.light_sampler: "bvh"` only; renderer/src/compile/light_bvh.rs).
    pub const LIGHT_BVH: u32 = 52;
    /// The compressed 8-wide BVH (`accel: "cwbvh"` only; renderer/src/accel/cwbvh.rs): its
    /// nodes (`GpuCwbvhNode`), and per leaf slot the index of the `GpuPrim` it holds.
    pub const CWBVH_NODES: u32 = 53;
    pub const CWBVH_PRIMS: u32 = 54;
    /// bdpt: the odd-indexed samples' share of SPLAT (same format), so that both halves of the
    /// error estimate carry their light-tracing splats (renderer/src/render/halves.rs).
    pub const SPLAT_ODD: u32 = 55;
    /// The error estimate on the GPU (shaders/estimate/estimate.comp,
    /// renderer/src/render/estimate_gpu.rs): each workgroup's partial sum and count of the
    /// per-pixel terms, and the reduced total (`GpuEstimateResult`).
    pub const ESTIMATE_PARTIALS: u32 = 56;
    pub const ESTIMATE_RESULT: u32 = 57;
    /// Instancing (scenes with `instance` objects only; renderer/src/compile/instances.rs):
    /// the instances (`GpuInstance`) and the top-level BVH over their world boxes, whose leaves
    /// index INSTANCES (the meshes' own BVHs live in BVH_NODES after the scene's).
    pub const INSTANCES: u32 = 58;
    pub const TLAS_NODES: u32 = 59;
}

/// Entries of the BVH traversal's short stack (`BVH_STACK` in the shaders): trees up to this
/// many levels are walked with the stack alone (see renderer/src/accel/flatten.rs).
pub const BVH_STACK_DEPTH: u32 = 64;

/// Entries of the CWBVH traversal's stack of node groups (`CWBVH_STACK` in the shaders): the
/// host keeps every CWBVH within this many levels (renderer/src/accel/cwbvh.rs), so a walk,
/// which pushes at most one group per level, never overflows it.
pub const CWBVH_STACK_DEPTH: u32 = 32;

/// Bits of an instance index in the two-level walk's stack entries (`TL_LEAF` in
/// shaders/common/traverse.glsl: the leaf's instance count above them, below the tag bit).
pub const TL_COUNT_SHIFT: u32 = 28;

/// Instances a scene may have (see [`TL_COUNT_SHIFT`]).
pub const MAX_INSTANCES: u32 = 1 << TL_COUNT_SHIFT;

/// Marks "none" in u32 index fields.
pub const NONE: u32 = u32::MAX;

/// `GpuPrim::a[3]` bits: material index in the low 24 bits, flags above.
pub const PRIM_MATERIAL_MASK: u32 = 0x00ff_ffff;
pub const PRIM_SPHERE: u32 = 1 << 31;
pub const PRIM_FLIP_NORMALS: u32 = 1 << 30;
pub const PRIM_ALPHA: u32 = 1 << 29;

/// One primitive in BVH order (48 bytes).
/// Triangle: a = v0 | flags+material, b = v1 | light index, c = v2 | shading index (or NONE).
/// Sphere:   a = centre | flags+material, b = (radius, 0, 0) | light index, c unused.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuPrim {
    pub a: [f32; 4],
    pub b: [f32; 4],
    pub c: [f32; 4],
}

/// Per-triangle shading data, indexed by `GpuPrim::c[3]`: vertex normals (n.w = u of that vertex)
/// and the three v coordinates (uv_v.w: 1 when normals are present, 0 otherwise).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuTriShading {
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
    pub uv_v: [f32; 4],
}

/// A BVH2 node holding both children's boxes (Aila & Laine 2009 layout, 64 bytes): one node
/// fetch tests two boxes. A child with count 0 is an inner node index; count > 0 is a leaf of
/// `count` primitives starting at `GpuPrim` index `child`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuBvhNode {
    pub l_min: [f32; 3],
    pub left: u32,
    pub l_max: [f32; 3],
    pub right: u32,
    pub r_min: [f32; 3],
    pub l_count: u32,
    pub r_max: [f32; 3],
    pub r_count: u32,
}

/// A compressed 8-wide BVH node (Ylitie, Karras & Laine 2017; obvhs's `CwBvhNode` layout, 80
/// bytes). Child c's box is `p + e · q` per axis, with `e = 2^(e_imask[axis] − 127)` and `q` its
/// quantised bounds `q[2·axis][c]` (low) and `q[2·axis + 1][c]` (high). `e_imask[3]`: bit c set
/// when child c is an inner node. `meta[c]`: 0 for an empty slot; an inner child `0b001_xxxxx`
/// with `xxxxx` = 24 + its slot; a leaf the unary count of its primitives in the high 3 bits and
/// their offset from `prim_base` (into the CWBVH_PRIMS indices) in the low 5. Inner children are
/// stored contiguously from `child_base`, in slot order.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuCwbvhNode {
    pub p: [f32; 3],
    pub e_imask: [u8; 4],
    pub child_base: u32,
    pub prim_base: u32,
    pub meta: [u8; 8],
    pub q: [[u8; 8]; 6],
}

/// The uniform grid's frame (64 bytes, binding GRID): cell (x, y, z) spans
/// `lo + (x, y, z) · cell` to `lo + (x + 1, y + 1, z + 1) · cell`, cells numbered x fastest.
/// `prim_refs` is the length of the reference list (binding GRID_PRIMS).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuGridInfo {
    pub lo: [f32; 3],
    pub nx: u32,
    pub hi: [f32; 3],
    pub ny: u32,
    pub cell: [f32; 3],
    pub nz: u32,
    pub inv_cell: [f32; 3],
    pub prim_refs: u32,
}

/// An instance of a prototype mesh (112 bytes, binding INSTANCES): rows of two 3×4 affine
/// matrices, composed in f64 on the host and rounded once: camera-relative world → object
/// (rays are moved into the prototype's frame with it; the transpose of its 3×3 part moves
/// normals back) and object → camera-relative world (hit vertices). `root`: the prototype's
/// BVH root in BVH_NODES (its leaves index PRIMS directly). `material`: the instance's material
/// replacing the prototype's, or NONE. `flags`: INST_MIRROR (negative determinant: the winding
/// is swapped back, as a flattened copy's), INST_ALPHA (the replacing material is alpha-masked).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuInstance {
    pub world_to_object: [[f32; 4]; 3],
    pub object_to_world: [[f32; 4]; 3],
    pub root: u32,
    pub material: u32,
    pub flags: u32,
    pub pad: u32,
}

/// `GpuGlobals::scene_flags` bit: a material the primitives use is a conductor or a principled
/// surface, whose anisotropy reads the tangent's direction (shaders/common/surface.glsl).
pub const SCENE_TANGENTS: u32 = 1;

/// `GpuInstance::flags` bits.
pub const INST_MIRROR: u32 = 1;
pub const INST_ALPHA: u32 = 2;

/// Material type ids (MAT_*, MATF_* in the shaders).
pub mod mat {
    pub const DIFFUSE: u32 = 0;
    pub const CONDUCTOR: u32 = 1;
    pub const DIELECTRIC: u32 = 2;
    pub const PRINCIPLED: u32 = 3;
    pub const PHONG: u32 = 4;
    pub const F_TWO_SIDED: u32 = 1;
    pub const F_HAS_ETA_K: u32 = 2;
}

/// A material (176 bytes). `header` = (type, flags, alpha mask texture or NONE, 0).
/// `colors[i]` = rgb and, in w, the texture index as u32 bits (NONE: constant). The slot
/// meanings per type are those of `SurfaceParams` in shaders/common/bsdf/bsdf.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    pub header: [u32; 4],
    pub emission: [f32; 4],
    pub colors: [[f32; 4]; 3],
    pub scalars: [f32; 12],
    pub scalar_tex: [u32; 12],
}

/// A texture's place in the texel buffer (32 bytes). Texels are linear RGBA f32, row 0 at top.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuTexture {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub flags: u32,
    pub scale: [f32; 2],
    pub pad: [f32; 2],
}

/// Light kinds (LIGHT_* in the shaders).
pub mod light {
    pub const TRIANGLE: u32 = 0;
    pub const SPHERE: u32 = 1;
    pub const POINT: u32 = 2;
    pub const SPOT: u32 = 3;
    pub const DIRECTIONAL: u32 = 4;
    pub const ENV_CONSTANT: u32 = 5;
    pub const ENV_MAP: u32 = 6;
}

/// A light (80 bytes). Triangle: p0..p2 vertices, p0.w area. Sphere: p0 centre, p0.w radius,
/// p1.x 1 when its normals point inwards. Both: p2.w the share of the surface its alpha mask
/// cuts away (0 without a mask; used by `deferred` only, renderer/src/compile/mask_coverage.rs).
/// Point: p0 position. Spot: p0 position, p1 direction, p2 = (cos cutoff, cos beam, cutoff rad,
/// beam rad). Directional: p0 = travel direction. Environments: radiance (constant) or scale.
/// `prim` is the emitting primitive (area lights) and `pick_pdf` the probability of choosing
/// this light (proportional to power); `bvh_trail` its path in the light BVH (bit k: the second
/// child at depth k; light sampler "bvh" only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    pub kind: u32,
    pub prim: u32,
    pub pick_pdf: f32,
    pub bvh_trail: u32,
    pub p0: [f32; 4],
    pub p1: [f32; 4],
    pub p2: [f32; 4],
    pub radiance: [f32; 4],
}

/// A node of the light BVH (renderer/src/compile/light_bvh.rs): bounds, power, emission cone;
/// an inner node's first child follows it and `index` is its second, a leaf's `index` is its
/// light. After the tree, one entry per infinite light (`index`: the light).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Default)]
pub struct GpuLightNode {
    /// (bounds min, power φ)
    pub min_phi: [f32; 4],
    /// (bounds max, cos θ_o of the normal cone)
    pub max_cos_o: [f32; 4],
    /// (normal cone axis, cos θ_e of the emission spread)
    pub w_cos_e: [f32; 4],
    pub index: u32,
    /// Bit 0: leaf.
    pub flags: u32,
    pub pad: [u32; 2],
}

/// One entry of the light-selection alias table (Walker/Vose): keep `index` with probability
/// `prob`, else take `alias`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuAlias {
    pub prob: f32,
    pub alias: u32,
}

/// Scene-wide values and the camera (binding GLOBALS).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuGlobals {
    /// Camera basis, camera-relative world space: w = unused.
    pub cam_forward: [f32; 4],
    pub cam_right: [f32; 4],
    pub cam_up: [f32; 4],
    /// (tan(fov_y/2), aspect = width/height, aperture radius, focus distance)
    pub lens: [f32; 4],
    /// (width, height, filter kind 0 box / 1 gaussian, number of lights)
    pub film: [u32; 4],
    /// (gaussian stddev σ, radius 4σ, the width r/31 of a step of its table, 0):
    /// shaders/common/filter.glsl, with `filter_c` and `filter_alias`
    pub filter: [f32; 4],
    /// Scene bounding sphere, camera-relative (centre, radius).
    pub scene_sphere: [f32; 4],
    /// (environment light index or NONE, env map texture or NONE, env map width, env map height)
    pub env: [u32; 4],
    /// (env scale, cos rotate_y, sin rotate_y, the light BVH's probability of picking an
    /// infinite light)
    pub env_params: [f32; 4],
    /// (number of primitives, number of BVH nodes, light BVH tree nodes, infinite lights after
    /// them; the last two 0 with the power light sampler)
    pub counts: [u32; 4],
    /// (number of instances, top-level BVH nodes, 0, 0): zero without instances.
    pub instances: [u32; 4],
    /// (SCENE_* flags, 0, 0, 0)
    pub scene_flags: [u32; 4],
    /// The Gaussian filter's running sums C_k of its steps, and an alias table of the steps
    /// (shaders/common/filter.glsl); zero for the box filter.
    pub filter_c: [f32; 32],
    pub filter_alias: [u32; 32],
}

/// Per-dispatch constants (push constants, 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Default)]
pub struct GpuPush {
    pub seed_lo: u32,
    pub seed_hi: u32,
    /// Index of the first sample of this pass (the RNG key, so passes can be split freely).
    pub sample_base: u32,
    pub spp: u32,
    /// Mitsuba's max_depth (−1: unbounded).
    pub max_depth: i32,
    pub rr_depth: i32,
    pub flags: u32,
    /// How the pass is cut into dispatches (render/dispatch.rs): bits 0–3 log2 of the threads
    /// per pixel, bits 8–31 the first row of this dispatch's band.
    pub dispatch: u32,
}

/// Most threads per pixel a pass may use (`GpuPush::dispatch` bits 0–3 hold their log2; see
/// renderer/src/render/dispatch.rs and shaders/common/dispatch.glsl).
pub const MAX_LANES: u32 = 8;

/// `GpuPush::flags` bit: poison every 7th sample (sample index % 7 == 3) with NaN, so tests can
/// check that such samples are dropped and counted (shaders/common/film.glsl).
pub const PUSH_FLAG_INJECT_NAN: u32 = 1;
/// `GpuPush::flags` bits of bdpt (read in shaders/bdpt/bdpt.comp): uniform instead of
/// power-heuristic MIS weights; render only the strategy (s, t) in bits 8–15 (s) and 16–23 (t);
/// with it, leave that strategy unweighted.
pub const PUSH_FLAG_BDPT_NO_MIS: u32 = 1 << 1;
pub const PUSH_FLAG_BDPT_STRATEGY: u32 = 1 << 2;
pub const PUSH_FLAG_BDPT_UNWEIGHTED: u32 = 1 << 3;
pub const PUSH_FLAG_BDPT_S_SHIFT: u32 = 8;
pub const PUSH_FLAG_BDPT_T_SHIFT: u32 = 16;
/// bdpt, split design: log2 of the pixels sharing one light subpath (bits 24–27).
pub const PUSH_FLAG_BDPT_SHARE_SHIFT: u32 = 24;

/// Counters the kernels bump (binding STATS).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Default)]
pub struct GpuStats {
    pub dropped_samples: u32,
    /// Rays traced, as a 64-bit count in two words (the kernel carries into `rays_hi`).
    pub rays_lo: u32,
    pub rays_hi: u32,
    pub pad: u32,
}

/// Push constants of the GPU error estimate (shaders/estimate/estimate.comp mirrors them):
/// the film size, the samples per pixel of the accumulation, the stage (0: per-pixel terms
/// summed per workgroup, 1: the workgroups' partial sums summed) and the number of partials.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Default)]
pub struct GpuEstimatePush {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub stage: u32,
    pub partials: u32,
    pub pad: [u32; 3],
}

/// What the GPU error estimate writes (binding ESTIMATE_RESULT): the sum of the per-pixel,
/// per-channel terms and how many terms were summed (the estimate is `sum / count`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Default)]
pub struct GpuEstimateResult {
    pub sum: f32,
    pub count: u32,
    pub pad: [u32; 2],
}

/// The path under which [`glsl_constants`] is served to `#include`.
pub const GLSL_CONSTANTS_PATH: &str = "common/constants.glsl";

/// The constants above as GLSL `#define`s (unsigned, except binding numbers, which layout
/// qualifiers take as plain integers).
pub fn glsl_constants() -> String {
    let bindings = [
        ("B_GLOBALS", binding::GLOBALS),
        ("B_BVH_NODES", binding::BVH_NODES),
        ("B_PRIMS", binding::PRIMS),
        ("B_TRI_SHADING", binding::TRI_SHADING),
        ("B_MATERIALS", binding::MATERIALS),
        ("B_TEXTURES", binding::TEXTURES),
        ("B_TEXELS", binding::TEXELS),
        ("B_LIGHTS", binding::LIGHTS),
        ("B_LIGHT_ALIAS", binding::LIGHT_ALIAS),
        ("B_ENV_DIST", binding::ENV_DIST),
        ("B_ACCUM", binding::ACCUM),
        ("B_STATS", binding::STATS),
        ("B_SPLAT", binding::SPLAT),
        ("B_GRID", binding::GRID),
        ("B_GRID_CELLS", binding::GRID_CELLS),
        ("B_GRID_PRIMS", binding::GRID_PRIMS),
        ("B_BDPT_LIGHT_VERTICES", binding::BDPT_LIGHT_VERTICES),
        ("B_BDPT_LIGHT_COUNTS", binding::BDPT_LIGHT_COUNTS),
        ("B_BDPT_SPLAT_NEW", binding::BDPT_SPLAT_NEW),
        ("B_BVH_PARENTS", binding::BVH_PARENTS),
        // Entries of the traversal's short stack (plain integer: an array size).
        ("BVH_STACK", BVH_STACK_DEPTH),
        ("B_ACCUM_ODD", binding::ACCUM_ODD),
        ("B_LIGHT_BVH", binding::LIGHT_BVH),
        ("B_CWBVH_NODES", binding::CWBVH_NODES),
        ("B_CWBVH_PRIMS", binding::CWBVH_PRIMS),
        ("CWBVH_STACK", CWBVH_STACK_DEPTH),
        ("TL_COUNT_SHIFT", TL_COUNT_SHIFT),
        ("B_SPLAT_ODD", binding::SPLAT_ODD),
        ("B_ESTIMATE_PARTIALS", binding::ESTIMATE_PARTIALS),
        ("B_ESTIMATE_RESULT", binding::ESTIMATE_RESULT),
        ("B_INSTANCES", binding::INSTANCES),
        ("B_TLAS_NODES", binding::TLAS_NODES),
    ];
    let flags = [
        ("NONE", NONE),
        ("PRIM_MATERIAL_MASK", PRIM_MATERIAL_MASK),
        ("PRIM_SPHERE", PRIM_SPHERE),
        ("PRIM_FLIP_NORMALS", PRIM_FLIP_NORMALS),
        ("PRIM_ALPHA", PRIM_ALPHA),
        ("SCENE_TANGENTS", SCENE_TANGENTS),
        ("INST_MIRROR", INST_MIRROR),
        ("INST_ALPHA", INST_ALPHA),
        ("LIGHT_TRIANGLE", light::TRIANGLE),
        ("LIGHT_SPHERE", light::SPHERE),
        ("LIGHT_POINT", light::POINT),
        ("LIGHT_SPOT", light::SPOT),
        ("LIGHT_DIRECTIONAL", light::DIRECTIONAL),
        ("LIGHT_ENV_CONSTANT", light::ENV_CONSTANT),
        ("LIGHT_ENV_MAP", light::ENV_MAP),
        ("MAT_DIFFUSE", mat::DIFFUSE),
        ("MAT_CONDUCTOR", mat::CONDUCTOR),
        ("MAT_DIELECTRIC", mat::DIELECTRIC),
        ("MAT_PRINCIPLED", mat::PRINCIPLED),
        ("MAT_PHONG", mat::PHONG),
        ("MATF_TWO_SIDED", mat::F_TWO_SIDED),
        ("MATF_HAS_ETA_K", mat::F_HAS_ETA_K),
        ("PUSH_FLAG_INJECT_NAN", PUSH_FLAG_INJECT_NAN),
        ("PUSH_FLAG_BDPT_NO_MIS", PUSH_FLAG_BDPT_NO_MIS),
        ("PUSH_FLAG_BDPT_STRATEGY", PUSH_FLAG_BDPT_STRATEGY),
        ("PUSH_FLAG_BDPT_UNWEIGHTED", PUSH_FLAG_BDPT_UNWEIGHTED),
        ("PUSH_FLAG_BDPT_S_SHIFT", PUSH_FLAG_BDPT_S_SHIFT),
        ("PUSH_FLAG_BDPT_T_SHIFT", PUSH_FLAG_BDPT_T_SHIFT),
        ("PUSH_FLAG_BDPT_SHARE_SHIFT", PUSH_FLAG_BDPT_SHARE_SHIFT),
    ];
    let mut s = String::from(
        "// Generated from renderer/src/layout.rs (glsl_constants): edit the Rust side.\n\
         #ifndef COMMON_CONSTANTS_GLSL\n#define COMMON_CONSTANTS_GLSL\n",
    );
    for (name, v) in bindings {
        s.push_str(&format!("#define {name} {v}\n"));
    }
    for (name, v) in flags {
        s.push_str(&format!("#define {name} 0x{v:08x}u\n"));
    }
    s.push_str("#endif\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::size_of;

    #[test]
    fn sizes_match_the_glsl_mirror() {
        assert_eq!(size_of::<GpuPrim>(), 48);
        assert_eq!(size_of::<GpuTriShading>(), 64);
        assert_eq!(size_of::<GpuBvhNode>(), 64);
        assert_eq!(size_of::<GpuCwbvhNode>(), 80);
        assert_eq!(size_of::<GpuMaterial>(), 176);
        assert_eq!(size_of::<GpuTexture>(), 32);
        assert_eq!(size_of::<GpuLight>(), 80);
        assert_eq!(size_of::<GpuAlias>(), 8);
        assert_eq!(size_of::<GpuLightNode>(), 64);
        assert_eq!(size_of::<GpuGlobals>(), 192 + 256);
        assert_eq!(size_of::<GpuInstance>(), 112);
        assert_eq!(size_of::<GpuPush>(), 32);
        assert_eq!(size_of::<GpuStats>(), 16);
    }
}
