// Connection strategies of bdpt and their MIS weights, after pbrt-v3's ConnectBDPT and
// MISWeight (Veach 1997, ch. 10). A strategy (s, t) joins the first s light-subpath vertices to
// the first t camera-subpath vertices; the path has s + t − 1 segments.
//   s = 0: the camera subpath hits an emitter (area light front side, or the environment);
//   s = 1: a fresh light sample (NEE's sample_light, pick ∝ power) is joined to camera vertex t−1;
//   t = 1: light vertex s−1 is joined to a fresh lens point and splatted (light tracing);
//   else : light vertex s−1 and camera vertex t−1 are joined by a shadow ray.
// (1, 1) and t = 0 are not used (pbrt): the light seen directly is s = 0's alone.
// Weights: the power heuristic over every strategy that could have made the same path, from the
// ratios of the per-vertex densities; connections at specular vertices and strategies that would
// have to hit a delta light are not counted, and specular vertices' zero densities are read as 1
// (pbrt's remap0), so the discrete δ probabilities cancel. With mis off (BDPT_MIS 0) every such
// strategy gets the same weight. The sampled light point's density for s = 1 is NEE's own
// (nee_density_ratio), so the weights match how the path was really made.
#ifndef BDPT_CONNECT_GLSL
#define BDPT_CONNECT_GLSL
#include "bdpt/vertex.glsl"

// The density values that strategy (s, t) changes before the ratios are taken (pbrt's
// ScopedAssignments): reverse densities at p_{t−1}, p_{t−2}, q_{s−1}, q_{s−2}; the light endpoint
// as this strategy sees it (for s = 1, the fresh sample); and the NEE/emission ratio of x0.
struct MisInputs {
    float pt_rev, ptm_rev, qs_rev, qsm_rev;
    float l0_fwd;      // pdf_fwd of light vertex 0
    bool l0_delta;     // light vertex 0 is a delta light
    float nee_ratio;   // pNEE(x0 | x1) / pemit(x0)
};

float remap0(float f) { return f != 0.0 ? f : 1.0; }

// The term of strategy s_other (ratio ri = its density / the current strategy's, emission's x0
// density throughout) in the weight's denominator.
float mis_term(float ri, int s_other, int s, float nee_ratio) {
    if (s_other == 1) ri *= nee_ratio;
    if (s == 1) ri /= nee_ratio;
#if BDPT_MIS
    return ri * ri;
#else
    return 1.0;
#endif
}

// Weight of strategy (s, t) for the current subpaths (pbrt-v3 MISWeight).
float mis_weight(int s, int t, MisInputs mi) {
    if (s + t == 2) return 1.0;
    float sum_ri = 0.0;
    // Step 1: hypothetical strategies with fewer camera vertices (i = their t).
    float ri = 1.0;
    for (int i = t - 1; i > 0; --i) {
        Vertex c = vtx[CAM(i)];
        float rev = i == t - 1 ? mi.pt_rev : (i == t - 2 ? mi.ptm_rev : c.pdf_rev);
        ri *= remap0(rev) / remap0(c.pdf_fwd);
        bool delta = i == t - 1 ? false : vertex_is_delta(c);
        if (!delta && !vertex_is_delta(vtx[CAM(i - 1)])) sum_ri += mis_term(ri, s + t - i, s, mi.nee_ratio);
    }
    // Step 2: hypothetical strategies with fewer light vertices (i = their s).
    ri = 1.0;
    for (int i = s - 1; i >= 0; --i) {
        Vertex l = vtx[LGT(i)];
        float fwd = i == 0 ? mi.l0_fwd : l.pdf_fwd;
        float rev = i == s - 1 ? mi.qs_rev : (i == s - 2 ? mi.qsm_rev : l.pdf_rev);
        ri *= remap0(rev) / remap0(fwd);
        bool delta = i == s - 1 ? false : vertex_is_delta(l);
        bool delta_light = i > 0 ? vertex_is_delta(vtx[LGT(i - 1)]) : mi.l0_delta;
        if (!delta && !delta_light) sum_ri += mis_term(ri, i, s, mi.nee_ratio);
    }
    return 1.0 / (1.0 + sum_ri);
}

