// `deferred`, stage 3: shading. One thread per pixel (16×16 workgroups, one per tile) shades
// each sample of the batch in sample order — reads the sample's G-buffer texel, regenerates its
// camera ray to reconstruct the position — and adds them to the accumulation buffer one by one,
// exactly as one sample per dispatch would (so the image does not depend on the batch size), in
// the radiometric units of `nee`:
//   • emission of a front-facing emitter seen directly, or the environment where the ray escaped;
//   • (max_depth ≥ 2) for every light of its tile's list that reaches the pixel — inside the
//     light's influence radius, inside a spot's cone, in front of an area emitter — f·|cos|·I/d²
//     with the material's BSDF (common/bsdf: exact for every material type), optionally
//     shadowed by an any-hit ray through the BVH; only the `max_per_pixel` strongest by
//     estimated irradiance when that cap is set;
//   • every directional light (irradiance × f·|cos|), optionally shadowed;
//   • the environment as an ambient term: one BSDF-sampled direction per sample weighted by the
//     environment radiance there (an unbiased estimate of unshadowed environment lighting; with
//     `shadows` the direction is tested for occlusion, making it exact direct lighting).
// Debug modes replace the radiance by G-buffer contents or the culling counts (common.glsl).
// Counters (common.glsl) record the lights tested and shaded per pixel for the statistics.
#version 460
#extension GL_GOOGLE_include_directive : require
#define DEFERRED_STAGE_READS readonly
#include "deferred/common.glsl"
#include "common/film.glsl"
#include "common/traverse.glsl"
#include "common/surface.glsl"
#include "common/material.glsl"
#include "common/env.glsl"

layout(local_size_x = TILE, local_size_y = TILE, local_size_z = 1) in;

#define MAX_CAP 32

shared uint s_rays;
shared uint s_dropped;
shared uint s_tested;
shared uint s_shaded;
shared uint s_lit;


// Light l as seen from p: direction wi, distance, and the incident irradiance-per-solid-angle
// factor Li = I(−wi)·falloff / d² (so that f·|cos|·Li is the reflected radiance). False when
// the light cannot contribute: outside its influence radius (when culling), outside a spot's
// cone, behind an area emitter, or at the light itself.
bool light_incident(DLight l, vec3 p, out vec3 wi, out float dist, out vec3 Li) {
    wi = vec3(0.0, 0.0, 1.0); dist = 0.0; Li = vec3(0.0);
    vec3 w = l.pos_radius.xyz - p;
    float d2 = dot(w, w);
    if (!(d2 > 0.0)) return false;
    float r = l.pos_radius.w;
    if (DEFERRED_CULL && d2 >= r * r) return false;
    dist = sqrt(d2);
    wi = w / dist;
    uint kind = dl_kind(l);
    float falloff = 1.0;
    float cos_out = -dot(wi, l.axis.xyz); // cosine between the light's axis and the way to p
    if (kind == DL_SPOT) {
        // Mitsuba 3's spot: 1 inside the beam, linear in angle to 0 at the cutoff.
        if (cos_out <= l.axis.w) return false;
        if (cos_out < l.spot.x)
            falloff = clamp((l.spot.y - safe_acos(cos_out)) / (l.spot.y - l.spot.z), 0.0, 1.0);
    } else if (kind == DL_COSINE) {
        // A small planar emitter: I(θ) = L·A·cos θ on its front side.
        falloff = cos_out;
    }
    if (!(falloff > 0.0)) return false;
    if (dist <= l.spot.w) return false; // inside an emitting sphere
    Li = l.intensity.rgb * (falloff / d2);
    return true;
}

// Whether the segment from the surface towards light l (or along wi for directional lights) is
// free of occluders.
bool unoccluded(Surface s, DLight l, vec3 wi, float dist, inout uint rays) {
    rays += 1u;
    Ray r;
    if (dl_kind(l) == DL_DIRECTIONAL) {
        r = spawn_ray(s, wi);
    } else {
        r = spawn_ray_to(s, l.pos_radius.xyz);
        // Stop short of a sphere emitter's surface (the point stands for its centre).
        r.tmax = max(r.tmax - l.spot.w * (1.0 + 1e-3), 0.0);
    }
    return !trace_any(r);
}

// Estimated irradiance from a light (ranking for the per-pixel cap).
float light_estimate(vec3 Li, vec3 wi, vec3 n) { return luminance(Li) * abs(dot(wi, n)); }

