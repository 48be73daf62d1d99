// Environment emission: constant radiance or an equirectangular map (+Y up, the image's centre
// column looking down −Z, rotated by rotate_y about +Y), with importance sampling of the map by a
// piecewise-constant 2D distribution of luminance·sinθ (pbrt's Distribution2D). env_dist holds
// the marginal CDF (h+1 floats), the conditional CDFs (h·(w+1)) and the per-texel pdf (w·h).
#ifndef COMMON_ENV_GLSL
#define COMMON_ENV_GLSL
#include "common/bindings.glsl"
#include "common/math.glsl"
#include "common/texture.glsl"

// World direction → map uv (u right, v down from +Y), undoing rotate_y.
vec2 env_dir_to_uv(vec3 d) {
    float c = g.env_params.y, s = g.env_params.z;
    // R_y(−α)·d
    vec3 l = vec3(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
    float theta = safe_acos(l.y);
    float phi = atan(l.x, -l.z);
    return vec2(0.5 + phi * INV_2PI, theta * INV_PI);
}

vec3 env_uv_to_dir(vec2 uv) {
    float phi = (uv.x - 0.5) * 2.0 * PI, theta = uv.y * PI;
    float st = sin(theta);
    vec3 l = vec3(st * sin(phi), cos(theta), -st * cos(phi));
    float c = g.env_params.y, s = g.env_params.z;
    // R_y(α)·l
    return vec3(c * l.x + s * l.z, l.y, -s * l.x + c * l.z);
}

// Radiance arriving from direction d (0 with no environment).
vec3 env_eval(vec3 d) {
    uint li = ENV_LIGHT;
    if (li == NONE) return vec3(0.0);
#ifdef HAS_ENV_MAP
    if (g.env.y != NONE) {
        vec2 uv = env_dir_to_uv(d);
        // texture_eval flips v (row = (1 − v)·h): pass 1 − v so row 0 is the top (+Y).
        return g.env_params.x * texture_eval(g.env.y, vec2(uv.x, 1.0 - uv.y)).rgb;
    }
#endif
    return lights[li].radiance.rgb;
}

#ifdef HAS_ENV_MAP
// Index of the last cdf entry <= u in cdf[base .. base+n] (n+1 entries, cdf[base] = 0).
uint find_interval(uint base, uint n, float u) {
    uint lo = 0u, hi = n; // invariant: cdf[lo] <= u < cdf[hi]
    while (hi - lo > 1u) {
        uint mid = (lo + hi) >> 1;
        if (env_dist[base + mid] <= u) lo = mid; else hi = mid;
    }
    return lo;
}

// Samples a direction with pdf (solid angle) proportional to the map's luminance.
vec3 env_map_sample(vec2 u, out float pdf) {
    uint w = g.env.z, h = g.env.w;
    uint row = find_interval(0u, h, u.y);
    float c0 = env_dist[row], c1 = env_dist[row + 1u];
    float dv = c1 > c0 ? (u.y - c0) / (c1 - c0) : 0.5;
    uint cbase = h + 1u + row * (w + 1u);
    uint col = find_interval(cbase, w, u.x);
    float d0 = env_dist[cbase + col], d1 = env_dist[cbase + col + 1u];
    float du = d1 > d0 ? (u.x - d0) / (d1 - d0) : 0.5;
    vec2 uv = vec2((float(col) + clamp(du, 0.0, 1.0)) / float(w), (float(row) + clamp(dv, 0.0, 1.0)) / float(h));
    float pdf_uv = env_dist[h + 1u + h * (w + 1u) + row * w + col];
    float st = sin(uv.y * PI);
    pdf = st > 0.0 ? pdf_uv / (2.0 * PI * PI * st) : 0.0;
    return env_uv_to_dir(uv);
}

float env_map_pdf(vec3 d) {
    uint w = g.env.z, h = g.env.w;
    vec2 uv = env_dir_to_uv(d);
    uint col = min(uint(uv.x * float(w)), w - 1u), row = min(uint(uv.y * float(h)), h - 1u);
    float st = sin(uv.y * PI);
    return st > 0.0 ? env_dist[h + 1u + h * (w + 1u) + row * w + col] / (2.0 * PI * PI * st) : 0.0;
}
#endif

#endif
