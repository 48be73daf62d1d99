//! Lambertian diffuse reflection with cosine-weighted sampling.
//! Follows Mitsuba 3 `src/bsdfs/diffuse.cpp` (one-sided; bsdf.glsl adds `twosided`).
//! Included by bsdf.glsl after the SurfaceParams / BsdfSample definitions; wo.z > 0 here
//! unless noted, since bsdf.glsl has already mirrored back-side queries of two-sided materials.
#ifndef COMMON_BSDF_DIFFUSE_GLSL
#define COMMON_BSDF_DIFFUSE_GLSL

#include "common/sampling.glsl"

/// f · cos θi = reflectance / π · cos θi on the upper hemisphere.
vec3 diffuse_eval(in SurfaceParams m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    return m.c0 * (INV_PI * wi.z);
}

float diffuse_pdf(in SurfaceParams m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    return pdf_cosine_hemisphere(wi);
}

bool diffuse_sample(in SurfaceParams m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
    if (wo.z <= 0.0) return false;
    // Cosine-weighted hemisphere: the weight f·cos/pdf is the reflectance itself
    vec3 wi = sample_cosine_hemisphere(u.yz);
    float pdf = pdf_cosine_hemisphere(wi);
    if (!(pdf > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = m.c0;
    return true;
}

#endif // COMMON_BSDF_DIFFUSE_GLSL
