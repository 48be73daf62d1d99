// `deferred` at max_depth ≤ 1: only what the camera sees directly — front-facing emitters and
// the environment — needs no G-buffer, culling or shading stage, so this single kernel (the
// session's own pipeline, bound to the scene buffers only) renders it. For max_depth ≥ 2 the
// integrator runs its three stages instead (gbuffer.comp, cull.comp, shade.comp).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "common/bindings.glsl"
#include "common/film.glsl"
#include "common/rng.glsl"
#include "common/camera.glsl"
#include "common/traverse.glsl"
#include "common/surface.glsl"
#include "common/env.glsl"

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;


void main() {
    COUNT_CLOCK_START;
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= g.film.x || px.y >= g.film.y) return;
    uint pixel = px.y * g.film.x + px.x;
    vec4 acc = accum[pixel];
    uint dropped = 0u;
    for (uint i = 0u; i < pc.spp; ++i) {
        // The same camera ray the three-stage path would trace for this sample.
        Rng rng = rng_init(pixel, pc.sample_base + i, pc.seed_lo, pc.seed_hi);
        Ray ray = camera_ray(px, rng);
        vec3 L = vec3(0.0);
        if (PASS_MAX_DEPTH >= 1) {
            Hit hit;
            if (!trace_closest(ray, hit)) {
                L = env_eval(ray.d);
            } else {
                Surface s = surface_at(hit, ray);
                if (dot(-ray.d, s.ng) > 0.0) L = materials[s.material].emission.rgb;
            }
        }
        film_add(acc, L, pc.sample_base + i, dropped);
    }
    accum[pixel] = acc;
    film_odd_store(pixel);
    film_count(pc.spp, dropped);
}
