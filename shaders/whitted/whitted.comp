// `whitted`: classic Whitted ray tracing (see renderer/src/integrators/whitted.rs for the model,
// max_depth's meaning and the material mapping). One thread per pixel; per sample a camera ray
// and then an explicit stack of weighted rays, depth first: each popped ray adds the emission it
// hits (or the environment), the direct light and ambient term of the local lobes there, and
// pushes its mirror-reflected and refracted branches. The only random numbers are the camera
// ray's (pixel filter, lens); with WHITTED_JITTER 0 not even those.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "common/bindings.glsl"
#include "common/film.glsl"
#include "common/dispatch.glsl"
#include "common/math.glsl"
#include "common/rng.glsl"
#include "common/camera.glsl"
#include "common/traverse.glsl"
#include "common/surface.glsl"
#include "common/material.glsl"
#include "common/lights.glsl"
#include "whitted/shade.glsl"
#include "whitted/direct.glsl"

#ifndef WHITTED_STACK
#define WHITTED_STACK 16
#endif
#ifndef WHITTED_MIN_WEIGHT
#define WHITTED_MIN_WEIGHT 1e-4
#endif
#ifndef WHITTED_JITTER
#define WHITTED_JITTER 1
#endif

PASS_LOCAL_SIZE;


// The ray through the centre of pixel px (and of the lens): no filter offset.
Ray camera_ray_center(uvec2 px) {
    vec2 film = vec2(px) + 0.5;
    vec2 res = vec2(g.film.xy);
    float tan_half = g.lens.x, aspect = g.lens.y;
    float sx = (2.0 * film.x / res.x - 1.0) * tan_half * aspect;
    float sy = (1.0 - 2.0 * film.y / res.y) * tan_half;
    Ray r;
    r.o = vec3(0.0);
    r.d = normalize(g.cam_forward.xyz + sx * g.cam_right.xyz + sy * g.cam_up.xyz);
    r.tmin = 0.0;
    r.tmax = FLT_MAX_C;
    return r;
}

// A pending ray of the tree: where it starts, its weight, and how many segments precede it.
struct Pending {
    vec3 o;
    vec3 d;
    vec3 beta;
    int depth;
};

// The ray stack: WHITTED_STACK entries where materials branch, else the camera ray's one.
#if WHITTED_BRANCHES
#define WHITTED_STACK_SIZE WHITTED_STACK
#else
#define WHITTED_STACK_SIZE 1
#endif

vec3 trace_whitted(uvec2 px, inout Rng rng, inout uint rays) {
    Pending stack[WHITTED_STACK_SIZE];
    int sp = 0;
    // Step 1: the camera ray.
#if WHITTED_JITTER
    Ray cam = camera_ray(px, rng);
#else
    Ray cam = camera_ray_center(px);
#endif
    stack[sp++] = Pending(cam.o, cam.d, vec3(1.0), 0);
    vec3 L = vec3(0.0);
    if (PASS_MAX_DEPTH == 0) return L; // max_depth 0: nothing at all (Mitsuba)
    while (sp > 0) {
        Pending e = stack[--sp];
        Ray ray;
        ray.o = e.o;
        ray.d = e.d;
        ray.tmin = 0.0;
        ray.tmax = FLT_MAX_C;
        // Step 2: the closest hit; escaping rays see the environment.
        Hit hit;
        rays += 1u;
        if (!trace_closest(ray, hit)) {
            L += e.beta * env_eval(ray.d);
            continue;
        }
        Surface s = surface_at(hit, ray);
        vec3 wo_world = -ray.d;
        // Step 3: emission, front side (the geometric normal's), as pt/nee and light sampling.
        if (s.light != NONE && dot(wo_world, s.ng) > 0.0) L += e.beta * materials[s.material].emission.rgb;
        // Step 4: a vertex reached by depth + 1 segments may add light only below max_depth.
        if (e.depth + 1 >= PASS_MAX_DEPTH) continue;

        // Step 5: the classic decomposition of the material.
        SurfaceParams m = resolve_material(s.material, s.uv);
        vec3 bt = cross(s.ns, s.tangent);
        vec3 wo = to_local(wo_world, s.tangent, bt, s.ns);
        Classic c = classic_material(m, wo);

        // Step 6: local lobes: shadow rays to every light, and the ambient term (the environment
        // along the shading normal on wo's side, times the lobes' albedo; no shadow ray).
        if (c.has_local) {
            L += e.beta * whitted_direct(s, c.local, wo_world, rays);
            if (any(greaterThan(c.ambient, vec3(0.0))) && ENV_LIGHT != NONE) {
                vec3 n_side = wo.z >= 0.0 ? s.ns : -s.ns;
                L += e.beta * c.ambient * env_eval(n_side);
            }
        }

#if WHITTED_BRANCHES
        // Step 7: the specular branches, the lighter pushed first so the heavier runs first.
        vec3 wr_beta = e.beta * c.kr, wt_beta = e.beta * c.kt;
        bool reflect_on = max_comp(wr_beta) >= WHITTED_MIN_WEIGHT;
        bool refract_on = max_comp(wt_beta) >= WHITTED_MIN_WEIGHT;
        vec3 wr = from_local(vec3(-wo.x, -wo.y, wo.z), s.tangent, bt, s.ns);
        vec3 wt = from_local(c.wt, s.tangent, bt, s.ns);
        bool refract_first = refract_on && reflect_on && max_comp(wt_beta) < max_comp(wr_beta);
        for (int k = 0; k < 2; ++k) {
            bool is_refract = (k == 0) == refract_first;
            if (is_refract ? !refract_on : !reflect_on) continue;
            if (sp >= WHITTED_STACK) break; // cannot happen below the depth cap (whitted.rs)
            Ray next = spawn_ray(s, is_refract ? wt : wr);
            stack[sp++] = Pending(next.o, next.d, is_refract ? wt_beta : wr_beta, e.depth + 1);
        }
#endif
    }
    return L;
}

void main() {
    COUNT_CLOCK_START;
    FilmTask t = film_task();
    vec4 acc = film_load(t);
    uint rays = 0u, dropped = 0u;
    for (uint r = 0u; r < film_rounds(t); ++r) {
        uint i = film_sample(t, r);
        vec3 L = vec3(0.0);
        if (film_has(t, i)) {
            Rng rng = rng_init(t.pixel, pc.sample_base + i, pc.seed_lo, pc.seed_hi);
            L = trace_whitted(t.px, rng, rays);
        }
        film_lanes_add(t, acc, L, r, dropped);
    }
    film_store(t, acc);
    film_count(rays, dropped);
}
