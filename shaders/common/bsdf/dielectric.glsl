//! Dielectric interfaces (always two-sided; inside/outside from the sign of wo.z, relative IOR
//! eta = ior / 1). Smooth (alpha below GGX_ALPHA_DELTA): Mitsuba 3 `src/bsdfs/dielectric.cpp`,
//! reflect with probability F (exact Fresnel), weights specular reflectance / transmittance, the
//! transmitted weight scaled by 1/η² in radiance mode. Rough: Mitsuba 3
//! `src/bsdfs/roughdielectric.cpp` (Walter et al. 2007) with GGX alpha = roughness²: sample a
//! visible normal (Heitz 2018), choose reflection/refraction by F at that normal, pdfs with the
//! half-vector Jacobians, radiance-mode η² scaling ("missing term in the original paper").
//! Included by bsdf.glsl.
#ifndef COMMON_BSDF_DIELECTRIC_GLSL
#define COMMON_BSDF_DIELECTRIC_GLSL

#include "common/bsdf/microfacet.glsl"
#include "common/bsdf/fresnel.glsl"

float dielectric_alpha(in SurfaceParams m) { return sqr(clamp(m.s[0], 0.0, 1.0)); }

bool dielectric_is_delta(in SurfaceParams m) { return dielectric_alpha(m) < GGX_ALPHA_DELTA; }

/// Relative IOR (interior / exterior, exterior = 1). For the rough model an index-matched
/// interface has no half vector, so it is nudged off 1 (Mitsuba refuses int_ior == ext_ior).
float dielectric_eta(in SurfaceParams m, bool rough) {
    float eta = max(m.s[1], 1e-3);
    if (rough && abs(eta - 1.0) < 1e-3) eta = 1.001;
    return eta;
}

/// Rough model: f·cos θi, the pdf of sampling wi, and the sampling weight f·cos θi / pdf (formed
/// without the division), sharing the half-vector work. All zero for the smooth model.
vec3 dielectric_eval_pdf(in SurfaceParams m, vec3 wo, vec3 wi, uint mode, out float pdf, out vec3 weight) {
    pdf = 0.0;
    weight = vec3(0.0);
    if (dielectric_is_delta(m)) return vec3(0.0);
    float cos_theta_o = wo.z, cos_theta_i = wi.z;
    // Ignore perfectly grazing configurations
    if (cos_theta_o == 0.0 || cos_theta_i == 0.0) return vec3(0.0);
    float eta_m = dielectric_eta(m, true);
    vec2 alpha = vec2(max(dielectric_alpha(m), GGX_ALPHA_MIN));

    bool is_reflect = cos_theta_o * cos_theta_i > 0.0;
    // Relative IOR as seen from the side wo is on
    float eta = cos_theta_o > 0.0 ? eta_m : 1.0 / eta_m;
    float inv_eta = 1.0 / eta;

    // Generalised half vector, in the macro-surface normal's hemisphere
    vec3 h;
    if (!mf_half_vector(wo, wi, is_reflect ? 1.0 : eta, h)) return vec3(0.0);
    float dot_wo_h = dot(wo, h), dot_wi_h = dot(wi, h);
    // Micro and macro surface must agree on the side for both directions (smith_g1's test,
    // which Mitsuba replicates in pdf())
    if (dot_wo_h * cos_theta_o <= 0.0 || dot_wi_h * cos_theta_i <= 0.0) return vec3(0.0);

    float F = fresnel_dielectric(dot_wo_h, eta_m);
    // VNDF pdf of h seen from wo (mirrored to the upper side) is D·G1(wo)·|wo·h| / |cos θo|;
    // G1(wo)/|cos θo| also carries the 1/|cos θo| of the BSDF value
    vec3 wo_up = cos_theta_o < 0.0 ? -wo : wo;
    float D_G1_over_cos = ggx_D(h, alpha) * ggx_G1_over_cos(wo_up, h, alpha);
    float G1_wi = ggx_G1(wi, h, alpha);

    if (is_reflect) {
        // pdf: F · VNDF · 1/(4 |wi·h|), and |wi·h| = |wo·h| cancels; value F·D·G / (4 |cos θo|)
        pdf = F * D_G1_over_cos * 0.25;
        weight = m.c0 * G1_wi;
        return weight * pdf;
    }
    // Refraction Jacobian |dh/dwi| = η² |wi·h| / (wo·h + η wi·h)²
    float denom = sqr(dot_wo_h + eta * dot_wi_h);
    if (!(denom > 1e-20)) return vec3(0.0);
    float dwh_dwi = eta * eta * abs(dot_wi_h) / denom;
    pdf = (1.0 - F) * D_G1_over_cos * abs(dot_wo_h) * dwh_dwi;
    // value |(1−F)·D·G·η²·(wo·h)(wi·h) / (cos θo (wo·h + η wi·h)²)|, times 1/η² in radiance
    // mode for the solid angle compression ("missing term in the original paper")
    float scale = (mode == TRANSPORT_RADIANCE) ? inv_eta * inv_eta : 1.0;
    weight = m.c1 * (scale * G1_wi);
    return weight * pdf;
}

