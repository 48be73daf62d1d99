// The scene's storage buffers at their named bindings (types.glsl). Included once per kernel.
#ifndef COMMON_BINDINGS_GLSL
#define COMMON_BINDINGS_GLSL
// COUNT_STEPS, a measuring define (CANDELA_SHADER_DEFINES): each invocation counts the BVH nodes
// it fetches and the primitives it tests (the binary BVH's and the CWBVH's walks of the scene's
// own tree; not instances' walks, the stackless fallback or the grid), and film_count reports
// them in place of the rays: COUNT_STEPS=1 node fetches, =2 primitive tests.
#ifdef COUNT_STEPS
uint count_nodes = 0u, count_prims = 0u;
#define COUNT_NODE count_nodes++
#define COUNT_PRIM count_prims++
#else
#define COUNT_NODE
#define COUNT_PRIM
#endif
// COUNT_CLOCK, a measuring define like COUNT_STEPS: each invocation adds the subgroup clock's
// cycles it spends in closest-hit walks (=1), any-hit walks (=2) or its whole kernel (=3: from
// COUNT_CLOCK_START at the top of each pass kernel's main to film_count), reported in place of
// the rays (needs the device's VK_KHR_shader_clock).
#ifdef COUNT_CLOCK
#extension GL_ARB_shader_clock : require
uint count_clock = 0u, count_clock_start = 0u;
#define COUNT_CLOCK_START count_clock_start = clock2x32ARB().x
#else
#define COUNT_CLOCK_START
#endif
#include "common/types.glsl"

layout(set = 0, binding = B_GLOBALS, scalar) readonly buffer Globals { GpuGlobals g; };
// BVH nodes (GpuBvhNode) as four 16-byte words each, so that a node is fetched with four wide
// loads (`bvh_node` in common/traverse.glsl); the struct over a scalar-layout buffer was read in
// narrower pieces, 5-10% slower (bench/RESULTS.md, "The CWBVH node test and wide BVH loads").
layout(set = 0, binding = B_BVH_NODES, std430) readonly buffer BvhNodes { vec4 node_words[]; };
layout(set = 0, binding = B_PRIMS, scalar) readonly buffer Prims { GpuPrim prims[]; };
layout(set = 0, binding = B_TRI_SHADING, scalar) readonly buffer TriShading { GpuTriShading tri_shading[]; };
layout(set = 0, binding = B_MATERIALS, scalar) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = B_TEXTURES, scalar) readonly buffer Textures { GpuTexture textures[]; };
layout(set = 0, binding = B_TEXELS, scalar) readonly buffer Texels { vec4 texels[]; };
layout(set = 0, binding = B_LIGHTS, scalar) readonly buffer Lights { GpuLight lights[]; };
layout(set = 0, binding = B_LIGHT_ALIAS, scalar) readonly buffer LightAlias { GpuAlias light_alias[]; };
layout(set = 0, binding = B_ENV_DIST, scalar) readonly buffer EnvDist { float env_dist[]; };
layout(set = 0, binding = B_ACCUM, scalar) buffer Accum { vec4 accum[]; };
layout(set = 0, binding = B_STATS, scalar) buffer Stats { GpuStats stats; };
// The odd-indexed samples' share of ACCUM (the error estimate's second half; common/film.glsl).
layout(set = 0, binding = B_ACCUM_ODD, scalar) buffer AccumOdd { vec4 accum_odd[]; };

#endif
