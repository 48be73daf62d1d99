// Subpath generation for bdpt: pbrt-v3's GenerateCameraSubpath / GenerateLightSubpath /
// RandomWalk, written into the fixed-size private array `vtx` (vertex.glsl). The camera walk
// transports radiance, the light walk importance (adjoint BSDFs: dielectrics drop the 1/η²
// factor, and the shading-normal correction is applied). Russian roulette as Mitsuba's: from
// rr_depth segments on, continue with q = min(max β · η², 0.95) (light paths: β relative to
// the emitted β, no η²). Roulette and the depth limit only stop a walk; the vertices already
// made stay usable (no sample is discarded for reaching max_depth).
#ifndef BDPT_SUBPATH_GLSL
#define BDPT_SUBPATH_GLSL
#include "bdpt/paths.glsl"
#include "common/camera.glsl"
#include "common/traverse.glsl"

// Extends the subpath whose vertex `start − 1` sits at vtx[base + start − 1], by at most
// `max_new` vertices, from `ray` with throughput beta. pdf_dir is the density of ray.d (solid
// angle; planar when the previous vertex is an infinite light). Returns the vertices added.
int random_walk(Ray ray, vec3 beta, float pdf_dir, int max_new, uint mode, int base, int start,
                float rr_norm, inout Rng rng, inout uint rays) {
    int added = 0;
    float eta_scale = 1.0;
    while (added < max_new) {
        int i = start + added;
        Vertex prev = vtx[base + i - 1];
        // Step 1: the next vertex. Camera rays that escape reach the environment.
        Hit hit;
        rays += 1u;
        if (!trace_closest(ray, hit)) {
            if (mode == TRANSPORT_RADIANCE && ENV_LIGHT != NONE) {
                Vertex v = vertex_blank(VTX_INF);
                v.p = ray.d;
                v.light = ENV_LIGHT;
                v.wo = -ray.d;
                v.beta = beta;
                v.pdf_fwd = pdf_dir; // solid angle towards an infinite light
                vtx[base + i] = v;
                added += 1;
            }
            break;
        }
        Surface s = surface_at(hit, ray);
        Vertex v = vertex_blank(VTX_SURFACE);
        v.p = s.p; v.p_err = s.p_err; v.ng = s.ng; v.ns = s.ns; v.tangent = s.tangent;
        v.uv = s.uv; v.material = s.material; v.light = s.light;
        v.wo = -ray.d;
        v.beta = beta;
        v.pdf_fwd = prev.kind == VTX_INF ? pdf_dir * abs(dot(v.ng, ray.d)) : convert_density(pdf_dir, prev, v);
        vtx[base + i] = v;
        added += 1;
        if (added >= max_new) break;

        // Step 2: sample the BSDF for the next direction.
        SurfaceParams m = resolve_material(s.material, s.uv);
        vec4 u = rng_next4(rng);
        vec3 wo = vertex_to_local(v, v.wo);
        BsdfSample bs;
        if (!bsdf_sample(m, wo, u.xyz, mode, bs)) break;
        vec3 wi_world = from_local(bs.wi, v.tangent, cross(v.ns, v.tangent), v.ns);
        beta *= bs.weight;
        if (mode == TRANSPORT_IMPORTANCE) beta *= shading_correction(v, v.wo, wi_world);
        // Step 3: the reverse density (of sampling wo from wi), zero at specular vertices.
        float pdf_rev = bsdf_pdf(m, bs.wi, wo);
        pdf_dir = bs.pdf;
        if ((bs.flags & BSDF_DELTA) != 0u) {
            vtx[base + i].flags |= VF_DELTA;
            pdf_dir = 0.0;
            pdf_rev = 0.0;
        }
        vtx[base + i - 1].pdf_rev = convert_density(pdf_rev, v, prev);
        if ((bs.flags & BSDF_TRANSMISSION) != 0u && mode == TRANSPORT_RADIANCE) eta_scale *= sqr(bs.eta);
        if (!any(greaterThan(beta, vec3(0.0)))) break;
        // Step 4: Russian roulette once the subpath has rr_depth segments.
        if (i >= PASS_RR_DEPTH) {
            float q = min(max_comp(beta) * rr_norm * eta_scale, 0.95);
            if (!(u.w < q)) break;
            beta /= q;
        }
        ray = spawn_ray(s, wi_world);
    }
    return added;
}

