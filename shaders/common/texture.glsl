// Texture lookups: bilinear filtering with repeat wrapping over linear RGBA f32 texels, row 0 at
// the top (texel row = (1 − v)·height, as OBJ uvs expect); environment maps clamp rows. Mitsuba's bitmap texture filters the
// same way (texel centres at half-integers).
#ifndef COMMON_TEXTURE_GLSL
#define COMMON_TEXTURE_GLSL
#include "common/bindings.glsl"

vec4 texel_fetch(GpuTexture t, int x, int y) {
    int w = int(t.width), h = int(t.height);
    x = ((x % w) + w) % w;
    // Flag bit 0: clamp rows (environment maps: rows end at the poles) instead of repeating.
    y = (t.flags & 1u) != 0u ? clamp(y, 0, h - 1) : ((y % h) + h) % h;
    return texels[t.offset + uint(y) * t.width + uint(x)];
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
    int ix = int(x0), iy = int(y0);
    vec4 c00 = texel_fetch(t, ix, iy), c10 = texel_fetch(t, ix + 1, iy);
    vec4 c01 = texel_fetch(t, ix, iy + 1), c11 = texel_fetch(t, ix + 1, iy + 1);
    return mix(mix(c00, c10, ax), mix(c01, c11, ax), ay);
}

#endif
