// Connection strategies of bdpt and their MIS weights, after pbrt-v3's ConnectBDPT and
// MISWeight (Veach 1997, ch. 10). A strategy (s, t) joins the first s light-subpath vertices to
// the first t camera-subpath vertices; the path has s + t − 1 segments.
//   s = 0: the camera subpath hits an emitter (area light front side, or the environment);
//   s = 1: a fresh light sample (NEE's sample_light: pick ∝ power, or by the light BVH from
//          camera vertex t−1 under LIGHT_BVH) is joined to camera vertex t−1;
//   t = 1: light vertex s−1 is joined to a fresh lens point and splatted (light tracing);
//   else : light vertex s−1 and camera vertex t−1 are joined by a shadow ray.
// (1, 1) and t = 0 are not used (pbrt): the light seen directly is s = 0's alone.
// Weights: the power heuristic over every strategy that could have made the same path, from the
// ratios of the per-vertex densities; connections at specular vertices and strategies that would
// have to hit a delta light are not counted, and specular vertices' zero densities are read as 1
// (pbrt's remap0), so the discrete δ probabilities cancel. With mis off (bdpt_mis false) every such
// strategy gets the same weight. The sampled light point's density for s = 1 is NEE's own
// (nee_density_ratio: its pick, the light BVH's under LIGHT_BVH, and for spheres its cone), so
// the weights match how the path was really made.
#ifndef BDPT_CONNECT_GLSL
#define BDPT_CONNECT_GLSL
#include "bdpt/paths.glsl"

// Whether this kernel evaluates light tracing (t = 1): not the split design's camera pass, whose
// strategies are t ≥ 2 (light.comp has t = 1), so that its kernel compiles no lens sampling and
// no splats: code it never ran, which cost bdpt 3.8–8.3% on an H200 (bench/RESULTS.md, "bdpt's
// splats").
#ifdef BDPT_CAMERA_PASS
#define BDPT_HAS_T1 false
#else
#define BDPT_HAS_T1 true
#endif
// Likewise whether it evaluates s = 0 and s = 1: not the light pass, whose strategies are
// (s ≥ 2, t = 1), so that its kernel compiles no emission lookups and no light sampling.
#ifdef BDPT_LIGHT_PASS
#define BDPT_HAS_S01 false
#else
#define BDPT_HAS_S01 true
#endif

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
    if (BDPT_HAS_S01 && s == 1) ri /= nee_ratio;
    return bdpt_mis ? ri * ri : 1.0;
}

// A ratio's term without the NEE corrections: ri² (power heuristic), or 1 (mis off).
float mis_sq(float ri) { return bdpt_mis ? ri * ri : 1.0; }

