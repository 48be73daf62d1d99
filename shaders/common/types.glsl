// GPU scene layout: the GLSL mirror of renderer/src/compile/layout.rs (scalar block layout).
// Keep the two in step; the layout test checks every field.
#ifndef COMMON_TYPES_GLSL
#define COMMON_TYPES_GLSL

#extension GL_EXT_scalar_block_layout : require

// Bindings (B_*), NONE, PRIM_*, LIGHT_*, MAT_*, PUSH_FLAG_*: generated from the Rust side.
#include "common/constants.glsl"

struct GpuPrim { vec4 a; vec4 b; vec4 c; };
struct GpuGridInfo {
    vec3 lo; uint nx;
    vec3 hi; uint ny;
    vec3 cell; uint nz;
    vec3 inv_cell; uint prim_refs;
};
struct GpuTriShading { vec4 n0; vec4 n1; vec4 n2; vec4 uv_v; };
struct GpuBvhNode {
    vec3 l_min; uint left;
    vec3 l_max; uint right;
    vec3 r_min; uint l_count;
    vec3 r_max; uint r_count;
};
// renderer/src/layout.rs GpuCwbvhNode: bytes packed little-endian into uints; q: lo_x, hi_x,
// lo_y, hi_y, lo_z, hi_z, each eight bytes (one per child slot).
struct GpuCwbvhNode {
    vec3 p; uint e_imask;
    uint child_base; uint prim_base;
    uvec2 meta;
    uvec2 q[6];
};
struct GpuMaterial {
    uvec4 header;
    vec4 emission;
    vec4 colors[3];
    float scalars[12];
    uint scalar_tex[12];
};
struct GpuTexture { uint offset; uint width; uint height; uint flags; vec2 scale; vec2 pad; };
struct GpuLight { uint kind; uint prim; float pick_pdf; uint bvh_trail; vec4 p0; vec4 p1; vec4 p2; vec4 radiance; };
// Whether light kind k is a sphere light. Sphere lights are emissive spheres, so a kernel of a
// scene without spheres (no HAS_SPHERES) has none: every test folds to false and the sphere
// lights' sampling and densities are not compiled.
#ifdef HAS_SPHERES
#define light_is_sphere(k) ((k) == LIGHT_SPHERE)
#else
#define light_is_sphere(k) false
#endif
// The environment light's index (NONE: none), and whether light kind k is the environment. A
// kernel of a scene without an environment (no HAS_ENV) knows there is none: every test folds.
#ifdef HAS_ENV
#define ENV_LIGHT g.env.x
#define light_is_env(k) ((k) == LIGHT_ENV_CONSTANT || (k) == LIGHT_ENV_MAP)
#else
#define ENV_LIGHT NONE
#define light_is_env(k) false
#endif
struct GpuAlias { float prob; uint alias; };
struct GpuLightNode { vec4 min_phi; vec4 max_cos_o; vec4 w_cos_e; uint index; uint flags; uint pad0; uint pad1; };
struct GpuGlobals {
    vec4 cam_forward;
    vec4 cam_right;
    vec4 cam_up;
    vec4 lens;
    uvec4 film;
    vec4 filter_params;
    vec4 scene_sphere;
    uvec4 env;
    vec4 env_params;
    uvec4 counts;
    uvec4 instances;
    uvec4 scene_flags;
    float filter_c[32];
    uint filter_alias[32];
};
struct GpuInstance {
    vec4 world_to_object[3];
    vec4 object_to_world[3];
    uint root; uint material; uint flags; uint pad;
};
struct GpuStats { uint dropped_samples; uint rays_lo; uint rays_hi; uint pad; };

layout(push_constant, scalar) uniform Push {
    uint seed_lo;
    uint seed_hi;
    uint sample_base;
    uint spp;
    int max_depth;
    int rr_depth;
    uint flags;
    uint dispatch; // lanes and band: common/dispatch.glsl
} pc;

// What a render holds constant, read at run time (the generic kernel) or compiled in where the
// host specialises the kernel (renderer/src/render/session.rs, `defines`), so that the tests on
// them fold away: the depths (push constants), the pixel filter (the Gaussian, else the box:
// common/filter.glsl), the camera (a thin lens, else a pinhole: common/camera.glsl) and whether
// surfaces orthogonalise dp/du for their tangent (common/surface.glsl). The
// integrators' options have theirs beside their parameters (deferred/common.glsl, vct/common.glsl).
#ifndef PASS_MAX_DEPTH
#define PASS_MAX_DEPTH pc.max_depth
#endif
#ifndef PASS_RR_DEPTH
#define PASS_RR_DEPTH pc.rr_depth
#endif
#ifndef FILTER_GAUSSIAN
#define FILTER_GAUSSIAN (g.film.z == 1u)
#endif
#ifndef SURFACE_TANGENTS
#define SURFACE_TANGENTS ((g.scene_flags.x & SCENE_TANGENTS) != 0u)
#endif
#ifndef CAMERA_THIN_LENS
#define CAMERA_THIN_LENS (g.lens.z > 0.0)
#endif

#endif
