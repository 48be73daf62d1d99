// Texture lookups: bilinear filtering with repeat wrapping over linear RGBA f32 texels, row 0 at
// the top (texel row = (1 − v)·height, as OBJ uvs expect); environment maps clamp rows. Mitsuba's bitmap texture filters the
// same way (texel centres at half-integers).
#ifndef COMMON_TEXTURE_GLSL
#define COMMON_TEXTURE_GLSL
#include "common/bindings.glsl"

vec4 texel_fetch(GpuTexture t, int x, int y) {
    return texels[t.offset + uint(y) * t.width + uint(x)];
}

// The two neighbouring texel indices i and i + 1 of a bilinear lookup along an axis of n texels,
// wrapped (repeat) or clamped to [0, n). texture_eval's uv lies in [0, 1), so i is in [−1, n − 1]
// and a select wraps it (an integer modulo by a run-time divisor is a sequence of instructions:
// GPUs have no integer divider; measured in bench/RESULTS.md, "Texture lookups without integer
// modulos"); i is clamped to that range first, so no input (NaN uv included) reads outside the
// texture.
ivec2 texel_pair(int i, int n, bool clamp_edges) {
    i = clamp(i, -1, n - 1);
    if (clamp_edges) return ivec2(max(i, 0), min(i + 1, n - 1));
    return ivec2(i < 0 ? n - 1 : i, i + 1 >= n ? 0 : i + 1);
}

// Bilinear lookup at uv (scaled by the texture's uv scale).
vec4 texture_eval(uint index, vec2 uv) {
    GpuTexture t = textures[index];
    uv *= t.scale;
    uv = uv - floor(uv);
    float fx = uv.x * float(t.width) - 0.5;
    float fy = (1.0 - uv.y) * float(t.height) - 0.5;
    float x0 = floor(fx), y0 = floor(fy);
    float ax = fx - x0, ay = fy - y0;
    // Columns repeat; flag bit 0 clamps rows (environment maps: rows end at the poles).
    ivec2 xs = texel_pair(int(x0), int(t.width), false);
    ivec2 ys = texel_pair(int(y0), int(t.height), (t.flags & 1u) != 0u);
    vec4 c00 = texel_fetch(t, xs.x, ys.x), c10 = texel_fetch(t, xs.y, ys.x);
    vec4 c01 = texel_fetch(t, xs.x, ys.y), c11 = texel_fetch(t, xs.y, ys.y);
    return mix(mix(c00, c10, ax), mix(c01, c11, ax), ay);
}

#endif
