// Counter-based random numbers (DESIGN.md): every value is a hash of (seed, pixel, sample index,
// dimension), so an image does not depend on how samples are split into passes or devices.
// Hash: pcg4d, Jarzynski & Olano 2020, "Hash Functions for GPU Rendering" (JCGT 9(3)).
#ifndef COMMON_RNG_GLSL
#define COMMON_RNG_GLSL

struct Rng {
    uvec4 key; // (pixel, sample index, seed_lo, seed_hi ^ dimension)
    uint dim;
};

uvec4 pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    return v;
}

Rng rng_init(uint pixel, uint sample_index, uint seed_lo, uint seed_hi) {
    Rng r;
    r.key = uvec4(pixel, sample_index, seed_lo, seed_hi);
    r.dim = 0u;
    return r;
}

// Four independent 24-bit uniforms in [0, 1) for the next dimension.
vec4 rng_next4(inout Rng r) {
    uvec4 k = r.key;
    k.w ^= r.dim * 0x9E3779B9u;
    k.z += r.dim;
    uvec4 h = pcg4d(pcg4d(k));
    r.dim += 1u;
    return vec4(h >> 8u) * (1.0 / 16777216.0);
}

float rng_next1(inout Rng r) { return rng_next4(r).x; }
vec2 rng_next2(inout Rng r) { return rng_next4(r).xy; }
vec3 rng_next3(inout Rng r) { return rng_next4(r).xyz; }

#endif
