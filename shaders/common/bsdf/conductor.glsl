//! Conductors: a perfectly specular mirror (Mitsuba 3 `src/bsdfs/conductor.cpp`) when the GGX
//! alphas are below GGX_ALPHA_DELTA, otherwise the rough GGX microfacet conductor of
//! `src/bsdfs/roughconductor.cpp` (Walter et al. 2007; visible-normal sampling, Heitz 2018),
//! with Smith's separable G = G1(wo)·G1(wi) and the conductor Fresnel term (F = 1 when the
//! material has no eta/k: Mitsuba `material: "none"`).
//! Roughness mapping (SCENE_FORMAT.md): alpha = roughness², anisotropy a in [0, 1):
//! aspect = sqrt(1 − 0.9a), alpha_x = alpha / aspect (tangent), alpha_y = alpha · aspect.
//! Included by bsdf.glsl; back-side queries of two-sided materials are already mirrored.
#ifndef COMMON_BSDF_CONDUCTOR_GLSL
#define COMMON_BSDF_CONDUCTOR_GLSL

#include "common/bsdf/microfacet.glsl"
#include "common/bsdf/fresnel.glsl"

/// (alpha_x, alpha_y) before any clamping.
vec2 conductor_alpha(in SurfaceParams m) {
    float roughness = clamp(m.s[0], 0.0, 1.0);
    float anisotropy = clamp(m.s[1], 0.0, 1.0);
    float alpha = roughness * roughness;
    float aspect = sqrt(1.0 - 0.9 * anisotropy);
    return vec2(alpha / aspect, alpha * aspect);
}

bool conductor_is_delta(in SurfaceParams m) {
    vec2 alpha = conductor_alpha(m);
    return max(alpha.x, alpha.y) < GGX_ALPHA_DELTA;
}

/// Fresnel factor for the microfacet (or macro) cosine; 1 without eta/k.
vec3 conductor_fresnel(in SurfaceParams m, float cos_theta_i) {
    if ((m.flags & MATF_HAS_ETA_K) == 0u) return vec3(1.0);
    return fresnel_conductor(cos_theta_i, m.c1, m.c2);
}

/// f·cos θi, the pdf of sampling wi and the sampling weight f·cos θi / pdf (computed without the
/// division), sharing the half-vector work.
vec3 conductor_eval_pdf(in SurfaceParams m, vec3 wo, vec3 wi, out float pdf, out vec3 weight) {
    pdf = 0.0;
    weight = vec3(0.0);
    if (conductor_is_delta(m) || wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    vec2 alpha = max(conductor_alpha(m), vec2(GGX_ALPHA_MIN));
    // Half-direction vector
    vec3 h;
    if (!mf_half_vector(wo, wi, 1.0, h)) return vec3(0.0);
    // Micro and macro surface must agree on the side (smith_g1's test, replicated for the pdf)
    float dot_wo_h = dot(wo, h);
    if (dot_wo_h <= 0.0 || dot(wi, h) <= 0.0) return vec3(0.0);
    // D · G1(wo) / cos θo, formed without dividing by cos θo
    float D_G1_over_cos = ggx_D(h, alpha) * ggx_G1_over_cos(wo, h, alpha);
    // VNDF pdf D·G1(wo)·(wo·h)/cos θo times the reflection Jacobian 1 / (4 wi·h), wi·h = wo·h
    pdf = D_G1_over_cos * 0.25;
    // value D · G1(wo) · G1(wi) · F / (4 cos θo); weight F · G1(wi) · reflectance
    weight = m.c0 * conductor_fresnel(m, dot_wo_h) * ggx_G1(wi, h, alpha);
    return weight * pdf;
}

vec3 conductor_eval(in SurfaceParams m, vec3 wo, vec3 wi) {
    float pdf;
    vec3 weight;
    return conductor_eval_pdf(m, wo, wi, pdf, weight);
}

float conductor_pdf(in SurfaceParams m, vec3 wo, vec3 wi) {
    float pdf;
    vec3 weight;
    conductor_eval_pdf(m, wo, wi, pdf, weight);
    return pdf;
}

bool conductor_sample(in SurfaceParams m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
    if (wo.z <= 0.0) return false;

    if (conductor_is_delta(m)) {
        // Perfect mirror: weight = specular reflectance · F(cos θo)
        s.wi = vec3(-wo.x, -wo.y, wo.z);
        s.weight = m.c0 * conductor_fresnel(m, wo.z);
        s.pdf = 1.0;
        s.flags = BSDF_DELTA;
        return true;
    }

    vec2 alpha = max(conductor_alpha(m), vec2(GGX_ALPHA_MIN));
    // Sample M, the microfacet normal, among those visible from wo
    vec3 m_s = ggx_sample_vndf(wo, alpha, u.yz);
    // Perfect specular reflection based on the microfacet normal
    vec3 wi = mf_reflect(wo, m_s);
    if (wi.z <= 0.0) return false;
    // pdf and value through the half vector of (wo, wi): equal to m_s up to rounding, and exactly
    // what bsdf_pdf / bsdf_eval see for this direction (weight = F · G1(wi) · reflectance)
    float pdf;
    vec3 weight;
    conductor_eval_pdf(m, wo, wi, pdf, weight);
    if (!(pdf > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = weight;
    return true;
}

#endif // COMMON_BSDF_CONDUCTOR_GLSL
