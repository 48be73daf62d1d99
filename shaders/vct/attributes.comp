// vct stage 2b: per-voxel attributes from the fragments. Each fragment (voxel, primitive) finds
// the point of its primitive nearest the voxel centre and adds, with integer atomics in fixed
// point (order-independent, so the result is the same on every device and run), the material's
// albedo (its reflectance estimate `bsdf_albedo_hint`, textures looked up at that point), its
// emitted radiance, the geometric normal and the point's offset from the voxel centre; the
// normalize pass averages them.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "vct/closest.glsl"
#include "common/intersect.glsl"
#include "common/material.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void add_int(uint i, float x) { atomicAdd(acc[i], uint(int(round(x)))); }

void main() {
    uint gid = LINEAR_GID;
    if (gid >= VP_COUNT) return;
    uvec2 f = frags[gid];
    uvec3 v = unpack_cell(f.x);
    uint slot = voxel_slot(v);
    if (slot == NONE) return;
    GpuPrim pr = prims[f.y];
    uint bits = floatBitsToUint(pr.a.w);
    uint mat = bits & PRIM_MATERIAL_MASK;
    vec3 centre = from_grid(vec3(v) + 0.5);
    // Step 1: the primitive's point nearest the voxel centre, its normal and uv.
    vec3 q, n;
    vec2 uv = vec2(0.0);
    if ((bits & PRIM_SPHERE) != 0u) {
        vec3 dc = centre - pr.a.xyz;
        float l = length(dc);
        n = l > 0.0 ? dc / l : vec3(0.0, 0.0, 1.0);
        q = pr.a.xyz + pr.b.x * n;
        uv = sphere_uv(pr.b.x * n, pr.b.x);
        if ((bits & PRIM_FLIP_NORMALS) != 0u) n = -n;
    } else {
        vec3 b = closest_on_triangle(centre, pr.a.xyz, pr.b.xyz, pr.c.xyz);
        q = b.x * pr.a.xyz + b.y * pr.b.xyz + b.z * pr.c.xyz;
        n = normalize(cross(pr.b.xyz - pr.a.xyz, pr.c.xyz - pr.a.xyz));
        uv = barycentric_uv(b.yz);
#ifdef HAS_TRI_SHADING
        uint si = floatBitsToUint(pr.c.w);
        if (si != NONE) {
            GpuTriShading sh = tri_shading[si];
            uv = b.x * vec2(sh.n0.w, sh.uv_v.x) + b.y * vec2(sh.n1.w, sh.uv_v.y) + b.z * vec2(sh.n2.w, sh.uv_v.z);
        }
#endif
    }
    if (any(isnan(n))) n = vec3(0.0);
    // Step 2: material albedo and emission.
    SurfaceParams m = resolve_material(mat, uv);
    vec3 albedo = bsdf_albedo_hint(m);
    GpuMaterial gm = materials[mat];
    vec3 le = floatBitsToUint(pr.b.w) != NONE ? max(gm.emission.rgb, vec3(0.0)) : vec3(0.0);
    bool two_sided = (gm.header.y & MATF_TWO_SIDED) != 0u || gm.header.x == MAT_DIELECTRIC;
    vec3 off = clamp(to_grid(q) - (vec3(v) + 0.5), vec3(-1.0), vec3(1.0));
    // Step 3: fixed-point sums (albedo 2^-16, emission 2^-8, normal and offset 2^-15).
    uint base = slot * ACC_WORDS;
    for (int i = 0; i < 3; ++i) {
        atomicAdd(acc[base + uint(i)], uint(round(clamp(albedo[i], 0.0, 1.0) * 65535.0)));
        atomicAdd(acc[base + 3u + uint(i)], uint(round(min(le[i], 16000.0) * 256.0)));
        add_int(base + 6u + uint(i), n[i] * 32767.0);
        add_int(base + 9u + uint(i), off[i] * 32767.0);
    }
    atomicAdd(acc[base + 12u], 1u);
    if (two_sided) atomicOr(acc[base + 13u], 1u);
}
