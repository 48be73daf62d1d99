// vct stage 2b: per-voxel attributes from the fragments. Each fragment (voxel, primitive) finds
// the point of its primitive nearest the voxel centre and adds, with integer atomics in fixed
// point (order-independent, so the result is the same on every device and run), the material's
// albedo (its reflectance estimate `bsdf_albedo_hint`, textures looked up at that point), its
// emitted radiance, the geometric normal and the point's offset from the voxel centre; the
// normalize pass averages them. An alpha-masked primitive adds nothing to a voxel where its mask
// cuts away every one of nine points of it nearest the voxel (its centre's and those of eight
// points inside the voxel, half-way to its corners), so holes of a voxel or more stay open to
// cones; otherwise the first of them the mask keeps stands for it. A voxel no fragment adds to
// stays empty (normalize.comp).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "vct/closest.glsl"
#include "common/intersect.glsl"
#include "common/material.glsl"
#include "common/alpha.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void add_int(uint i, float x) { atomicAdd(acc[i], uint(int(round(x)))); }

// The point q of primitive pr nearest `target`, its geometric normal n and its uv; false when
// the primitive's alpha mask (material mat) cuts q away, as traversal would.
bool nearest_point(GpuPrim pr, uint bits, uint mat, vec3 target, out vec3 q, out vec3 n, out vec2 uv) {
    if ((bits & PRIM_SPHERE) != 0u) {
        vec3 dc = target - pr.a.xyz;
        float l = length(dc);
        n = l > 0.0 ? dc / l : vec3(0.0, 0.0, 1.0);
        q = pr.a.xyz + pr.b.x * n;
        uv = sphere_uv(pr.b.x * n, pr.b.x);
        if ((bits & PRIM_FLIP_NORMALS) != 0u) n = -n;
#ifdef HAS_ALPHA
        if ((bits & PRIM_ALPHA) != 0u && mask_cuts(mat, uv)) return false;
#endif
        return true;
    }
    vec3 b = closest_on_triangle(target, pr.a.xyz, pr.b.xyz, pr.c.xyz);
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
#ifdef HAS_ALPHA
    if ((bits & PRIM_ALPHA) != 0u && alpha_cut(mat, pr, b.yz)) return false;
#endif
    return true;
}

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
    // Step 1: the primitive's point nearest the voxel centre, its normal and uv; for a masked
    // primitive, the first of the nine points (see the top) that its mask keeps.
    bool masked = false;
#ifdef HAS_ALPHA
    masked = (bits & PRIM_ALPHA) != 0u;
#endif
    vec3 q, n;
    vec2 uv;
    bool kept = false;
    for (uint k = 0u; k < (masked ? 9u : 1u) && !kept; ++k) {
        vec3 target = from_grid(vec3(v) + (k == 0u ? vec3(0.5) : 0.25 + 0.5 * vec3(octant_bits(k - 1u))));
        kept = nearest_point(pr, bits, mat, target, q, n, uv);
    }
    if (!kept) return;
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
