// `deferred`: what every stage shares: its own buffers (bindings 30–34, next to the session's
// scene bindings), the parameters block, the light record written by the host light manager
// (renderer/src/integrators/deferred/lights.rs), and the packed G-buffer with its octahedral
// normal encoding (Cigolle et al. 2014, "A Survey of Efficient Representations for Independent
// Unit Vectors"), mirrored on the host by renderer/src/integrators/deferred/gbuffer.rs.
//
// Bindings 30–35: parameters, light records, G-buffer, tile counts, tile lists, counters.
//
// Batches: each stage's dispatch covers the samples pc.sample_base .. pc.sample_base + pc.spp − 1
// of a batch (renderer/src/integrators/deferred/batch.rs); the G-buffer, the tile counts and the
// tile lists hold one slice per sample of the batch (slice i: sample pc.sample_base + i), indexed
// by gbuf_index and tile_slot below.
//
// G-buffer: 16 bytes per pixel and sample (one uvec4) for the batch's camera samples:
//   x: shading normal, octahedral, 2 × 16-bit snorm (packSnorm2x16)
//   y: depth = distance t along the camera ray (f32 bits); the position is reconstructed as
//      o + t·d from the camera ray, which every stage regenerates from the same counter-based
//      random numbers (seed, pixel, sample index), so it is the very ray the G-buffer traced
//   z: material index (bits 0–23) | GB_FRONT (bit 24: the ray hit the front, geometric-normal
//      side, where emitters emit); NONE where the ray escaped
//   w: surface uv as 2 × f16 (packHalf2x16), for textured materials
#ifndef DEFERRED_COMMON_GLSL
#define DEFERRED_COMMON_GLSL
#include "common/bindings.glsl"
#include "common/math.glsl"
#include "common/rng.glsl"
#include "common/camera.glsl"

#define B_DPARAMS 30
#define B_DLIGHTS 31
#define B_GBUFFER 32
#define B_TILE_COUNTS 33
#define B_TILE_LIGHTS 34
#define B_COUNTERS 35

#define TILE 16
#define GB_MATERIAL_MASK 0x00ffffffu
#define GB_FRONT (1u << 24)
#define TILE_OVERFLOW 0xffffffffu

#define DL_POINT 0u
#define DL_SPOT 1u
#define DL_COSINE 2u
#define DL_DIRECTIONAL 3u

#define DEBUG_NONE 0u
#define DEBUG_NORMAL 1u
#define DEBUG_DEPTH 2u
#define DEBUG_GBUFFER_ERROR 3u
#define DEBUG_TILE_LIGHTS 4u

// The per-render parameters (DeferredParams in renderer/src/integrators/deferred/stages.rs).
struct DParams {
    uint n_cull;        // lights culled per tile: records [0, n_cull)
    uint n_dir;         // directional lights, always shaded: records [n_cull, n_cull + n_dir)
    uint tiles_x;
    uint tiles_y;
    uint tile_capacity; // light indices per tile list
    uint max_per_pixel; // 0: all the lights of the tile list that reach the pixel
    uint shadows;       // 1: shadow rays through the BVH (any hit)
    uint cull;          // 0: no tile culling and no influence radius (the unculled reference)
    uint debug;         // DEBUG_*
    uint env_ambient;   // 1: the environment lights surfaces as an unshadowed ambient term
    uint pad0;
    uint pad1;
};

// One light after the light manager (64 bytes; DeferredLight on the host).
//   pos_radius: position (camera-relative), influence radius (FLT_MAX: unbounded)
//   intensity:  rgb intensity W/sr (point, spot: peak; cosine: I0 along the axis) or irradiance
//               (directional); w: kind (DL_*) as float bits
//   axis:       spot/cosine axis or the directional light's travel direction; w: cos cutoff
//               (spot), 0 (cosine: a hemisphere), −1 (point)
//   spot:       (cos beam, cutoff rad, beam rad, distance to stop shadow rays short of the
//               light: the emitting sphere's radius for a sphere emitter, else 0)
struct DLight { vec4 pos_radius; vec4 intensity; vec4 axis; vec4 spot; };

layout(set = 0, binding = B_DPARAMS, scalar) readonly buffer DParamsBuf { DParams dp; };

