// Material lookup: a GpuMaterial's constants and textures evaluated at a surface point into the
// SurfaceParams that the BSDFs (common/bsdf/) take.
#ifndef COMMON_MATERIAL_GLSL
#define COMMON_MATERIAL_GLSL
#include "common/bindings.glsl"
#include "common/texture.glsl"
#include "common/bsdf/bsdf.glsl"

vec3 color_param(vec4 c, vec2 uv) {
#ifdef HAS_TEXTURES
    uint tex = floatBitsToUint(c.w);
    if (tex != NONE) return texture_eval(tex, uv).rgb;
#endif
    return c.rgb;
}

SurfaceParams resolve_material(uint index, vec2 uv) {
    GpuMaterial gm = materials[index];
    SurfaceParams m;
    m.type = gm.header.x;
    m.flags = gm.header.y;
    m.c0 = color_param(gm.colors[0], uv);
    m.c1 = color_param(gm.colors[1], uv);
    m.c2 = color_param(gm.colors[2], uv);
    for (int i = 0; i < 12; ++i) {
        m.s[i] = gm.scalars[i];
#ifdef HAS_TEXTURES
        if (gm.scalar_tex[i] != NONE) m.s[i] = texture_eval(gm.scalar_tex[i], uv).r;
#endif
    }
    return m;
}

#endif
