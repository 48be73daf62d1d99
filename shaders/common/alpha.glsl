// Alpha masks (a material's `alpha_mask`): where the mask is below 0.5 the surface does not
// exist. Traversal skips such hits (common/traverse.glsl: triangles at their uvs, spheres at
// their own, `sphere_uv`), and light sampling gives such points no emission (`emitter_cut`:
// nee's and whitted's light samples, bdpt's light subpaths), so every integrator sees the same
// holes. The light's pdfs still spread over the whole shape (holes included): a point in a hole
// is drawn with that density and contributes nothing, which keeps the estimate unbiased and the
// MIS pdfs of light and BSDF sampling equal.
#ifndef COMMON_ALPHA_GLSL
#define COMMON_ALPHA_GLSL
#include "common/bindings.glsl"
#include "common/intersect.glsl"
#include "common/texture.glsl"

#ifdef HAS_ALPHA
// True when material m's mask cuts the point of texture coordinates uv away (false without a
// mask).
bool mask_cuts(uint m, vec2 uv) {
    uint tex = materials[m].header.z;
    return tex != NONE && texture_eval(tex, uv).r < 0.5;
}

// The uvs of triangle p's point with barycentrics b12 (of v1, v2); p must have shading data.
vec2 triangle_uv(GpuPrim p, vec2 b12) {
    GpuTriShading s = tri_shading[floatBitsToUint(p.c.w)];
    return (1.0 - b12.x - b12.y) * vec2(s.n0.w, s.uv_v.x) + b12.x * vec2(s.n1.w, s.uv_v.y) + b12.y * vec2(s.n2.w, s.uv_v.z);
}

// True when material m's mask cuts triangle p's point with barycentrics b12 away.
bool alpha_cut(uint m, GpuPrim p, vec2 b12) {
    if (floatBitsToUint(p.c.w) == NONE) return false;
    return mask_cuts(m, triangle_uv(p, b12));
}

// True when area light l's point pl (barycentrics b on a triangle light; any value for a
// sphere) lies in a hole of its primitive's alpha mask, so it emits nothing.
bool emitter_cut(GpuLight l, vec3 pl, vec2 b) {
    GpuPrim p = prims[l.prim];
    uint bits = floatBitsToUint(p.a.w);
    if ((bits & PRIM_ALPHA) == 0u) return false;
    uint m = bits & PRIM_MATERIAL_MASK;
    if (light_is_sphere(l.kind)) return mask_cuts(m, sphere_uv(pl - p.a.xyz, p.b.x));
    return alpha_cut(m, p, b);
}
#else
bool emitter_cut(GpuLight l, vec3 pl, vec2 b) { return false; }
#endif

#endif