MisInputs mis_inputs_default() {
    Vertex l0 = vtx[LGT(0)];
    return MisInputs(0.0, 0.0, 0.0, 0.0, l0.pdf_fwd, (l0.flags & VF_DELTA_LIGHT) != 0u, 1.0);
}

// s = 0: camera vertex t−1 is an emitter. Returns β·Le (unweighted) and the weight.
vec3 connect_s0(int t, out float w) {
    w = 0.0;
    Vertex pt = vtx[CAM(t - 1)], ptm = vtx[CAM(t - 2)];
    vec3 Le = vec3(0.0);
    if (pt.kind == VTX_INF) {
        Le = env_eval(pt.p);
    } else if (pt.kind == VTX_SURFACE && pt.light != NONE && dot(pt.wo, pt.ng) > 0.0) {
        Le = materials[pt.material].emission.rgb;
    }
    vec3 L = pt.beta * Le;
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    MisInputs mi = mis_inputs_default();
    mi.pt_rev = pdf_light_origin(pt);
    if (t >= 3) {
        mi.ptm_rev = pdf_light(pt, ptm);
        mi.nee_ratio = nee_density_ratio(pt, ptm);
    }
    w = mis_weight(0, t, mi);
    return L;
}

// s = 1: a fresh light sample joined to camera vertex t−1 (t ≥ 2).
vec3 connect_s1(int t, vec3 u, inout uint rays, out float w) {
    w = 0.0;
    Vertex pt = vtx[CAM(t - 1)];
    if (pt.kind != VTX_SURFACE) return vec3(0.0);
    SurfaceParams mp = resolve_material(pt.material, pt.uv);
    if (bsdf_is_delta(mp)) return vec3(0.0);
    // Step 1: sample a light point as NEE does (the same u picks the same light).
    LightSample ls;
    if (!sample_light(pt.p, u, ls) || !any(greaterThan(ls.L, vec3(0.0)))) return vec3(0.0);
    uint li = pick_light(u.x);
    vec3 f = bsdf_eval(mp, vertex_to_local(pt, pt.wo), vertex_to_local(pt, ls.wi), TRANSPORT_RADIANCE);
    vec3 L = pt.beta * f * ls.L / ls.pdf;
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // Step 2: the sampled light as a vertex, for the densities.
    bool infinite = isinf(ls.dist);
    Vertex q = vertex_blank(infinite ? VTX_INF : VTX_LIGHT);
    q.p = infinite ? ls.wi : ls.p;
    q.light = li;
    GpuLight gl = lights[li];
    if (gl.kind == LIGHT_TRIANGLE || gl.kind == LIGHT_SPHERE) q.ng = light_front_normal(gl, ls.p);
    q.flags = ls.delta ? VF_DELTA_LIGHT : 0u;
    // Step 3: visibility.
    Surface sp = vertex_surface(pt);
    Ray shadow = infinite ? spawn_ray(sp, ls.wi) : spawn_ray_to(sp, ls.p);
    rays += 1u;
    if (trace_any(shadow)) return vec3(0.0);
    // Step 4: the weight.
    MisInputs mi = mis_inputs_default();
    mi.l0_fwd = pdf_light_origin(q);
    mi.l0_delta = ls.delta;
    mi.pt_rev = pdf_light(q, pt);
    mi.qs_rev = pdf_surface(pt, mp, pt.wo, q);
    if (t >= 3) mi.ptm_rev = pdf_surface(pt, mp, ls.wi, vtx[CAM(t - 2)]);
    mi.nee_ratio = nee_density_ratio(q, pt);
    w = mis_weight(1, t, mi);
    return L;
}

