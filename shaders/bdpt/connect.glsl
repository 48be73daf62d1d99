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
// (pbrt's remap0), so the discrete δ probabilities cancel. With mis off (bdpt_mis false) every such
// strategy gets the same weight. The sampled light point's density for s = 1 is NEE's own
// (nee_density_ratio), so the weights match how the path was really made.
#ifndef BDPT_CONNECT_GLSL
#define BDPT_CONNECT_GLSL
#include "bdpt/paths.glsl"

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

// Power heuristic (true) or uniform weights (false: the `mis` option off); set by main.
bool bdpt_mis = true;

// The term of strategy s_other (ratio ri = its density / the current strategy's, emission's x0
// density throughout) in the weight's denominator.
float mis_term(float ri, int s_other, int s, float nee_ratio) {
    if (s_other == 1) ri *= nee_ratio;
    if (s == 1) ri /= nee_ratio;
    return bdpt_mis ? ri * ri : 1.0;
}

// Weight of strategy (s, t) for the current subpaths (pbrt-v3 MISWeight).
float mis_weight(int s, int t, MisInputs mi) {
    if (s + t == 2) return 1.0;
    float sum_ri = 0.0;
    // Step 1: hypothetical strategies with fewer camera vertices (i = their t).
    float ri = 1.0;
    for (int i = t - 1; i > 0; --i) {
        Vertex c = CAMV(i);
        float rev = i == t - 1 ? mi.pt_rev : (i == t - 2 ? mi.ptm_rev : c.pdf_rev);
        ri *= remap0(rev) / remap0(c.pdf_fwd);
        bool delta = i == t - 1 ? false : vertex_is_delta(c);
        if (!delta && !vertex_is_delta(CAMV(i - 1))) sum_ri += mis_term(ri, s + t - i, s, mi.nee_ratio);
    }
    // Step 2: hypothetical strategies with fewer light vertices (i = their s).
    ri = 1.0;
    for (int i = s - 1; i >= 0; --i) {
        Vertex l = LGTV(i);
        float fwd = i == 0 ? mi.l0_fwd : l.pdf_fwd;
        float rev = i == s - 1 ? mi.qs_rev : (i == s - 2 ? mi.qsm_rev : l.pdf_rev);
        ri *= remap0(rev) / remap0(fwd);
        bool delta = i == s - 1 ? false : vertex_is_delta(l);
        bool delta_light = i > 0 ? vertex_is_delta(LGTV(i - 1)) : mi.l0_delta;
        if (!delta && !delta_light) sum_ri += mis_term(ri, i, s, mi.nee_ratio);
    }
    return 1.0 / (1.0 + sum_ri);
}

// s = 0: camera vertex t−1 is an emitter. Returns β·Le and sets the densities it changes.
vec3 connect_s0(int t, inout MisInputs mi) {
    Vertex pt = CAMV(t - 1), ptm = CAMV(t - 2);
    vec3 Le = vec3(0.0);
    if (pt.kind == VTX_INF) {
        Le = env_eval(pt.p);
    } else if (pt.kind == VTX_SURFACE && pt.light != NONE && dot(pt.wo, pt.ng) > 0.0) {
        Le = materials[pt.material].emission.rgb;
    }
    vec3 L = pt.beta * Le;
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    mi.pt_rev = pdf_light_origin(pt);
    if (t >= 3) mi.ptm_rev = pdf_light(pt, ptm);
    return L;
}

