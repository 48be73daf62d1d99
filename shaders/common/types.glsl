// GPU scene layout: the GLSL mirror of renderer/src/compile/layout.rs (scalar block layout).
// Keep the two in step; the layout test checks every field.
#ifndef COMMON_TYPES_GLSL
#define COMMON_TYPES_GLSL

#extension GL_EXT_scalar_block_layout : require

#define B_GLOBALS 0
#define B_BVH_NODES 1
#define B_PRIMS 2
#define B_TRI_SHADING 3
#define B_MATERIALS 4
#define B_TEXTURES 5
#define B_TEXELS 6
#define B_LIGHTS 7
#define B_LIGHT_ALIAS 8
#define B_ENV_DIST 9
#define B_ACCUM 10
#define B_STATS 11
#define B_SPLAT 12   // bdpt: light-tracing splat buffer (shaders/bdpt/splat.glsl)
#define B_GRID 13        // accel "grid" only (shaders/common/grid.glsl): GpuGridInfo
#define B_GRID_CELLS 14  // cell offsets into the reference list (cells + 1 entries)
#define B_GRID_PRIMS 15  // the reference list (primitive indices)

#define NONE 0xffffffffu
#define PRIM_MATERIAL_MASK 0x00ffffffu
#define PRIM_SPHERE (1u << 31)
#define PRIM_FLIP_NORMALS (1u << 30)
#define PRIM_ALPHA (1u << 29)

#define LIGHT_TRIANGLE 0u
#define LIGHT_SPHERE 1u
#define LIGHT_POINT 2u
#define LIGHT_SPOT 3u
#define LIGHT_DIRECTIONAL 4u
#define LIGHT_ENV_CONSTANT 5u
#define LIGHT_ENV_MAP 6u

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
struct GpuMaterial {
    uvec4 header;
    vec4 emission;
    vec4 colors[3];
    float scalars[12];
    uint scalar_tex[12];
};
struct GpuTexture { uint offset; uint width; uint height; uint flags; vec2 scale; vec2 pad; };
struct GpuLight { uint kind; uint prim; float pick_pdf; uint pad; vec4 p0; vec4 p1; vec4 p2; vec4 radiance; };
struct GpuAlias { float prob; uint alias; };
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
    uint pad;
} pc;

#endif