// The running sums that make a weight O(1) (the idea of SmallVCM's recursive weights, in pbrt's
// densities). A strategy changes the densities of at most two vertices at each end (MisInputs);
// below them the ratios and the delta tests are the subpath's own. So the terms of every
// hypothetical strategy that moves the join further than two vertices down one subpath are the
// product of the two changed ratios with a sum fixed per subpath, kept at each vertex:
//   camera, m ≥ 1:  A_m = sq(R_m) · (valid_m · e_m + A_{m−1}),  A_0 = 0,
//                   R_m = pdf_rev(c_m) / pdf_fwd(c_m), valid_m = neither c_m nor c_{m−1} is δ,
//                   e_1 = sq(1/K) (the t = 1 term: light tracing has 1/K light subpaths per
//                   camera sample when K pixels share one, paths.glsl), e = 1 elsewhere;
//   light, m ≥ 0:   B_m = sq(R_m) · (valid_m · f_m + B_{m−1}),  B_{−1} = 0,
//                   R_m = pdf_rev(l_m) / pdf_fwd(l_m), valid_m = l_m not δ and l_{m−1} not δ
//                   (m = 0: not a delta light), f_1 = nee_ratio² (the s = 1 term sees NEE's
//                   density of x0, nee_density_ratio(l_0, l_1); f = 1 elsewhere and with mis off).
// (densities through remap0; sq as mis_sq.) Written into mis_acc of the vertices this kernel
// traced, once per sample, before any strategy; the split design's light pass stores them with
// the light vertices.
void mis_running_sums(int nc, int nl, float nee_ratio_light) {
#ifndef BDPT_LIGHT_PASS
    float a = 0.0;
    float e1 = mis_sq(1.0 / bdpt_share());
    for (int m = 1; m < nc; ++m) {
        Vertex c = vtx[CAM(m)];
        float valid = vertex_is_delta(c) || vertex_is_delta(vtx[CAM(m - 1)]) ? 0.0 : 1.0;
        a = mis_sq(remap0(c.pdf_rev) / remap0(c.pdf_fwd)) * (valid * (m == 1 ? e1 : 1.0) + a);
        vtx[CAM(m)].mis_acc = a;
    }
#endif
#ifndef BDPT_CAMERA_PASS
    float b = 0.0;
    for (int m = 0; m < nl; ++m) {
        Vertex l = vtx[LGT(m)];
        bool before_delta = m == 0 ? (l.flags & VF_DELTA_LIGHT) != 0u : vertex_is_delta(vtx[LGT(max(m - 1, 0))]);
        float valid = vertex_is_delta(l) || before_delta ? 0.0 : 1.0;
        float f = m == 1 ? mis_sq(nee_ratio_light) : 1.0;
        b = mis_sq(remap0(l.pdf_rev) / remap0(l.pdf_fwd)) * (valid * f + b);
        vtx[LGT(m)].mis_acc = b;
    }
#endif
}

