// `vct`: the final gather of voxel cone tracing (Crassin et al. 2011, "Interactive Indirect
// Illumination Using Voxel Cone Tracing"). One thread per pixel and sample: the camera ray is
// traced through the BVH; at the primary hit the emission (max_depth ≥ 1) and the direct light
// (max_depth ≥ 2) are computed exactly as `nee` does at its first vertex (a light sample with a
// shadow ray — or a shadow cone with `shadows: "cone"` — and a BSDF sample that may hit an
// emitter or the environment, combined by MIS with the power heuristic); with max_depth ≥ 3 the
// indirect light comes from cones traced through the filtered voxel volume (VCT_VOLUME): N
// diffuse cones for diffuse surfaces, else one cone along the BSDF-sampled direction whose
// aperture follows the lobe (solid angle ≈ 1/pdf, so it narrows with roughness). The volume
// holds only reflected light (emission and the environment are the direct part), so nothing is
// counted twice. Compiled without VCT_VOLUME this kernel needs only the session's bindings and
// renders max_depth ≤ 2.
#version 460
#extension GL_GOOGLE_include_directive : require
// The gather only reads the volume: its buffers are declared `readonly` here (vct/common.glsl),
// +4.6..+17% on an H200 (bench/RESULTS.md, "Read-only buffers, the tangent only where a BSDF
// reads it").
#define VCT_READS readonly
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
#ifdef VCT_VOLUME
#include "vct/cone.glsl"
#endif

PASS_LOCAL_SIZE;

bool depth_allows(int d) { return PASS_MAX_DEPTH < 0 || PASS_MAX_DEPTH >= d; }

#ifdef VCT_VOLUME
// Ambient occlusion at s: the mean transparency of the diffuse cones within `ao_distance`.
float ambient_occlusion(Surface s, vec3 n, inout Rng rng) {
    uint nc = VCT_CONES;
    vec3 t, b;
    make_frame(n, t, b);
    float phi0 = 2.0 * PI * rng_next1(rng);
    vec3 origin = s.p + n * P.grid.w;
    float vis = 0.0;
    for (uint i = 0u; i < nc; ++i) {
        vec3 d = from_local(diffuse_cone_dir(i, nc, phi0), t, b, n);
        vis += 1.0 - cone_trace(origin, d, P.cone.x, 1.0, max(P.cone.w, 1.0)).a;
    }
    return vis / float(nc);
}
#endif

// Visibility between surface s and a light sample.
bool visible(Surface s, LightSample ls, inout uint rays, out float vis) {
    vis = 1.0;
#ifdef VCT_VOLUME
    if (VCT_SHADOW_CONE) {
        // Shadow cone: transparency of a narrow cone towards the light, stopping three voxels short.
        vec3 ng = dot(s.ng, ls.wi) >= 0.0 ? s.ng : -s.ng;
        float tmax = isinf(ls.dist) ? 1e9 : ls.dist / P.grid.w - 3.0;
        vis = 1.0 - cone_trace(s.p + ng * (CONE_OFFSET * P.grid.w), ls.wi, 0.02, 1.0, tmax).a;
        return vis > 0.0;
    }
#endif
    Ray shadow = isinf(ls.dist) ? spawn_ray(s, ls.wi) : spawn_ray_to(s, ls.p);
    rays += 1u;
    return !trace_any(shadow);
}