// The sides a kernel traces (paths.glsl): both in the per-pixel design, one per pass in the
// split design.
#if defined(BDPT_LIGHT_PASS)
#define BDPT_FIRST_SIDE 1
#define BDPT_LAST_SIDE 1
#elif defined(BDPT_CAMERA_PASS)
#define BDPT_FIRST_SIDE 0
#define BDPT_LAST_SIDE 0
#else
#define BDPT_FIRST_SIDE 0
#define BDPT_LAST_SIDE 1
#endif

// Both subpaths of one sample (those of this kernel's sides): the camera subpath (the lens
// vertex, then a radiance walk) and the light subpath (an emitted ray from light_emit.glsl, then
// an importance walk), through one call of random_walk (one inlined copy keeps the kernel
// small). nc ≥ 1; nl = 0 when no light or no emission was sampled. Vertex counts: camera ≤
// max_depth + 1, light ≤ max_depth. Each side draws from its own dimensions (0 and 256), so a
// side traced alone is the same subpath.
void trace_subpaths(uvec2 px, int max_depth, inout Rng rng, inout uint rays, out int nc, out int nl) {
    nc = 1;
    nl = 0;
    for (int side = BDPT_FIRST_SIDE; side <= BDPT_LAST_SIDE; ++side) {
        bool camera = side == 0;
        Ray ray;
        vec3 beta;
        float pdf, rr_norm = 1.0;
        if (camera) {
            // Step 1: the lens vertex. pbrt: the first vertex's density comes from Pdf_We
            // (uniform over the film), not from the filter.
            rng.dim = 0u;
            ray = camera_ray(px, rng);
            Vertex c = vertex_blank(VTX_CAMERA);
            c.p = ray.o;
            c.ns = g.cam_forward.xyz;
            c.beta = vec3(1.0);
            vtx[CAM(0)] = c;
            beta = vec3(1.0);
            pdf = camera_pdf_dir(dot(ray.d, g.cam_forward.xyz));
        } else {
            // Step 2: the light vertex; its density is pbrt's (pdfPos · pick; infinite lights:
            // the solid-angle density of the direction towards them, as s = 0 and s = 1 see it).
            if (max_depth <= 0) break;
            rng.dim = 256u;
            LightEmit e;
            vec4 u0 = rng_next4(rng), u1 = rng_next4(rng);
            if (!sample_light_emission(u0, u1, e)) break;
            Vertex l = vertex_blank(e.infinite ? VTX_INF : VTX_LIGHT);
            l.p = e.infinite ? -e.d : e.p;
            l.p_err = e.p_err;
            l.ng = e.n;
            l.ns = e.n;
            l.light = e.li;
            l.flags = e.delta ? VF_DELTA_LIGHT : 0u;
            l.beta = e.Le;
            l.pdf_fwd = e.infinite ? env_pdf_emit(-e.d) : e.pick * e.pdf_pos;
            vtx[LGT(0)] = l;
            nl = 1;
            // The emitted ray; β = Le |cos| / (pick · pdf_pos · pdf_dir). After an infinite light
            // the next density is planar (pdf_pos; the walk applies |cos|).
            bool area = dot(e.n, e.n) > 0.0;
            beta = e.Le * ((area ? abs(dot(e.n, e.d)) : 1.0) / (e.pick * e.pdf_pos * e.pdf_dir));
            ray.o = area ? offset_origin(e.p, e.p_err, e.n, e.d) : e.p;
            ray.d = e.d;
            ray.tmin = 0.0;
            ray.tmax = FLT_MAX_C;
            pdf = e.infinite ? e.pdf_pos : e.pdf_dir;
            float m = max_comp(beta);
            if (!(m > 0.0) || isinf(m)) break;
            rr_norm = 1.0 / m;
        }
        // Step 3: the walk.
        int added = random_walk(ray, beta, pdf, camera ? max_depth : max_depth - 1,
                                camera ? TRANSPORT_RADIANCE : TRANSPORT_IMPORTANCE,
                                camera ? CAM(0) : LGT(0), 1, rr_norm, rng, rays);
        if (camera) nc += added; else nl += added;
    }
}

#endif
