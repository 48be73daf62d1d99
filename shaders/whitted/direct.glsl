// `whitted`: deterministic direct lighting of a surface's local lobes. Every light is visited
// (no random pick): point and spot lights with one shadow ray (intensity / distance², spot
// falloff as Mitsuba), directional lights with one (irradiance), emissive triangles and spheres
// with WHITTED_AREA_SAMPLES shadow rays at a fixed Hammersley point set warped as nee's light
// sampling (common/lights.glsl): uniform by area on triangles, uniform in the subtended cone on
// spheres (uniform by area from inside). The same points for every pixel and sample, so the
// image has no noise but a fixed quadrature error (banded penumbrae). Environment lights are
// skipped: the environment enters as the ambient term (whitted.comp).
#ifndef WHITTED_DIRECT_GLSL
#define WHITTED_DIRECT_GLSL
#include "common/lights.glsl"
#include "common/surface.glsl"
#include "common/material.glsl"

#ifndef WHITTED_AREA_SAMPLES
#define WHITTED_AREA_SAMPLES 16u
#endif

// Van der Corput radical inverse in base 2.
float radical_inverse2(uint i) { return float(bitfieldReverse(i) >> 8) * (1.0 / 16777216.0); }

// Point j of the fixed N-point set in [0,1)²: Hammersley, both coordinates centred in their strata.
vec2 whitted_point(uint j, uint n) {
    float inv = 1.0 / float(n);
    return vec2((float(j) + 0.5) * inv, fract(radical_inverse2(j) + 0.5 * inv));
}

// Samples point u on area light l (triangle, with its normal nl_tri, or sphere) as seen from
// p_ref. Returns false when the point faces away or is degenerate. pdf: solid angle, without
// any pick probability.
bool whitted_area_sample(GpuLight l, vec3 nl_tri, vec3 p_ref, vec2 u, out vec3 pl, out vec3 wi,
                         out float dist, out float pdf) {
    pl = vec3(0.0); wi = vec3(0.0, 0.0, 1.0); dist = 0.0; pdf = 0.0;
    vec3 nl;
    if (l.kind == LIGHT_TRIANGLE) {
        vec2 b = sample_uniform_triangle(u);
        vec3 p0 = l.p0.xyz, p1 = l.p1.xyz, p2 = l.p2.xyz;
        pl = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
        nl = nl_tri;
        vec3 w = pl - p_ref;
        float dist2 = dot(w, w);
        if (!(dist2 > 0.0)) return false;
        dist = sqrt(dist2);
        wi = w / dist;
        float cosl = -dot(nl, wi);
        if (cosl <= 0.0 || emitter_cut(l, pl, b)) return false;  // front side only, no hole
        pdf = dist2 / (cosl * l.p0.w);
        return pdf > 0.0 && !isinf(pdf);
    }
    // Sphere: the only other area light (callers pass no other), so the generic kernel does not
    // test for it (a run-time test here cost that kernel 7.7% on an H200); a kernel without
    // spheres has none (light_is_sphere, common/types.glsl).
#ifndef HAS_SPHERES
    return false;
#endif
    vec3 c = l.p0.xyz;
    float r = l.p0.w;
    nl = sample_sphere_seen_from(c, r, p_ref, u, sphere_sampled_by_area(l, p_ref));
    pl = c + r * nl;
    vec3 w = pl - p_ref;
    float dist2 = dot(w, w);
    if (!(dist2 > 0.0)) return false;
    dist = sqrt(dist2);
    wi = w / dist;
    vec3 front = l.p1.x > 0.5 ? -nl : nl;
    if (dot(front, wi) >= 0.0 || emitter_cut(l, pl, vec2(0.0))) return false;
    pdf = sphere_light_pdf(l, p_ref, pl, nl);
    return pdf > 0.0 && !isinf(pdf);
}

// Radiance reflected towards wo_world by the local lobes `m` of surface s, from every light.
// An area light's shadow rays take their two possible origins and the triangle's normal from
// values computed once per light, not per ray (per light rather than per hit: fewer values live
// across the light loop; bench/RESULTS.md, "Whitted's shadow-ray origins").
vec3 whitted_direct(Surface s, in SurfaceParams m, vec3 wo_world, inout uint rays) {
    vec3 bt = cross(s.ns, s.tangent);
    vec3 wo = to_local(wo_world, s.tangent, bt, s.ns);
    vec3 L = vec3(0.0);
    uint n_lights = g.film.w;
    for (uint li = 0u; li < n_lights; ++li) {
        GpuLight l = lights[li];
        if (l.kind == LIGHT_TRIANGLE || light_is_sphere(l.kind)) {
            // Step 1: area lights: the fixed point set; a triangle does not light itself.
            if (l.kind == LIGHT_TRIANGLE && s.light == li) continue;
            vec3 sum = vec3(0.0);
            vec3 nl_tri = l.kind == LIGHT_TRIANGLE ? triangle_light_normal(l) : vec3(0.0);
            SurfaceOrigins origins = surface_origins(s);
            for (uint j = 0u; j < WHITTED_AREA_SAMPLES; ++j) {
                vec3 pl, wi_world;
                float dist, pdf;
                if (!whitted_area_sample(l, nl_tri, s.p, whitted_point(j, WHITTED_AREA_SAMPLES), pl, wi_world, dist, pdf)) continue;
                vec3 f = bsdf_eval(m, wo, to_local(wi_world, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
                if (!any(greaterThan(f, vec3(0.0)))) continue;
                rays += 1u;
                if (trace_any(shadow_ray_between(origin_towards(origins, s, pl - s.p), pl))) continue;
                sum += f * (1.0 / pdf);
            }
            L += sum * l.radiance.rgb * (1.0 / float(WHITTED_AREA_SAMPLES));
        }
#ifdef HAS_DELTA_LIGHTS
        else if (l.kind == LIGHT_POINT || l.kind == LIGHT_SPOT) {
            // Step 2: point and spot lights: intensity / distance², one shadow ray.
            vec3 w = l.p0.xyz - s.p;
            float dist2 = dot(w, w);
            if (!(dist2 > 0.0)) continue;
            vec3 wi_world = w * inversesqrt(dist2);
            float falloff = l.kind == LIGHT_SPOT ? spot_falloff(l, -dot(wi_world, l.p1.xyz)) : 1.0;
            if (!(falloff > 0.0)) continue;
            vec3 f = bsdf_eval(m, wo, to_local(wi_world, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
            if (!any(greaterThan(f, vec3(0.0)))) continue;
            rays += 1u;
            if (trace_any(spawn_ray_to(s, l.p0.xyz))) continue;
            L += f * l.radiance.rgb * (falloff / dist2);
        } else if (l.kind == LIGHT_DIRECTIONAL) {
            // Step 3: directional lights: irradiance, one shadow ray to infinity.
            vec3 wi_world = -l.p0.xyz;
            vec3 f = bsdf_eval(m, wo, to_local(wi_world, s.tangent, bt, s.ns), TRANSPORT_RADIANCE);
            if (!any(greaterThan(f, vec3(0.0)))) continue;
            rays += 1u;
            if (trace_any(spawn_ray(s, wi_world))) continue;
            L += f * l.radiance.rgb;
        }
#endif
    }
    return L;
}

#endif
