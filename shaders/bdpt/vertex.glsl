// Path vertices of bdpt and the densities between them, after pbrt-v3's `Vertex`
// (integrators/bdpt.h): each vertex keeps its throughput β and the area densities of being
// sampled from either side — pdf_fwd along its own subpath, pdf_rev from the other direction —
// which the MIS weights (connect.glsl) turn into the ratios of Veach's technique densities, and
// a running sum of those ratios along its subpath (mis_acc) so that a weight costs O(1).
// Conventions: densities are per unit area at the receiving vertex, except towards an infinite
// light, where they are per unit solid angle; after an infinite light the first vertex's density
// is planar (the bounding disk's 1/(πR²) times |cos|); specular vertices store 0 (pbrt's
// remap0 then reads them as 1, so the δ factors cancel in every ratio).
#ifndef BDPT_VERTEX_GLSL
#define BDPT_VERTEX_GLSL
#include "common/bindings.glsl"
#include "common/math.glsl"
#include "common/surface.glsl"
#include "common/material.glsl"
#include "common/lights.glsl"
#include "common/light_emit.glsl"
#include "common/camera_we.glsl"

#define VTX_CAMERA 0u   // the lens point
#define VTX_LIGHT 1u    // a point on a light (area, point, spot): a light subpath's start or an NEE sample
#define VTX_INF 2u      // an infinite light (environment, directional): p is the unit direction towards it
#define VTX_SURFACE 3u  // a surface hit (may be emissive: light != NONE)

#define VF_DELTA 1u        // the BSDF sample taken here was a delta lobe
#define VF_DELTA_LIGHT 2u  // point, spot or directional light (no strategy can hit it)

struct Vertex {
    vec3 p; uint kind;
    vec3 ng; uint flags;     // ng: geometric (front) normal; 0 where the vertex is not on a surface
    vec3 ns; uint material;
    vec3 tangent; uint light;
    vec3 p_err; float pdf_fwd;
    vec3 wo; float pdf_rev;  // wo: unit direction towards the previous vertex of its own subpath
    vec3 beta; float mis_acc; // mis_acc: the running sum of the MIS weights' unchanged terms (connect.glsl)
    vec2 uv;
};

// Capacity: camera subpaths have up to max_depth + 1 vertices, light subpaths max_depth.
#define BDPT_MAX_CAM (BDPT_DEPTH_CAP + 1)
#define BDPT_MAX_LIGHT (BDPT_DEPTH_CAP < 2 ? 2 : BDPT_DEPTH_CAP) // ≥ 2: LGT(1) is always addressable

Vertex vertex_blank(uint kind) {
    Vertex v;
    v.p = vec3(0.0); v.kind = kind; v.ng = vec3(0.0); v.flags = 0u; v.ns = vec3(0.0);
    v.material = NONE; v.tangent = vec3(1.0, 0.0, 0.0); v.light = NONE; v.p_err = vec3(0.0);
    v.pdf_fwd = 0.0; v.wo = vec3(0.0); v.pdf_rev = 0.0; v.beta = vec3(0.0); v.mis_acc = 0.0; v.uv = vec2(0.0);
    return v;
}

bool vertex_is_delta(Vertex v) { return (v.flags & VF_DELTA) != 0u; }
bool vertex_on_surface(Vertex v) { return dot(v.ng, v.ng) > 0.0; }
// pbrt's IsLight: a light vertex, or a surface with an area light.
bool vertex_is_light(Vertex v) { return v.kind == VTX_LIGHT || v.kind == VTX_INF || (v.kind == VTX_SURFACE && v.light != NONE); }

Surface vertex_surface(Vertex v) {
    Surface s;
    s.p = v.p; s.p_err = v.p_err; s.ng = v.ng; s.ns = v.ns; s.tangent = v.tangent;
    s.uv = v.uv; s.material = v.material; s.light = v.light;
    return s;
}

vec3 vertex_to_local(Vertex v, vec3 w) { return to_local(w, v.tangent, cross(v.ns, v.tangent), v.ns); }

// Unit direction from a to b (either may be at infinity).
vec3 vertex_dir(Vertex a, Vertex b) {
    if (b.kind == VTX_INF) return b.p;
    if (a.kind == VTX_INF) return -a.p;
    return normalize(b.p - a.p);
}

