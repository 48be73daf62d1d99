// Cone tracing through the filtered volume (Crassin et al. 2011 §4): march along the axis with
// steps proportional to the cone's diameter, read the level whose cell size matches the
// diameter (log2 of it, in voxels; at most the option `max_level`, beyond which the footprint
// stays that level's cell), correct each sample's opacity for the step length
// (α' = 1 − (1 − α)^(Δt/diameter)) and composite front to back, stopping when opaque, out of the
// grid or past t_max. Returns (radiance, opacity): the radiance that reaches the apex from the
// volume, weighted by what lies in front of it.
// Leak guard: coarse cells average a wall with what lies behind it, and the blurred, opacity-
// corrected samples let a cone through a wall a few voxels thick. So the cone also ends where
// its axis enters an occupied level-0 voxel: the rest of its weight takes the radiance of the
// side of that voxel's surface it arrives at. The axis is tested in half-voxel steps wherever
// the filtered volume is not empty (and before the cone leaves the grid), so even walls one
// voxel thick stop every cone, at every resolution.
#ifndef VCT_CONE_GLSL
#define VCT_CONE_GLSL
#include "vct/volume.glsl"

// Cones start this many voxels off the surface (along its normal), then march from one voxel on:
// closer, they see their own surface's voxels.
#define CONE_OFFSET 1.5

// Apex p (camera-relative), unit direction d, tan of the half-angle; t0 and t_max in voxels.
vec4 cone_trace(vec3 p, vec3 d, float tan_half, float t0, float t_max) {
    vec3 pg0 = to_grid(p);
    float r = float(vct_res());
    vec3 C = vec3(0.0);
    float A = 0.0;
    float t = t0;
    float step_factor = max(P.cone.z, 0.05);
    float max_diam = float(1u << min(P.dims.w, vct_levels() - 1u));
    // Axis positions up to t_checked have been tested for occupied level-0 voxels.
    float t_checked = t0;
    uvec2 walk = uvec2(NONE);
    for (int it = 0; it < 4096 && t < t_max && A < 0.99; ++it) {
        vec3 pg = pg0 + t * d;
        bool outside = any(lessThan(pg, vec3(-1.0))) || any(greaterThan(pg, vec3(r + 1.0)));
        float diam = clamp(2.0 * tan_half * t, 1.0, max_diam);
        vec4 s = outside ? vec4(0.0) : vol_sample_lod(pg, log2(diam), d);
        float dt = diam * step_factor;
        float a = clamp(s.a, 0.0, 1.0);
        // Leak guard on the axis, from the last sample to this one, in half-voxel steps, where
        // the filtered volume shows something here (a > 0) or the cone is about to leave the
        // grid; else at this sample only. Steps of far cones span many voxels, so testing only
        // the samples let cones through walls a voxel or two thick, the more so the finer the
        // volume (its steps span more voxels): images came out darker at higher resolutions.
        float t_from = (a > 1e-4 || outside) ? t_checked : t;
        for (float u = t_from; u <= t + 1e-3; u += 0.5) {
            vec3 pu = pg0 + u * d;
            if (any(lessThan(pu, vec3(0.0))) || any(greaterThanEqual(pu, vec3(r)))) {
                if (u > t_checked + 0.5) break; // left the grid
                continue;
            }
            uint hit = occupied_slot_walk(uvec3(pu), walk);
            if (hit != NONE) {
                C += (1.0 - A) * level0_seen(hit, d);
                return vec4(C, 1.0);
            }
        }
        if (outside) break;
        t_checked = t;
        if (a > 1e-4) {
            float ac = 1.0 - pow(1.0 - min(a, 0.9999), dt / diam);
            C += (1.0 - A) * s.rgb * (ac / a);
            A += (1.0 - A) * ac;
        }
        t += dt;
    }
    return vec4(C, A);
}

// Cone directions for the diffuse gather: N directions around +z placed on the cosine-weighted
// hemisphere by a golden-angle spiral, rotated by `phi0`; each then stands for π/N of the
// cosine-weighted integral (E ≈ π/N · Σ L_i).
vec3 diffuse_cone_dir(uint i, uint n, float phi0) {
    float u = (float(i) + 0.5) / float(n);
    float r = sqrt(u);
    float phi = phi0 + float(i) * 2.39996323;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u, 0.0)));
}

#endif