// Weight of strategy (s, t) for the current subpaths (pbrt-v3 MISWeight): the terms of the two
// vertices at each end that the strategy changes one by one, the rest from the running sums.
// Light tracing's density counts 1/K times when K pixels share a light subpath (paths.glsl):
// the term of a hypothetical t = 1 strategy by sq(1/K), every other term of t = 1's own weight
// by sq(K).
float mis_weight(int s, int t, MisInputs mi) {
    if (s + t == 2) return 1.0;
    float sum_ri = 0.0;
    // Step 1: hypothetical strategies with fewer camera vertices (i = their t): i = t−1, t−2,
    // then every i ≤ t−3 at once (s_other ≥ 3 there, so only s = 1's correction applies).
    float ri = 1.0;
    for (int i = t - 1; i > 0 && i >= t - 2; --i) {
        Vertex c = CAMV(i);
        float rev = i == t - 1 ? mi.pt_rev : mi.ptm_rev;
        ri *= remap0(rev) / remap0(c.pdf_fwd);
        bool delta = i == t - 1 ? false : vertex_is_delta(c);
        if (!delta && !vertex_is_delta(CAMV(i - 1))) {
            sum_ri += mis_term(ri, s + t - i, s, mi.nee_ratio) * (i == 1 ? mis_sq(1.0 / bdpt_share()) : 1.0);
        }
    }
    if (t >= 4) {
        // (Both factors checked: a product of 0 and inf is no term, as in the walk.)
        float x = mis_term(ri, 3, s, mi.nee_ratio), acc = CAMV(t - 3).mis_acc;
        if (x > 0.0 && acc > 0.0) sum_ri += x * acc;
    }
    // Step 2: hypothetical strategies with fewer light vertices (i = their s): i = s−1, s−2,
    // then every i ≤ s−3 at once (s ≥ 3 there, so the running sum holds the s = 1 correction).
    ri = 1.0;
    for (int i = s - 1; i >= 0 && i >= s - 2; --i) {
        Vertex l = LGTV(i);
        float fwd = i == 0 ? mi.l0_fwd : l.pdf_fwd;
        float rev = i == s - 1 ? mi.qs_rev : mi.qsm_rev;
        ri *= remap0(rev) / remap0(fwd);
        bool delta = i == s - 1 ? false : vertex_is_delta(l);
        bool delta_light = i > 0 ? vertex_is_delta(LGTV(i - 1)) : mi.l0_delta;
        if (!delta && !delta_light) sum_ri += mis_term(ri, i, s, mi.nee_ratio);
    }
    if (s >= 3) {
        float x = mis_sq(ri), acc = LGTV(s - 3).mis_acc;
        if (x > 0.0 && acc > 0.0) sum_ri += x * acc;
    }
    // (t = 1 has no camera-side terms: every term above is of a strategy with t ≥ 2.)
    if (BDPT_HAS_T1 && t == 1) sum_ri *= mis_sq(bdpt_share());
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
// unweighted contribution before visibility, the shadow ray that decides it, and sets the
// densities it changes (and, for s = 1, NEE's density ratio of the fresh point); for t = 1 the
// contribution is before the pixel filter and `film` says where it lands (the caller splats
// it). Both ends go through one loop, so the BSDF code is inlined once.
vec3 connect_st(int s, int t, vec4 u, out vec2 film, inout MisInputs mi, out Ray shadow) {
    film = vec2(-1.0);
    shadow.o = vec3(0.0); shadow.d = vec3(0.0, 0.0, 1.0); shadow.tmin = 0.0; shadow.tmax = 0.0;
    // Step 1: the two ends (q: light side, p: camera side). Plain variables, not arrays: arrays
    // of vertices indexed in the loop below would live in (slow) local memory.
    Vertex p_end = CAMV(t - 1);
    // Escaped camera rays (infinite-light vertices) only count for s = 0 (pbrt).
    if (t >= 2 && p_end.kind != VTX_SURFACE) return vec3(0.0);
    Vertex q_end;
    vec3 weight_q = vec3(0.0), weight_p = vec3(0.0); // β·f at each end, or the sampled end's weight
    float cos_theta = 0.0;
    LightSample ls;
    if (BDPT_HAS_S01 && s == 1) {
        // A fresh light point, chosen from camera vertex t−1 as NEE does.
        if (!sample_light(p_end.p, p_end.ns, u.xyz, ls) || !any(greaterThan(ls.L, vec3(0.0)))) return vec3(0.0);
        uint li = ls.li;
        bool infinite = isinf(ls.dist);
        q_end = vertex_blank(infinite ? VTX_INF : VTX_LIGHT);
        q_end.p = infinite ? ls.wi : ls.p;
        q_end.light = li;
        GpuLight gl = lights[li];
        if (gl.kind == LIGHT_TRIANGLE || light_is_sphere(gl.kind)) q_end.ng = light_front_normal(gl, ls.p);
        q_end.flags = ls.delta ? VF_DELTA_LIGHT : 0u;
        weight_q = ls.L / ls.pdf;
    } else {
        q_end = LGTV(s - 1);
    }
    if (BDPT_HAS_T1 && t == 1) {
        // A fresh lens point, and where the connection lands on the film.
        if (q_end.kind != VTX_SURFACE) return vec3(0.0);
        Vertex c = vertex_blank(VTX_CAMERA);
        c.p = camera_sample_lens(u.zw);
        vec3 d = c.p - q_end.p;
        float d2 = dot(d, d);
        if (!(d2 > 0.0)) return vec3(0.0);
        if (!camera_film_position(c.p, -d * inversesqrt(d2), film, cos_theta)) return vec3(0.0);
        p_end = c;
        weight_p = vec3(camera_connection_we(cos_theta, d2));
    }
    // Step 2: at each surface end (e = 0: q, 1: p), the BSDF towards the other end (importance
    // on the light side, with the shading-normal correction) and the densities of sampling the
    // other end and, in reverse, its own predecessor. Sampled ends give their densities from the
    // light or camera. One loop, so the BSDF code is inlined once.
    float q_rev_other = 0.0, p_rev_other = 0.0, q_rev_pred = 0.0, p_rev_pred = 0.0;
    for (int e = 0; e < 2; ++e) {
        Vertex v = e == 0 ? q_end : p_end;
        Vertex other = e == 0 ? p_end : q_end;
        float rev_other = 0.0, rev_pred = 0.0;
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
            // Densities towards the other end and back to the predecessor (read only then),
            // through one call site; the camera-side predecessor counts only beyond the lens
            // (t ≥ 3).
            bool need_pred = e == 0 ? s >= 2 : t >= 3;
            for (int j = 0; j < (need_pred ? 2 : 1); ++j) {
                Vertex to = j == 0 ? other : (e == 0 ? LGTV(max(s - 2, 0)) : CAMV(max(t - 2, 0)));
                float pdf = pdf_surface(v, m, j == 0 ? v.wo : wn, to);
                if (j == 0) rev_other = pdf; else rev_pred = pdf;
            }
        } else if (v.kind == VTX_CAMERA) {
            rev_other = convert_density(camera_pdf_dir(cos_theta), v, other);
        } else {
            rev_other = pdf_light(v, other);
        }
        if (e == 0) {
            q_rev_other = rev_other;
            q_rev_pred = rev_pred;
        } else {
            p_rev_other = rev_other;
            p_rev_pred = rev_pred;
        }
    }
    // Step 3: the contribution; 1/d² only between two subpath vertices (the sampled ends' weights
    // already hold theirs).
    vec3 L = weight_q * weight_p;
    if (s >= 2 && t >= 2) {
        vec3 d = q_end.p - p_end.p;
        L /= dot(d, d);
    }
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // Step 4: the shadow ray, from the camera end when it is a surface (traced by connect, once
    // the weight is known).
    if (BDPT_HAS_T1 && t == 1) {
        shadow = spawn_ray_to(vertex_surface(q_end), p_end.p);
    } else if (BDPT_HAS_S01 && s == 1 && isinf(ls.dist)) {
        shadow = spawn_ray(vertex_surface(p_end), ls.wi);
    } else {
        shadow = spawn_ray_to(vertex_surface(p_end), q_end.p);
    }
    // Step 5: the densities this strategy changes; for s = 1, NEE's density of the fresh point
    // given camera vertex t−1 (p_end; (1, 1) is not a strategy).
    if (BDPT_HAS_S01 && s == 1) {
        mi.l0_fwd = pdf_light_origin(q_end);
        mi.l0_delta = ls.delta;
        mi.nee_ratio = nee_density_ratio(q_end, p_end);
    }
    mi.pt_rev = q_rev_other;
    mi.qs_rev = p_rev_other;
    mi.qsm_rev = q_rev_pred;
    mi.ptm_rev = p_rev_pred;
    return L;
}