// s ≥ 1, t ≥ 1: light vertex s−1 (for s = 1, a fresh light sample drawn as NEE draws it, with
// u.xyz) joined to camera vertex t−1 (for t = 1, a fresh lens point, with u.zw). Returns the
// unweighted contribution and sets the densities it changes; for t = 1 the contribution is
// before the pixel filter and `film` says where it lands (the caller splats it). Both ends go
// through one loop, so the BSDF code is inlined once.
vec3 connect_st(int s, int t, vec4 u, inout uint rays, out vec2 film, inout MisInputs mi, out Vertex q) {
    film = vec2(-1.0);
    // Step 1: the two ends (0: light side q, 1: camera side p) and their own predecessors.
    Vertex ends[2], preds[2];
    ends[1] = CAMV(t - 1);
    // Escaped camera rays (infinite-light vertices) only count for s = 0 (pbrt).
    if (t >= 2 && ends[1].kind != VTX_SURFACE) return vec3(0.0);
    preds[1] = CAMV(max(t - 2, 0));
    preds[0] = LGTV(max(s - 2, 0));
    vec3 weight_q = vec3(0.0), weight_p = vec3(0.0); // β·f at each end, or the sampled end's weight
    float cos_theta = 0.0, ls_pdf = 0.0;
    LightSample ls;
    if (s == 1) {
        // A fresh light point, chosen from camera vertex t−1 as NEE does.
        if (!sample_light(ends[1].p, u.xyz, ls) || !any(greaterThan(ls.L, vec3(0.0)))) return vec3(0.0);
        uint li = pick_light(u.x); // the light sample_light picked with the same u
        bool infinite = isinf(ls.dist);
        Vertex q = vertex_blank(infinite ? VTX_INF : VTX_LIGHT);
        q.p = infinite ? ls.wi : ls.p;
        q.light = li;
        GpuLight gl = lights[li];
        if (gl.kind == LIGHT_TRIANGLE || gl.kind == LIGHT_SPHERE) q.ng = light_front_normal(gl, ls.p);
        q.flags = ls.delta ? VF_DELTA_LIGHT : 0u;
        ends[0] = q;
        weight_q = ls.L / ls.pdf;
    } else {
        ends[0] = LGTV(s - 1);
    }
    if (t == 1) {
        // A fresh lens point, and where the connection lands on the film.
        if (ends[0].kind != VTX_SURFACE) return vec3(0.0);
        Vertex c = vertex_blank(VTX_CAMERA);
        c.p = camera_sample_lens(u.zw);
        vec3 d = c.p - ends[0].p;
        float d2 = dot(d, d);
        if (!(d2 > 0.0)) return vec3(0.0);
        if (!camera_film_position(c.p, -d * inversesqrt(d2), film, cos_theta)) return vec3(0.0);
        ends[1] = c;
        weight_p = vec3(camera_connection_we(cos_theta, d2));
    }
    // Step 2: at each surface end, the BSDF towards the other end (importance on the light side,
    // with the shading-normal correction) and the densities of sampling the other end and, in
    // reverse, its own predecessor. Sampled ends give their densities from the light or camera.
    float rev_other[2], rev_pred[2];
    rev_other[0] = 0.0; rev_other[1] = 0.0; rev_pred[0] = 0.0; rev_pred[1] = 0.0;
    for (int e = 0; e < 2; ++e) {
        Vertex v = ends[e], other = ends[1 - e];
        if (v.kind == VTX_SURFACE) {
            SurfaceParams m = resolve_material(v.material, v.uv);
            if (bsdf_is_delta(m)) return vec3(0.0);
            vec3 wn = vertex_dir(v, other);
            uint mode = e == 0 ? TRANSPORT_IMPORTANCE : TRANSPORT_RADIANCE;
            vec3 f = bsdf_eval(m, vertex_to_local(v, v.wo), vertex_to_local(v, wn), mode);
            if (e == 0) f *= shading_correction(v, v.wo, wn);
            if (!any(greaterThan(f, vec3(0.0)))) return vec3(0.0);
            vec3 wf = v.beta * f;
            if (e == 0) weight_q = wf; else weight_p = wf;
            // Densities towards the other end and back to the predecessor, through one call
            // site; the camera-side predecessor counts only beyond the lens (t ≥ 3).
            bool need_pred = e == 0 ? s >= 2 : t >= 3;
            for (int j = 0; j < (need_pred ? 2 : 1); ++j) {
                float pdf = pdf_surface(v, m, j == 0 ? v.wo : wn, j == 0 ? other : preds[e]);
                if (j == 0) rev_other[e] = pdf; else rev_pred[e] = pdf;
            }
        } else if (v.kind == VTX_CAMERA) {
            rev_other[e] = convert_density(camera_pdf_dir(cos_theta), v, other);
        } else {
            rev_other[e] = pdf_light(v, other);
        }
    }
    // Step 3: the contribution; 1/d² only between two subpath vertices (the sampled ends' weights
    // already hold theirs).
    vec3 L = weight_q * weight_p;
    if (s >= 2 && t >= 2) {
        vec3 d = ends[0].p - ends[1].p;
        L /= dot(d, d);
    }
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // Step 4: visibility, from the camera end when it is a surface.
    Ray shadow;
    if (t == 1) {
        shadow = spawn_ray_to(vertex_surface(ends[0]), ends[1].p);
    } else if (s == 1 && isinf(ls.dist)) {
        shadow = spawn_ray(vertex_surface(ends[1]), ls.wi);
    } else {
        shadow = spawn_ray_to(vertex_surface(ends[1]), ends[0].p);
    }
    rays += 1u;
    if (trace_any(shadow)) return vec3(0.0);
    // Step 5: the densities this strategy changes.
    q = ends[0];
    if (s == 1) {
        mi.l0_fwd = pdf_light_origin(ends[0]);
        mi.l0_delta = ls.delta;
    }
    mi.pt_rev = rev_other[0];
    mi.qs_rev = rev_other[1];
    mi.qsm_rev = rev_pred[0];
    mi.ptm_rev = rev_pred[1];
    return L;
}

// Strategy (s, t): the unweighted contribution and its weight w (see connect_s0, connect_st).
vec3 connect(int s, int t, vec4 u, inout uint rays, out vec2 film, out float w) {
    w = 0.0;
    film = vec2(-1.0);
    Vertex l0 = LGTV(0);
    MisInputs mi = MisInputs(0.0, 0.0, 0.0, 0.0, l0.pdf_fwd, (l0.flags & VF_DELTA_LIGHT) != 0u, 1.0);
    Vertex q;
    vec3 L = s == 0 ? connect_s0(t, mi) : connect_st(s, t, u, rays, film, mi, q);
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // x0 (the light end) and x1 (its neighbour), for NEE's density of x0 (sphere lights).
    Vertex x0 = l0, x1 = LGTV(1);
    if (s == 0) {
        x0 = CAMV(t - 1);
        x1 = CAMV(max(t - 2, 0));
    } else if (s == 1) {
        x0 = q;
        x1 = CAMV(t - 1);
    }
    mi.nee_ratio = nee_density_ratio(x0, x1);
    w = mis_weight(s, t, mi);
    return L;
}

#endif
