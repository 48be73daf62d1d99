// The surface at a ray hit: position with its rounding-error bound, geometric and shading
// normals, uv, tangent frame, material and light. Spawned rays leave the surface through the
// error bound (pbrt-v4's OffsetRayOrigin: offset along the normal by the bound, then one ulp
// away), which is scale-invariant, so tiny and huge scenes are equally robust.
#ifndef COMMON_SURFACE_GLSL
#define COMMON_SURFACE_GLSL
#include "common/bindings.glsl"
#include "common/math.glsl"
#include "common/traverse.glsl"

struct Surface {
    vec3 p;
    vec3 p_err;    // absolute error bound of p, per component
    vec3 ng;       // geometric normal (front side)
    vec3 ns;       // shading normal (front side)
    vec3 tangent;  // unit, orthogonal to ns: anisotropy stretches along it
    vec2 uv;
    uint material;
    uint light;    // index into lights, NONE when not emissive
};

float gamma_n(float n) { const float e = 5.96046448e-8; return (n * e) / (1.0 - n * e); }

Surface surface_at(Hit hit, Ray ray) {
    Surface s;
    GpuPrim p = prims[hit.prim];
    uint bits = floatBitsToUint(p.a.w);
    s.material = bits & PRIM_MATERIAL_MASK;
    s.light = floatBitsToUint(p.b.w);
    vec3 dpdu = vec3(0.0);
#ifdef HAS_SPHERES
    if ((bits & PRIM_SPHERE) != 0u) {
        vec3 c = p.a.xyz;
        float radius = p.b.x;
        // Re-project the hit onto the sphere; its error is then a few ulps of |p|.
        vec3 pw = ray.o + hit.t * ray.d;
        vec3 local = pw - c;
        float len = length(local);
        local = len > 0.0 ? local * (radius / len) : vec3(0.0, 0.0, radius);
        s.p = c + local;
        s.p_err = gamma_n(5.0) * (abs(c) + abs(local));
        s.ng = normalize(local);
        if ((bits & PRIM_FLIP_NORMALS) != 0u) s.ng = -s.ng;
        s.ns = s.ng;
        s.uv = sphere_uv(local, radius);
        dpdu = vec3(-local.y, local.x, 0.0);
    } else
#endif
    {
        vec3 p0 = p.a.xyz, p1 = p.b.xyz, p2 = p.c.xyz;
        float b1 = hit.b12.x, b2 = hit.b12.y, b0 = 1.0 - b1 - b2;
#ifdef HAS_INSTANCES
        // An instance's triangle: vertices to the (camera-relative) world, where it is what its
        // flattened copy would be: a mirroring instance swaps v1 and v2 (with their
        // barycentrics and shading data) to keep the facing, as the loader does for meshes.
        bool instanced = hit.inst != NONE;
        GpuInstance inst;
        vec3 p_obj_err = vec3(0.0);
        bool mirror = false;
        if (instanced) {
            inst = instances[hit.inst];
            if (inst.material != NONE) s.material = inst.material;
            s.light = NONE;
            vec3 po = b0 * p0 + b1 * p1 + b2 * p2;
            mat3 lin = mat3(inst.object_to_world[0].xyz, inst.object_to_world[1].xyz, inst.object_to_world[2].xyz);
            vec3 tr = vec3(inst.object_to_world[0].w, inst.object_to_world[1].w, inst.object_to_world[2].w);
            // Rows in lin's columns: world = po * lin + tr. Rounding of the vertices' move and of
            // the ray's move into the object frame widen the error bound.
            p0 = p0 * lin + tr; p1 = p1 * lin + tr; p2 = p2 * lin + tr;
            p_obj_err = gamma_n(16.0) * (abs(po) * mat3(abs(lin[0]), abs(lin[1]), abs(lin[2])) + abs(tr));
            mirror = (inst.flags & INST_MIRROR) != 0u;
            if (mirror) {
                vec3 tp = p1; p1 = p2; p2 = tp;
                float tb = b1; b1 = b2; b2 = tb;
            }
        }
#endif
        s.p = b0 * p0 + b1 * p1 + b2 * p2;
        s.p_err = gamma_n(7.0) * (abs(b0 * p0) + abs(b1 * p1) + abs(b2 * p2));
#ifdef HAS_INSTANCES
        s.p_err += p_obj_err;
#endif
        s.ng = normalize(cross(p1 - p0, p2 - p0));
        s.ns = s.ng;
        // Without uvs a triangle is parameterised by its barycentrics (`barycentric_uv`), so
        // dp/du runs along its first edge (Mitsuba's convention for meshes without texture
        // coordinates; anisotropic lobes stretch along it).
        s.uv = barycentric_uv(vec2(b1, b2));
        dpdu = p1 - p0;
        uint si = floatBitsToUint(p.c.w);
#ifdef HAS_TRI_SHADING
        if (si != NONE) {
            GpuTriShading sh = tri_shading[si];
#ifdef HAS_INSTANCES
            if (instanced) {
                if (mirror) {
                    vec4 tn = sh.n1; sh.n1 = sh.n2; sh.n2 = tn;
                    sh.uv_v.yz = sh.uv_v.zy;
                }
                // Normals through the inverse transpose (the world-to-object rows, transposed),
                // each renormalised as the loader does for a flattened copy.
                mat3 nm = mat3(inst.world_to_object[0].xyz, inst.world_to_object[1].xyz, inst.world_to_object[2].xyz);
                if (sh.uv_v.w > 0.5) {
                    sh.n0.xyz = normalize(nm * sh.n0.xyz);
                    sh.n1.xyz = normalize(nm * sh.n1.xyz);
                    sh.n2.xyz = normalize(nm * sh.n2.xyz);
                }
            }
#endif
            vec2 uv0 = vec2(sh.n0.w, sh.uv_v.x), uv1 = vec2(sh.n1.w, sh.uv_v.y), uv2 = vec2(sh.n2.w, sh.uv_v.z);
            s.uv = b0 * uv0 + b1 * uv1 + b2 * uv2;
            if (sh.uv_v.w > 0.5) {
                vec3 n = b0 * sh.n0.xyz + b1 * sh.n1.xyz + b2 * sh.n2.xyz;
                float l = length(n);
                if (l > 1e-20) s.ns = n / l;
            }
            // dp/du from the uv parameterisation (pbrt's triangle derivatives).
            vec2 duv02 = uv0 - uv2, duv12 = uv1 - uv2;
            float det = duv02.x * duv12.y - duv02.y * duv12.x;
            if (abs(det) > 1e-12) dpdu = (duv12.y * (p0 - p2) - duv02.y * (p1 - p2)) / det;
        }
#endif
    }
    // Tangent: dp/du made orthogonal to the shading normal in scenes with a conductor or a
    // principled surface, whose anisotropy reads its direction (SURFACE_TANGENTS, a scene
    // constant: common/types.glsl); else, and where dp/du is degenerate, any frame around the
    // shading normal (every other model is isotropic about it).
    vec3 t = dpdu - s.ns * dot(s.ns, dpdu);
    float tl = dot(t, t);
    if (SURFACE_TANGENTS && tl > 1e-24 && !isinf(tl)) {
        s.tangent = t * inversesqrt(tl);
    } else {
        vec3 b;
        make_frame(s.ns, s.tangent, b);
    }
    return s;
}