// Sample `slice` of the batch (sample index pc.sample_base + slice) at pixel px: its radiance
// (or debug value); adds its rays and shading counts to the running totals.
vec3 shade_sample(uvec2 px, uint pixel, uint tile_index, uint slice, inout uint rays,
                  inout uint tested, inout uint shaded, inout uint lit) {
    uint sample_index = pc.sample_base + slice;
    // Step 1: the camera ray (the one the G-buffer traced) and the packed surface.
    Rng rng;
    Ray ray = sample_camera_ray(px, sample_index, rng);
    rays += 1u;
    GSample gs = gbuffer_unpack(gbuf[gbuf_index(slice, pixel)]);
    vec3 L = vec3(0.0);
    if (!gs.hit) {
        // Step 2a: escaped rays see the environment.
        if (PASS_MAX_DEPTH >= 1) L = env_eval(ray.d);
    } else {
        // Step 2b: emission of an emitter seen from its front side.
        if (gs.front && PASS_MAX_DEPTH >= 1) L += materials[gs.material].emission.rgb;
        if (PASS_MAX_DEPTH >= 2) {
            // Step 3: the shading point: position from the camera ray and depth; the
            // rounding-error bound of the reconstruction for spawning shadow rays.
            Surface s;
            s.p = ray.o + gs.t * ray.d;
            s.p_err = 2e-6 * (abs(s.p) + abs(ray.o) + vec3(gs.t));
            // The stored shading normal stands in for the geometric one when offsetting
            // shadow rays; the tangent is any frame (the G-buffer keeps no tangent).
            s.ns = gs.n;
            s.ng = gs.n;
            vec3 bt;
            make_frame(gs.n, s.tangent, bt);
            bt = cross(s.ns, s.tangent);
            s.uv = gs.uv;
            s.material = gs.material;
            s.light = NONE;
            SurfaceParams m = resolve_material(gs.material, gs.uv);
            vec3 wo = to_local(-ray.d, s.tangent, bt, s.ns);
            if (!bsdf_is_delta(m)) {
                // Step 4: the lights of this pixel's tile (all of them when the tile
                // overflowed or culling is off).
                uint count = tile_counts[tile_slot(slice, tile_index)];
                bool all = !DEFERRED_CULL || count == TILE_OVERFLOW;
                uint n = all ? dp.n_cull : count;
                uint base = tile_slot(slice, tile_index) * dp.tile_capacity;
                uint cap = min(uint(DEFERRED_CAP), uint(MAX_CAP));
                lit += 1u;
                tested += n;
                if (cap == 0u) {
                    for (uint k = 0u; k < n; ++k) {
                        DLight l = dlights[all ? k : tile_lights[base + k]];
                        vec3 wi, Li; float dist;
                        if (!light_incident(l, s.p, wi, dist, Li)) continue;
                        shaded += 1u;
                        vec3 f = bsdf_eval(m, wo, to_local(wi, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
                        if (!any(greaterThan(f, vec3(0.0)))) continue;
                        if (DEFERRED_SHADOWS && !unoccluded(s, l, wi, dist, rays)) continue;
                        L += f * Li;
                    }
                } else {
                    // Step 4′: keep the `cap` strongest by estimated irradiance (a sorted
                    // list, strongest first), then shade those.
                    float best_e[MAX_CAP];
                    uint best_i[MAX_CAP];
                    uint nb = 0u;
                    for (uint k = 0u; k < n; ++k) {
                        uint li = all ? k : tile_lights[base + k];
                        vec3 wi, Li; float dist;
                        if (!light_incident(dlights[li], s.p, wi, dist, Li)) continue;
                        float e = light_estimate(Li, wi, s.ns);
                        if (nb == cap && e <= best_e[cap - 1u]) continue;
                        uint j = nb < cap ? nb++ : cap - 1u;
                        while (j > 0u && best_e[j - 1u] < e) {
                            best_e[j] = best_e[j - 1u]; best_i[j] = best_i[j - 1u]; --j;
                        }
                        best_e[j] = e; best_i[j] = li;
                    }
                    shaded += nb;
                    for (uint k = 0u; k < nb; ++k) {
                        DLight l = dlights[best_i[k]];
                        vec3 wi, Li; float dist;
                        if (!light_incident(l, s.p, wi, dist, Li)) continue;
                        vec3 f = bsdf_eval(m, wo, to_local(wi, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
                        if (!any(greaterThan(f, vec3(0.0)))) continue;
                        if (DEFERRED_SHADOWS && !unoccluded(s, l, wi, dist, rays)) continue;
                        L += f * Li;
                    }
                }
                // Step 5: directional lights, always shaded.
                for (uint k = dp.n_cull; k < dp.n_cull + dp.n_dir; ++k) {
                    DLight l = dlights[k];
                    vec3 wi = -l.axis.xyz;
                    vec3 f = bsdf_eval(m, wo, to_local(wi, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
                    if (!any(greaterThan(f, vec3(0.0)))) continue;
                    if (DEFERRED_SHADOWS && !unoccluded(s, l, wi, 0.0, rays)) continue;
                    L += f * l.intensity.rgb;
                }
            }
            // Step 6: the environment as an ambient term, by one BSDF sample.
            if (DEFERRED_ENV_AMBIENT && ENV_LIGHT != NONE) {
                BsdfSample bs;
                if (bsdf_sample(m, wo, rng_next3(rng), TRANSPORT_RADIANCE, bs)) {
                    vec3 wi = from_local(bs.wi, s.tangent, bt, s.ns);
                    bool vis = true;
                    if (DEFERRED_SHADOWS) {
                        rays += 1u;
                        vis = !trace_any(spawn_ray(s, wi));
                    }
                    if (vis) L += bs.weight * env_eval(wi);
                }
            }
        }
    }
    // Debug views of the G-buffer and the culling.
    if (DEFERRED_DEBUG == DEBUG_NORMAL) {
        L = gs.hit ? gs.n : vec3(0.0);
    } else if (DEFERRED_DEBUG == DEBUG_DEPTH) {
        L = vec3(gs.hit ? gs.t : 0.0);
    } else if (DEFERRED_DEBUG == DEBUG_GBUFFER_ERROR) {
        // Against a fresh ray cast with the full surface: normal angle (radians), position
        // error relative to the depth, and 1 where hit/material/side disagree.
        Hit hit;
        bool h = trace_closest(ray, hit);
        if (h != gs.hit) {
            L = vec3(0.0, 0.0, 1.0);
        } else if (!h) {
            L = vec3(0.0);
        } else {
            Surface s = surface_at(hit, ray);
            vec3 p = ray.o + gs.t * ray.d;
            float angle = 2.0 * asin(min(1.0, 0.5 * length(gs.n - s.ns)));
            bool same = s.material == gs.material && (dot(-ray.d, s.ng) > 0.0) == gs.front;
            L = vec3(angle, length(p - s.p) / max(gs.t, 1e-30), same ? 0.0 : 1.0);
        }
    } else if (DEFERRED_DEBUG == DEBUG_TILE_LIGHTS) {
        uint count = tile_counts[tile_slot(slice, tile_index)];
        uint reach = 0u;
        if (gs.hit) {
            vec3 p = ray.o + gs.t * ray.d;
            for (uint k = 0u; k < dp.n_cull; ++k) {
                vec3 wi, Li; float dist;
                if (light_incident(dlights[k], p, wi, dist, Li)) reach += 1u;
            }
        }
        L = vec3(count == TILE_OVERFLOW ? float(dp.n_cull) : float(count), float(reach),
                 count == TILE_OVERFLOW ? 1.0 : 0.0);
    }
    return L;
}

void main() {
    COUNT_CLOCK_START;
    uint lid = gl_LocalInvocationIndex;
    if (lid == 0u) { s_rays = 0u; s_dropped = 0u; s_tested = 0u; s_shaded = 0u; s_lit = 0u; }
    barrier();
    uvec2 px = gl_GlobalInvocationID.xy;
    bool inside = px.x < g.film.x && px.y < g.film.y;
    uint rays = 0u, dropped = 0u;
    uint tested = 0u, shaded = 0u, lit = 0u; // for the counters
    if (inside) {
        uint pixel = px.y * g.film.x + px.x;
        uint tile_index = gl_WorkGroupID.y * dp.tiles_x + gl_WorkGroupID.x;
        // The batch's samples in order, each added as its own dispatch would add it (the odd
        // half too), so the sums are those of one sample per dispatch, bit for bit.
        vec4 acc = accum[pixel];
        for (uint slice = 0u; slice < pc.spp; ++slice) {
            vec3 L = shade_sample(px, pixel, tile_index, slice, rays, tested, shaded, lit);
            film_add(acc, L, pc.sample_base + slice, dropped);
            film_odd_store(pixel);
        }
        accum[pixel] = acc;
    }
    // Step 7: counters, reduced per workgroup first.
    if (rays > 0u) atomicAdd(s_rays, rays);
    if (dropped > 0u) atomicAdd(s_dropped, dropped);
    if (tested > 0u) atomicAdd(s_tested, tested);
    if (shaded > 0u) atomicAdd(s_shaded, shaded);
    if (lit > 0u) atomicAdd(s_lit, lit);
    barrier();
    if (lid == 0u) {
        counter_add(0u, s_tested);
        counter_add(1u, s_shaded);
        counter_add(2u, s_lit);
        film_count(s_rays, s_dropped);
    }
}