// The options that pick code paths, read from the parameters (the generic kernel) or compiled in
// where the host specialises the kernel (renderer/src/integrators/deferred/mod.rs, `constants`).
#ifndef DEFERRED_SHADOWS
#define DEFERRED_SHADOWS (dp.shadows != 0u)
#endif
#ifndef DEFERRED_CULL
#define DEFERRED_CULL (dp.cull != 0u)
#endif
#ifndef DEFERRED_CAP
#define DEFERRED_CAP dp.max_per_pixel
#endif
#ifndef DEFERRED_DEBUG
#define DEFERRED_DEBUG dp.debug
#endif
#ifndef DEFERRED_ENV_AMBIENT
#define DEFERRED_ENV_AMBIENT (dp.env_ambient != 0u)
#endif
layout(set = 0, binding = B_DLIGHTS, scalar) readonly buffer DLights { DLight dlights[]; };
// The G-buffer's and the tiles' qualifier: empty for the stages that write them, `readonly` in
// the shading stage (shade.comp), which only reads them.
#ifndef DEFERRED_STAGE_READS
#define DEFERRED_STAGE_READS
#endif
layout(set = 0, binding = B_GBUFFER, scalar) DEFERRED_STAGE_READS buffer GBuffer { uvec4 gbuf[]; };
layout(set = 0, binding = B_TILE_COUNTS, scalar) DEFERRED_STAGE_READS buffer TileCounts { uint tile_counts[]; };
layout(set = 0, binding = B_TILE_LIGHTS, scalar) DEFERRED_STAGE_READS buffer TileLights { uint tile_lights[]; };
// Shading counters, 64-bit as (lo, hi) pairs, summed over a pass and read back by the host:
// candidate lights tested per pixel, lights that reached the pixel (and were shaded), and the
// pixels shaded with direct light.
layout(set = 0, binding = B_COUNTERS, scalar) buffer Counters { uvec2 counters[3]; };

// Adds v to the 64-bit counter i (carry into the high word when the low word wraps).
void counter_add(uint i, uint v) {
    if (v == 0u) return;
    uint before = atomicAdd(counters[i].x, v);
    if (before + v < before) atomicAdd(counters[i].y, 1u);
}

uint dl_kind(DLight l) { return floatBitsToUint(l.intensity.w); }

// The G-buffer entry of `pixel` in slice `slice` (the batch's sample pc.sample_base + slice).
uint gbuf_index(uint slice, uint pixel) { return slice * g.film.x * g.film.y + pixel; }

// The tile-count entry of tile `tile` in slice `slice`; its list starts at
// tile_slot(slice, tile) * dp.tile_capacity.
uint tile_slot(uint slice, uint tile) { return slice * dp.tiles_x * dp.tiles_y + tile; }

// Octahedral encoding of a unit vector into [−1, 1]² (Cigolle et al. 2014, listing 1).
vec2 oct_wrap(vec2 v) { return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }
vec2 oct_encode(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    return n.z >= 0.0 ? n.xy : oct_wrap(n.xy);
}
vec3 oct_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) n.xy = oct_wrap(n.xy);
    return normalize(n);
}

struct GSample {
    bool hit;
    vec3 n;       // shading normal (front side, as surface_at gives it)
    float t;      // distance along the camera ray
    uint material;
    bool front;   // the ray met the geometric front side
    vec2 uv;
};

uvec4 gbuffer_pack(vec3 n, float t, uint material, bool front, vec2 uv) {
    return uvec4(packSnorm2x16(oct_encode(n)), floatBitsToUint(t),
                 (material & GB_MATERIAL_MASK) | (front ? GB_FRONT : 0u), packHalf2x16(uv));
}

GSample gbuffer_unpack(uvec4 w) {
    GSample s;
    s.hit = w.z != NONE;
    s.n = oct_decode(unpackSnorm2x16(w.x));
    s.t = uintBitsToFloat(w.y);
    s.material = w.z & GB_MATERIAL_MASK;
    s.front = (w.z & GB_FRONT) != 0u;
    s.uv = unpackHalf2x16(w.w);
    return s;
}

// The camera ray of (pixel, sample): the first draw of that sample's random sequence, so the
// G-buffer, cull and shade stages all see the same ray.
Ray sample_camera_ray(uvec2 px, uint sample_index, out Rng rng) {
    uint pixel = px.y * g.film.x + px.x;
    rng = rng_init(pixel, sample_index, pc.seed_lo, pc.seed_hi);
    return camera_ray(px, rng);
}

// Monotone map of a float's bits to uint (for atomicMin/Max on floats of either sign).
uint float_order(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}
float float_unorder(uint u) {
    return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

#endif