// pbrt's ConvertDensity: a solid-angle density at `from` towards `to` as an area density at `to`
// (solid angle when `to` is at infinity).
float convert_density(float pdf, Vertex from, Vertex to) {
    if (to.kind == VTX_INF) return pdf;
    vec3 w = to.p - from.p;
    float d2 = dot(w, w);
    if (!(d2 > 0.0)) return 0.0;
    if (vertex_on_surface(to)) pdf *= abs(dot(to.ng, w)) * inversesqrt(d2);
    return pdf / d2;
}

// Adjoint shading-normal factor for importance transport (Veach 1997 §5.3; pbrt-v3's
// CorrectShadingNormal): |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|).
float shading_correction(Vertex v, vec3 wo, vec3 wi) {
    float den = abs(dot(wo, v.ng)) * abs(dot(wi, v.ns));
    return den > 0.0 ? abs(dot(wo, v.ns)) * abs(dot(wi, v.ng)) / den : 0.0;
}

// pbrt's PdfLight: area density at `to` of light vertex l emitting towards it (an infinite
// light: the bounding disk's planar density times |cos| at `to`).
float pdf_light(Vertex l, Vertex to) {
    if (l.kind == VTX_INF) {
        float pdf = 1.0 / (PI * sqr(g.scene_sphere.w));
        if (vertex_on_surface(to)) pdf *= abs(dot(to.ng, l.p));
        return pdf;
    }
    vec3 w = to.p - l.p;
    float d2 = dot(w, w);
    if (!(d2 > 0.0)) return 0.0;
    w *= inversesqrt(d2);
    float pdf = light_pdf_dir(l.light, l.ng, w) / d2;
    if (vertex_on_surface(to)) pdf *= abs(dot(to.ng, w));
    return pdf;
}

// env_pdf with emission's pick (∝ power: light subpaths start there, light_emit.glsl) in place
// of NEE's (the light BVH's under LIGHT_BVH).
float env_pdf_emit(vec3 d) {
    uint li = ENV_LIGHT;
    if (li == NONE) return 0.0;
    float nee_pick = light_pick_pmf(li, vec3(0.0), vec3(0.0));
    return nee_pick > 0.0 ? env_pdf(d) / nee_pick * lights[li].pick_pdf : 0.0;
}

// pbrt's PdfLightOrigin: density of light vertex l as the start of a light subpath, pick
// included (area lights: per unit area; infinite lights: per unit solid angle of the direction
// towards them; delta positions: the pick probability).
float pdf_light_origin(Vertex l) {
    if (l.kind == VTX_INF) return env_pdf_emit(l.p);
    return lights[l.light].pick_pdf * light_pdf_pos(l.light);
}

// pbrt's Vertex::Pdf for a surface vertex v with material m: density at `next` of sampling the
// BSDF towards it, having arrived from direction w_prev.
float pdf_surface(Vertex v, SurfaceParams m, vec3 w_prev, Vertex next) {
    vec3 wn = vertex_dir(v, next);
    float pdf = bsdf_pdf(m, vertex_to_local(v, w_prev), vertex_to_local(v, wn));
    return convert_density(pdf, v, next);
}

// NEE and emission choose a light's point with different densities: NEE picks the light by the
// light BVH from the shading point under LIGHT_BVH (emission ∝ power), and samples a sphere's
// visible cone (emission its whole area). MIS weights use emission's density for x0 in every
// strategy but s = 1, whose weight this ratio pNEE(x0 | x1) / pemit(x0) corrects: the pick
// ratio, times for spheres the point densities' ratio (1 with the power pick for triangles,
// delta and infinite lights).
float nee_density_ratio(Vertex x0, Vertex x1) {
    if (x1.kind != VTX_SURFACE) return 1.0;
    uint li = x0.light != NONE ? x0.light : (x0.kind == VTX_INF ? ENV_LIGHT : NONE);
    if (li == NONE) return 1.0;
    GpuLight l = lights[li];
    float r = light_pick_pmf(li, x1.p, x1.ns) / l.pick_pdf;
    if (x0.kind != VTX_INF && light_is_sphere(l.kind)) {
        vec3 w = x0.p - x1.p;
        float d2 = dot(w, w);
        float cosl = abs(dot(x0.ng, w)) * inversesqrt(max(d2, 1e-38));
        // light_pdf_hit includes NEE's pick probability, and pemit = pick / area.
        r = light_pdf_hit(li, x1.p, x1.ns, x0.p, x0.ng) * cosl / d2 * light_area(l) / l.pick_pdf;
    }
    return (r > 0.0 && !isinf(r) && !isnan(r)) ? r : 1.0;
}

#endif