vec3 dielectric_eval(in SurfaceParams m, vec3 wo, vec3 wi, uint mode) {
    float pdf;
    vec3 weight;
    return dielectric_eval_pdf(m, wo, wi, mode, pdf, weight);
}

float dielectric_pdf(in SurfaceParams m, vec3 wo, vec3 wi) {
    float pdf;
    vec3 weight;
    dielectric_eval_pdf(m, wo, wi, TRANSPORT_RADIANCE, pdf, weight);
    return pdf;
}

bool dielectric_sample(in SurfaceParams m, vec3 wo, vec3 u, uint mode, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
    float cos_theta_o = wo.z;
    // Ignore perfectly grazing configurations
    if (cos_theta_o == 0.0) return false;

    if (dielectric_is_delta(m)) {
        float eta_m = dielectric_eta(m, false);
        float cos_theta_t, eta_it, eta_ti;
        float F = fresnel_dielectric(cos_theta_o, eta_m, cos_theta_t, eta_it, eta_ti);
        if (u.x < F) {
            // Specular reflection
            s.wi = vec3(-wo.x, -wo.y, wo.z);
            s.pdf = F;
            s.weight = m.c0;
            s.flags = BSDF_DELTA;
            s.eta = 1.0;
        } else {
            // Specular refraction; radiance is scaled by 1/η² for the solid-angle compression
            vec3 wi = vec3(-eta_ti * wo.x, -eta_ti * wo.y, cos_theta_t);
            if (wi.z * cos_theta_o >= 0.0) return false;
            s.wi = normalize(wi);
            s.pdf = 1.0 - F;
            float factor = (mode == TRANSPORT_RADIANCE) ? eta_ti * eta_ti : 1.0;
            s.weight = m.c1 * factor;
            s.flags = BSDF_DELTA | BSDF_TRANSMISSION;
            s.eta = eta_it;
        }
        return s.pdf > 0.0;
    }

    float eta_m = dielectric_eta(m, true);
    vec2 alpha = vec2(max(dielectric_alpha(m), GGX_ALPHA_MIN));
    // Sample the microfacet normal among those visible from wo's side
    vec3 wo_up = cos_theta_o < 0.0 ? -wo : wo;
    vec3 m_s = ggx_sample_vndf(wo_up, alpha, u.yz);
    float cos_theta_t, eta_it, eta_ti;
    float F = fresnel_dielectric(dot(wo, m_s), eta_m, cos_theta_t, eta_it, eta_ti);

    // Select the lobe by the Fresnel reflectance at the sampled normal
    vec3 wi;
    if (u.x < F) {
        // Perfect specular reflection based on the microfacet normal
        wi = mf_reflect(wo, m_s);
        if (wi.z * cos_theta_o <= 0.0) return false;
    } else {
        // Perfect specular transmission based on the microfacet normal
        wi = mf_refract(wo, m_s, cos_theta_t, eta_ti);
        if (wi.z * cos_theta_o >= 0.0) return false;
        float len2 = dot(wi, wi);
        if (!(len2 > 0.0)) return false;
        wi *= inversesqrt(len2);
        s.flags = BSDF_TRANSMISSION;
        s.eta = cos_theta_o > 0.0 ? eta_m : 1.0 / eta_m;
    }
    // pdf and weight through the half vector of (wo, wi): m_s up to rounding, and exactly what
    // bsdf_pdf / bsdf_eval see for this direction (weight = reflectance·G1(wi) or
    // transmittance·G1(wi)/η² in radiance mode, as Mitsuba)
    float pdf;
    vec3 weight;
    dielectric_eval_pdf(m, wo, wi, mode, pdf, weight);
    if (!(pdf > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = weight;
    return true;
}

#endif // COMMON_BSDF_DIELECTRIC_GLSL