// The MisInputs every strategy of a sample starts from: light vertex 0 as the light subpath
// made it, and NEE's density ratio of x0 for s ≥ 2 (x0, x1 = light vertices 0, 1: the same for
// all of them, so computed once).
MisInputs mis_inputs_of_sample(int nl) {
    Vertex l0 = LGTV(0);
    float nee_ratio = nl >= 2 ? nee_density_ratio(l0, LGTV(1)) : 1.0;
    return MisInputs(0.0, 0.0, 0.0, 0.0, l0.pdf_fwd, (l0.flags & VF_DELTA_LIGHT) != 0u, nee_ratio);
}

// Strategy (s, t): the unweighted contribution and its weight w (see connect_s0, connect_st);
// mi: mis_inputs_of_sample's. The shadow ray is traced last, when only the contribution and
// the ray are still needed (fewer registers live across the traversal).
vec3 connect(int s, int t, vec4 u, MisInputs mi, inout uint rays, out vec2 film, out float w) {
    w = 0.0;
    film = vec2(-1.0);
    Ray shadow;
    vec3 L = BDPT_HAS_S01 && s == 0 ? connect_s0(t, mi) : connect_st(s, t, u, film, mi, shadow);
    if (!any(greaterThan(L, vec3(0.0)))) return vec3(0.0);
    // NEE's density of x0 (the light end) given x1 (its neighbour), for s = 0 (s = 1: set by
    // connect_st; s ≥ 2: light vertices 0 and 1, mis_inputs_of_sample's).
    if (BDPT_HAS_S01 && s == 0) mi.nee_ratio = nee_density_ratio(CAMV(t - 1), CAMV(max(t - 2, 0)));
    w = mis_weight(s, t, mi);
    if (!BDPT_HAS_S01 || s > 0) {
        rays += 1u;
        if (trace_any(shadow)) {
            w = 0.0;
            return vec3(0.0);
        }
    }
    return L;
}

#endif