vec3 shade(uvec2 px, inout Rng rng, inout uint rays) {
    // Step 1: the camera ray; escaping rays see the environment.
    Ray ray = camera_ray(px, rng);
    Hit hit;
    rays += 1u;
    bool hit_any = trace_closest(ray, hit);
#ifdef VCT_VOLUME
    if (VCT_AO) {
        if (!hit_any) return vec3(1.0);
        Surface sa = surface_at(hit, ray);
        vec3 na = dot(sa.ng, -ray.d) >= 0.0 ? sa.ng : -sa.ng;
        return vec3(ambient_occlusion(sa, na, rng));
    }
#endif
    if (PASS_MAX_DEPTH == 0) return vec3(0.0);
    if (!hit_any) return env_eval(ray.d);
    Surface s = surface_at(hit, ray);
    vec3 wo_world = -ray.d;
    vec3 L = vec3(0.0);

    // Step 2: emission, front side only (as nee).
    GpuMaterial gm = materials[s.material];
    if (s.light != NONE && dot(wo_world, s.ng) > 0.0) L += gm.emission.rgb;
    if (!depth_allows(2)) return L;

    // Step 3: direct light, exact: a light sample and a BSDF sample, MIS-weighted.
    SurfaceParams m = resolve_material(s.material, s.uv);
    vec3 bt = cross(s.ns, s.tangent);
    vec3 wo = to_local(wo_world, s.tangent, bt, s.ns);
    vec3 ul = rng_next3(rng);
    if (!bsdf_is_delta(m)) {
        LightSample ls;
        if (sample_light(s.p, s.ns, ul, ls) && any(greaterThan(ls.L, vec3(0.0)))) {
            vec3 wi = to_local(ls.wi, s.tangent, bt, s.ns);
            vec3 f = bsdf_eval(m, wo, wi, TRANSPORT_RADIANCE);
            float vis;
            if (any(greaterThan(f, vec3(0.0))) && visible(s, ls, rays, vis)) {
                float w = ls.delta ? 1.0 : power_heuristic(ls.pdf, bsdf_pdf(m, wo, wi));
                L += f * ls.L * (vis * w / ls.pdf);
            }
        }
    }
    BsdfSample bs;
    bool sampled = bsdf_sample(m, wo, rng_next3(rng), TRANSPORT_RADIANCE, bs);
    vec3 wi_world = vec3(0.0);
    if (sampled && any(greaterThan(bs.weight, vec3(0.0)))) {
        bool delta = (bs.flags & BSDF_DELTA) != 0u;
        wi_world = from_local(bs.wi, s.tangent, bt, s.ns);
        Ray r2 = spawn_ray(s, wi_world);
        Hit h2;
        rays += 1u;
        if (!trace_closest(r2, h2)) {
            vec3 le = env_eval(wi_world);
            float w = delta ? 1.0 : power_heuristic(bs.pdf, env_pdf(wi_world));
            L += bs.weight * le * w;
        } else {
            Surface s2 = surface_at(h2, r2);
            if (s2.light != NONE && dot(-wi_world, s2.ng) > 0.0) {
                float w = delta ? 1.0 : power_heuristic(bs.pdf, light_pdf_hit(s2.light, s.p, s.ns, s2.p, s2.ng));
                L += bs.weight * materials[s2.material].emission.rgb * w;
            }
        }
    } else {
        sampled = false;
    }
    if (!depth_allows(3)) return L;

#ifdef VCT_VOLUME
    // Step 4: indirect light from the voxel volume.
    vec3 ng_o = dot(s.ng, wo_world) >= 0.0 ? s.ng : -s.ng;
    float vox = P.grid.w;
    if (material_type(m) == MAT_DIFFUSE) {
        // Diffuse cones over the hemisphere of the side seen, randomly rotated per sample:
        // ∫ f L cos dω ≈ Σ_i f_i(cos) L_i · π / (N cos_i) (cosine-weighted placement).
        uint nc = VCT_CONES;
        vec3 n = dot(s.ns, wo_world) >= 0.0 ? s.ns : -s.ns;
        vec3 t, b;
        make_frame(n, t, b);
        float phi0 = 2.0 * PI * rng_next1(rng);
        vec3 origin = s.p + ng_o * (CONE_OFFSET * vox);
        // `cones_per_sample` (VCT_CONES_PER_SAMPLE) < nc: a run of that many cones from a random
        // one, weighted by nc / run, so each cone is traced with the same expected weight.
        uint run = clamp(uint(VCT_CONES_PER_SAMPLE), 1u, nc);
        uint first = run < nc ? min(uint(rng_next1(rng) * float(nc)), nc - 1u) : 0u;
        float run_weight = float(nc) / float(run);
        for (uint j = 0u; j < run; ++j) {
            uint i = (first + j) % nc;
            vec3 dl = diffuse_cone_dir(i, nc, phi0);
            vec3 d = from_local(dl, t, b, n);
            vec3 f = bsdf_eval(m, wo, to_local(d, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
            if (!any(greaterThan(f, vec3(0.0)))) continue;
            vec3 Lc = cone_trace(origin, d, P.cone.x, 1.0, 1e9).rgb;
            L += f * Lc * (PI * run_weight / (float(nc) * max(dl.z, 1e-3)));
        }
    } else if (sampled) {
        // One cone along the sampled direction; its solid angle ≈ 1/pdf (narrow for smooth lobes,
        // the finest voxels for delta ones), at most the diffuse cones' aperture.
        bool delta = (bs.flags & BSDF_DELTA) != 0u;
        float tan_half = delta ? 0.0 : min(sqrt(1.0 / (PI * max(bs.pdf, 1e-6))), P.cone.x);
        vec3 side = dot(wi_world, ng_o) >= 0.0 ? ng_o : -ng_o;
        vec3 Lc = cone_trace(s.p + side * (CONE_OFFSET * vox), wi_world, tan_half, 1.0, 1e9).rgb;
        L += bs.weight * Lc;
    }
#endif
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
            L = shade(t.px, rng, rays);
        }
        film_lanes_add(t, acc, L, r, dropped);
    }
    film_store(t, acc);
    film_count(rays, dropped);
}