// Pushes p off the surface towards the side of w.
vec3 offset_origin(vec3 p, vec3 p_err, vec3 ng, vec3 w) {
    float d = dot(abs(ng), p_err);
    vec3 offset = d * ng;
    if (dot(w, ng) < 0.0) offset = -offset;
    vec3 po = p + offset;
    // Round away from p by one ulp in each component.
    for (int i = 0; i < 3; ++i) {
        if (offset[i] > 0.0) po[i] = uintBitsToFloat(floatBitsToUint(po[i]) + (po[i] >= 0.0 ? 1u : 0xffffffffu));
        else if (offset[i] < 0.0) po[i] = uintBitsToFloat(floatBitsToUint(po[i]) + (po[i] > 0.0 ? 0xffffffffu : 1u));
    }
    return po;
}

// A ray leaving surface s in direction w.
Ray spawn_ray(Surface s, vec3 w) {
    Ray r;
    r.o = offset_origin(s.p, s.p_err, s.ng, w);
    r.d = w;
    r.tmin = 0.0;
    r.tmax = FLT_MAX_C;
    return r;
}

// A shadow ray from origin o (already off its surface) to the point `to` (itself on its
// surface); stops just short.
Ray shadow_ray_between(vec3 o, vec3 to) {
    vec3 d = to - o;
    float len = length(d);
    Ray r;
    r.o = o;
    r.d = d / len;
    r.tmin = 0.0;
    r.tmax = len * (1.0 - 1e-4);
    return r;
}

// A shadow ray from surface s to the point `to` (itself already on its surface); stops just short.
Ray spawn_ray_to(Surface s, vec3 to) {
    return shadow_ray_between(offset_origin(s.p, s.p_err, s.ng, to - s.p), to);
}

// Both of surface s's ray origins, computed once where many rays leave one point (whitted's
// shadow rays): offset_origin depends on the direction only through its side of ng.
struct SurfaceOrigins { vec3 front; vec3 back; };

SurfaceOrigins surface_origins(Surface s) {
    return SurfaceOrigins(offset_origin(s.p, s.p_err, s.ng, s.ng), offset_origin(s.p, s.p_err, s.ng, -s.ng));
}

// The origin offset_origin gives for a ray from s along w.
vec3 origin_towards(SurfaceOrigins o, Surface s, vec3 w) { return dot(w, s.ng) < 0.0 ? o.back : o.front; }

#endif
