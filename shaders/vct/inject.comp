// vct stage 4: light injection. Every occupied voxel gets the radiance its surface reflects
// diffusely under direct light: L = albedo/π · E, with the irradiance E estimated from
// `inject_samples` light samples at the voxel's mean surface point (the same light sampling as
// `nee`: every light of the scene, emissive triangles and spheres, point, spot, directional,
// environment, in the same units), each tested with a shadow ray through the BVH. Each voxel
// keeps its front (the side of its normal) and back radiance apart; one-sided surfaces have no
// back. Emission is not injected: direct light is computed exactly at shaded points, so the
// cones gather only reflected light. The K samples of a voxel are the points of the 3D R2
// low-discrepancy sequence (Roberts 2018: i·(1/φ, 1/φ², 1/φ³) mod 1, φ the root of x⁴ = x + 1)
// under one random shift per voxel (Cranley-Patterson rotation): each sample stays uniform, so
// the estimate stays unbiased, and the K samples spread over the lights and their surfaces
// instead of clumping. The shift is keyed by the voxel (deterministic).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "common/rng.glsl"
#include "common/traverse.glsl"
#include "common/lights.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void main() {
    uint slot = LINEAR_GID;
    if (slot >= VP_COUNT) return;
    Voxel vx = load_voxel(slot);
    if (vx.opacity <= 0.0) { rad[slot] = uvec4(0u); return; }
    // Step 1: irradiance from K light samples with shadow rays, keyed by the voxel (not the
    // slot), so both storages inject the same values.
    uvec3 cell = slot_cell(slot);
    uint cell_key = cell.x + vct_res() * (cell.y + vct_res() * cell.z);
    uint K = max(P.mode.z, 1u);
    vec3 E = vec3(0.0), E_back = vec3(0.0);
    bool degenerate = dot(vx.n, vx.n) == 0.0;
    float eps = 0.05 * P.grid.w;
    Rng rng = rng_init(cell_key, 0u, 0x76637421u, 0x1a2b3c4du);
    vec3 shift = rng_next3(rng);
    const vec3 R2 = vec3(0.8191725133961645, 0.6710436067037893, 0.5497004779019703);
    for (uint i = 0u; i < K; ++i) {
        LightSample ls;
        if (!sample_light(vx.p, vx.n, fract(shift + float(i) * R2), ls)) continue;
        float c = dot(vx.n, ls.wi);
        float cosw = vx.two_sided ? abs(c) : max(c, 0.0);
        if (degenerate) cosw = 0.5; // normals cancel: the average over both sides
        if (cosw <= 0.0 || !any(greaterThan(ls.L, vec3(0.0)))) continue;
        // Leave the surface on the light's side.
        vec3 side = dot(vx.n, vx.n) > 0.0 ? (c >= 0.0 ? vx.n : -vx.n) : ls.wi;
        Ray r;
        r.o = vx.p + side * eps;
        r.tmin = 0.0;
        if (isinf(ls.dist)) {
            r.d = ls.wi;
            r.tmax = FLT_MAX_C;
        } else {
            vec3 d = ls.p - r.o;
            float len = length(d);
            r.d = d / len;
            r.tmax = len * (1.0 - 1e-3);
        }
        if (trace_any(r)) continue;
        if (c >= 0.0 || degenerate) E += ls.L * cosw / ls.pdf;
        if (c < 0.0 || degenerate) E_back += ls.L * cosw / ls.pdf;
    }
    // Step 2: outgoing diffuse radiance of each side, premultiplied by opacity.
    vec3 L = vx.albedo * INV_PI * E / float(K);
    vec3 Lb = vx.albedo * INV_PI * E_back / float(K);
    if (!(all(greaterThanEqual(L, vec3(0.0))) && all(lessThan(L, vec3(6e4))))) L = vec3(0.0);
    if (!(all(greaterThanEqual(Lb, vec3(0.0))) && all(lessThan(Lb, vec3(6e4))))) Lb = vec3(0.0);
    rad[slot] = uvec4(pack_h4(vec4(L * vx.opacity, vx.opacity)), pack_h4(vec4(Lb * vx.opacity, vx.opacity)));
}