// t = 1: light vertex s−1 (s ≥ 2) joined to a fresh lens point. Returns the contribution
// before the pixel filter (the caller splats it), the film position and the weight.
vec3 connect_t1(int s, vec2 u, inout uint rays, out vec2 film, out float w) {
    w = 0.0;
    film = vec2(-1.0);
    Vertex qs = vtx[LGT(s - 1)];
    if (qs.kind != VTX_SURFACE) return vec3(0.0);
    SurfaceParams mq = resolve_material(qs.material, qs.uv);
    if (bsdf_is_delta(mq)) return vec3(0.0);
    // Step 1: the lens point and where on the film the connection lands.
    vec3 pl = camera_sample_lens(u);
    vec3 d = pl - qs.p;
    float d2 = dot(d, d);
    if (!(d2 > 0.0)) return vec3(0.0);
    vec3 wi = d * inversesqrt(d2); // from qs towards the lens
    float cos_theta;
    if (!camera_film_position(pl, -wi, film, cos_theta)) return vec3(0.0);
    vec3 f = bsdf_eval(mq, vertex_to_local(qs, qs.wo), vertex_to_local(qs, wi), TRANSPORT_IMPORTANCE)
             * shading_correction(qs, qs.wo, wi);
    vec3 L = qs.beta * f * camera_connection_we(cos_theta, d2);
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // Step 2: visibility.
    rays += 1u;
    if (trace_any(spawn_ray_to(vertex_surface(qs), pl))) return vec3(0.0);
    // Step 3: the weight; the camera's density at qs is Pdf_We's, converted to area.
    MisInputs mi = mis_inputs_default();
    Vertex c = vertex_blank(VTX_CAMERA);
    c.p = pl;
    mi.qs_rev = convert_density(camera_pdf_dir(cos_theta), c, qs);
    mi.qsm_rev = pdf_surface(qs, mq, wi, vtx[LGT(s - 2)]);
    mi.nee_ratio = nee_density_ratio(vtx[LGT(0)], vtx[LGT(1)]);
    w = mis_weight(s, 1, mi);
    return L;
}

// s ≥ 2, t ≥ 2: light vertex s−1 joined to camera vertex t−1.
vec3 connect_st(int s, int t, inout uint rays, out float w) {
    w = 0.0;
    Vertex qs = vtx[LGT(s - 1)], pt = vtx[CAM(t - 1)];
    if (qs.kind != VTX_SURFACE || pt.kind != VTX_SURFACE) return vec3(0.0);
    SurfaceParams mq = resolve_material(qs.material, qs.uv);
    SurfaceParams mp = resolve_material(pt.material, pt.uv);
    if (bsdf_is_delta(mq) || bsdf_is_delta(mp)) return vec3(0.0);
    // Step 1: both BSDFs (with their shading-normal cosines) and 1/d² for the geometry term.
    vec3 d = qs.p - pt.p;
    float d2 = dot(d, d);
    if (!(d2 > 0.0)) return vec3(0.0);
    d *= inversesqrt(d2); // from pt towards qs
    vec3 fq = bsdf_eval(mq, vertex_to_local(qs, qs.wo), vertex_to_local(qs, -d), TRANSPORT_IMPORTANCE)
              * shading_correction(qs, qs.wo, -d);
    vec3 fp = bsdf_eval(mp, vertex_to_local(pt, pt.wo), vertex_to_local(pt, d), TRANSPORT_RADIANCE);
    vec3 L = qs.beta * fq * fp * pt.beta / d2;
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // Step 2: visibility.
    rays += 1u;
    if (trace_any(spawn_ray_to(vertex_surface(pt), qs.p))) return vec3(0.0);
    // Step 3: the weight.
    MisInputs mi = mis_inputs_default();
    mi.pt_rev = pdf_surface(qs, mq, qs.wo, pt);
    if (t >= 3) mi.ptm_rev = pdf_surface(pt, mp, d, vtx[CAM(t - 2)]);
    mi.qs_rev = pdf_surface(pt, mp, pt.wo, qs);
    mi.qsm_rev = pdf_surface(qs, mq, -d, vtx[LGT(s - 2)]);
    mi.nee_ratio = nee_density_ratio(vtx[LGT(0)], vtx[LGT(1)]);
    w = mis_weight(s, t, mi);
    return L;
}

#endif
