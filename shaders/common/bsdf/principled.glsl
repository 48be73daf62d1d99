//! The Disney principled BSDF as Mitsuba 3 implements it: a port of `src/bsdfs/principled.cpp`
//! and `src/bsdfs/principledhelpers.h` (Burley 2012 "Physically Based Shading at Disney",
//! Burley 2015 "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering").
//! Lobes: diffuse + retro-reflection (2015 split), fake subsurface, sheen, GGX specular reflection
//! with Mitsuba's `principled_fresnel` (true dielectric Fresnel blended with Schlick metallic and
//! spec_tint terms), GGX specular transmission (spec_trans), and a GTR1 clearcoat.
//! Sampling, lobe-selection probabilities and pdfs are Mitsuba's (all sampling rates = 1).
//!
//! Parameter notes:
//! - `subsurface` (s[9]) is Mitsuba's `flatness`: Burley 2012's Hanrahan-Krueger-inspired
//!   diffuse approximation (f_ss), lerped with the diffuse + retro term.
//! - IOR: Mitsuba takes either `eta` or `specular` (eta = 2 / (1 − sqrt(0.08·specular)) − 1).
//!   Here s[8] > 0 means `eta` = s[8] was given; s[8] <= 0 means eta comes from specular (s[2]).
//!   With spec_trans > 0, eta = 1 is nudged to 1.001 and specular 0 to 1e-3 (as Mitsuba).
//! - Mitsuba's per-feature `m_has_*` switches are implied by the values being 0 (they give the
//!   same result), except that sheen is only added where the diffuse lobe is active (brdf > 0),
//!   which is what Mitsuba's scalar variants (the reference, scalar_rgb) compute.
//! - Mitsuba's clearcoat term 0.25·cc·F·D·G·|cos θi| has no 1/(4 cos θo cos θi) factor; kept.
//! - As in Mitsuba, sample() returns pdf = principled_pdf(wo, wi) and weight = eval / pdf. (The
//!   diffuse and clearcoat selection probabilities do not depend on F: on the front side
//!   p_reflect + p_trans = 1 for every F, so the mixture pdf is exact.)
//! - The back side of a one-sided (spec_trans == 0) principled material is black for eval, pdf
//!   and sample alike (bsdf.glsl); Mitsuba's pdf() alone returns a nonzero value there.
//! Verified against Mitsuba 3.9.1 scalar_rgb: eval and pdf agree to ~1e-4 relative on random
//! direction pairs, albedos from sampling agree within Monte Carlo error.
//! Names: Mitsuba's si.wi is our wo and its wo is our wi. Included by bsdf.glsl; with
//! spec_trans == 0 back-side queries of two-sided materials are already mirrored.
#ifndef COMMON_BSDF_PRINCIPLED_GLSL
#define COMMON_BSDF_PRINCIPLED_GLSL

#include "common/sampling.glsl"
#include "common/bsdf/microfacet.glsl"
#include "common/bsdf/fresnel.glsl"

/// Material parameters unpacked (and clamped to their documented ranges).
struct PrincipledParams {
    vec3 base_color;
    float metallic, roughness, spec_tint, anisotropic, sheen, sheen_tint, spec_trans;
    float flatness, clearcoat, clearcoat_gloss;
    float eta;
    vec2 alpha;   // main specular GGX (alpha_x, alpha_y)
    float brdf;   // weight of the reflection-only (diffuse) major lobe
    float bsdf;   // weight of the transmissive major lobe
};

PrincipledParams principled_unpack(in SurfaceParams m) {
    PrincipledParams p;
    p.base_color = max(m.c0, vec3(0.0));
    p.metallic = clamp(m.s[0], 0.0, 1.0);
    p.roughness = clamp(m.s[1], 0.0, 1.0);
    float specular = clamp(m.s[2], 0.0, 1.0);
    p.spec_tint = clamp(m.s[3], 0.0, 1.0);
    p.anisotropic = clamp(m.s[4], 0.0, 1.0);
    p.sheen = max(m.s[5], 0.0);
    p.sheen_tint = clamp(m.s[6], 0.0, 1.0);
    p.spec_trans = clamp(m.s[7], 0.0, 1.0);
    p.flatness = clamp(m.s[9], 0.0, 1.0);
    p.clearcoat = max(m.s[10], 0.0);
    p.clearcoat_gloss = clamp(m.s[11], 0.0, 1.0);

    bool has_spec_trans = p.spec_trans > 0.0;
    if (m.s[8] > 0.0) {
        // `eta` given; eta = 1 is not plausible for transmission
        p.eta = m.s[8];
        if (has_spec_trans && p.eta == 1.0) p.eta = 1.001;
    } else {
        // `specular` given; zero specular is not plausible for transmission
        if (has_spec_trans && specular == 0.0) specular = 1e-3;
        p.eta = 2.0 / (1.0 - sqrt(0.08 * specular)) - 1.0;
    }

    // calc_dist_params: alpha = roughness² stretched by the anisotropy, clamped to 0.001
    float roughness_2 = p.roughness * p.roughness;
    float aspect = sqrt(1.0 - 0.9 * p.anisotropic);
    p.alpha = max(vec2(roughness_2 / aspect, roughness_2 * aspect), vec2(0.001));

    p.brdf = (1.0 - p.metallic) * (1.0 - p.spec_trans);
    p.bsdf = (1.0 - p.metallic) * p.spec_trans;
    return p;
}

/// Clearcoat GTR1 alpha: lerp(0.1, 0.001, clearcoat_gloss).
float principled_cc_alpha(in PrincipledParams p) { return mix(0.1, 0.001, p.clearcoat_gloss); }

/// GTR1 (Berry) distribution, isotropic (principledhelpers.h `GTR1Isotropic::eval`).
float gtr1_D(vec3 m, float alpha) {
    float cos_theta = m.z;
    float alpha2 = alpha * alpha;
    float result = (alpha2 - 1.0) / (PI * log(alpha2) * (1.0 + (alpha2 - 1.0) * cos_theta * cos_theta));
    return (result * cos_theta > 1e-20) ? result : 0.0;
}

/// Density of gtr1_sample w.r.t. solid angle: cos θm · D(m).
float gtr1_pdf(vec3 m, float alpha) { return m.z < 0.0 ? 0.0 : m.z * gtr1_D(m, alpha); }

/// Sample a GTR1 normal proportionally to D(m) cos θm (not visible normals, as Mitsuba).
vec3 gtr1_sample(vec2 u, float alpha) {
    float phi = 2.0 * PI * u.x;
    float alpha2 = alpha * alpha;
    float cos_theta2 = (1.0 - pow(alpha2, 1.0 - u.y)) / (1.0 - alpha2);
    float sin_theta = safe_sqrt(1.0 - cos_theta2);
    float cos_theta = safe_sqrt(cos_theta2);
    return vec3(cos(phi) * sin_theta, sin(phi) * sin_theta, cos_theta);
}

/// Separable GGX shadowing-masking with a fixed alpha, used by the clearcoat
/// (principledhelpers.h `smith_ggx1`, written without tan²θ).
float principled_smith_ggx1(vec3 v, vec3 wh, float alpha) {
    if (dot(v, wh) * v.z <= 0.0) return 0.0;
    float cos_theta = abs(v.z);
    float sin_theta_2 = max(1.0 - cos_theta * cos_theta, 0.0);
    float denom = cos_theta + sqrt(cos_theta * cos_theta + alpha * alpha * sin_theta_2);
    return denom > 0.0 ? min(2.0 * cos_theta / denom, 1.0) : 0.0;
}

/// Macro/micro-surface compatibility (principledhelpers.h `mac_mic_compatibility`).
/// `cos_theta_o` is wo.z; the micro normal is flipped to wo's side.
bool principled_mac_mic(vec3 h, vec3 wo, vec3 wi, float cos_theta_o, bool reflection) {
    vec3 h_o = cos_theta_o >= 0.0 ? h : -h;
    if (reflection) return dot(wo, h_o) > 0.0 && dot(wi, h_o) > 0.0;
    return dot(wo, h_o) > 0.0 && dot(wi, -h_o) > 0.0;
}

/// Mitsuba's `principled_fresnel`: metallic and spec_tint Schlick terms blended with the true
/// dielectric Fresnel on the front side; the plain dielectric Fresnel (times bsdf) inside.
vec3 principled_fresnel(in PrincipledParams p, float F_dielectric, float lum, float cos_theta_i,
                        bool front_side) {
    if (!front_side) return vec3(p.bsdf * F_dielectric);
    bool outside = cos_theta_i >= 0.0;
    float eta_it = outside ? p.eta : 1.0 / p.eta;
    // Metallic component based on Schlick
    vec3 F_schlick = p.metallic * schlick_fresnel(p.base_color, cos_theta_i, p.eta);
    // Tinted dielectric component based on Schlick
    vec3 c_tint = lum > 0.0 ? p.base_color / lum : vec3(1.0);
    vec3 F0_spec_tint = c_tint * schlick_R0_eta(eta_it);
    F_schlick += (1.0 - p.metallic) * p.spec_tint * schlick_fresnel(F0_spec_tint, cos_theta_i, p.eta);
    return vec3((1.0 - p.metallic) * (1.0 - p.spec_tint) * F_dielectric) + F_schlick;
}

/// Lobe-selection probabilities (diffuse, clearcoat, spec_trans, spec_reflect), normalised;
/// false when they are undefined (no lobe can be sampled from this side).
bool principled_lobe_probs(in PrincipledParams p, float F, bool front_side, out vec4 probs) {
    float prob_spec_reflect = front_side ? (1.0 - p.bsdf * (1.0 - F)) : F;
    float prob_spec_trans = p.spec_trans > 0.0 ? (front_side ? p.bsdf * (1.0 - F) : (1.0 - F)) : 0.0;
    // Clearcoat has 1/4 of the main specular reflection energy
    float prob_clearcoat = (p.clearcoat > 0.0 && front_side) ? 0.25 * p.clearcoat : 0.0;
    float prob_diffuse = front_side ? p.brdf : 0.0;
    float total = prob_diffuse + prob_clearcoat + prob_spec_trans + prob_spec_reflect;
    if (!(total > 0.0)) {
        probs = vec4(0.0);
        return false;
    }
    probs = vec4(prob_diffuse, prob_clearcoat, prob_spec_trans, prob_spec_reflect) / total;
    return true;
}

vec3 principled_eval(in SurfaceParams m, vec3 wo, vec3 wi, uint mode) {
    float cos_theta_o = wo.z, cos_theta_i = wi.z;
    // Ignore perfectly grazing configurations
    if (cos_theta_o == 0.0) return vec3(0.0);
    PrincipledParams p = principled_unpack(m);

    bool is_reflect = cos_theta_o * cos_theta_i > 0.0;
    bool is_refract = cos_theta_o * cos_theta_i < 0.0;
    if (!is_reflect && !is_refract) return vec3(0.0);
    bool front_side = cos_theta_o > 0.0;
    float inv_eta = 1.0 / p.eta;
    // Eta w.r.t. the ray instead of the object
    float eta_path = front_side ? p.eta : inv_eta;
    float inv_eta_path = front_side ? inv_eta : p.eta;

    // Half vector, pointing out of the object
    vec3 wh;
    if (!mf_half_vector(wo, wi, is_reflect ? 1.0 : eta_path, wh)) return vec3(0.0);
    float dot_wo_h = dot(wo, wh), dot_wi_h = dot(wi, wh);

    // Dielectric Fresnel
    float F_spec_dielectric = fresnel_dielectric(dot_wo_h, p.eta);

    bool reflection_compatible = principled_mac_mic(wh, wo, wi, cos_theta_o, true);
    bool refraction_compatible = principled_mac_mic(wh, wo, wi, cos_theta_o, false);
    // Masks for evaluating the lobes
    bool spec_reflect_active = is_reflect && reflection_compatible && F_spec_dielectric > 0.0;
    bool clearcoat_active = p.clearcoat > 0.0 && is_reflect && reflection_compatible && front_side;
    bool spec_trans_active = p.bsdf > 0.0 && is_refract && refraction_compatible && F_spec_dielectric < 1.0;
    bool diffuse_active = p.brdf > 0.0 && is_reflect && front_side;
    bool sheen_active = p.sheen > 0.0 && is_reflect && (1.0 - p.metallic > 0.0) && front_side;

    // Main specular distribution and separable Smith term; G1(wo)/|cos θo| carries the
    // 1/|cos θo| of the microfacet models below
    float D = ggx_D(wh, p.alpha);
    float G_over_cos = ggx_G1_over_cos(wo, wh, p.alpha) * ggx_G1(wi, wh, p.alpha);
    float lum = luminance(p.base_color);

    vec3 value = vec3(0.0);

    // Main specular reflection: F · D · G / (4 |cos θo|)
    if (spec_reflect_active) {
        vec3 F_principled = principled_fresnel(p, F_spec_dielectric, lum, dot_wo_h, front_side);
        value += F_principled * (D * G_over_cos * 0.25);
    }

    // Main specular transmission
    if (spec_trans_active) {
        // Account for the solid angle compression when tracing radiance
        float scale = (mode == TRANSPORT_RADIANCE) ? inv_eta_path * inv_eta_path : 1.0;
        float denom = sqr(dot_wo_h + eta_path * dot_wi_h);
        if (denom > 1e-20) {
            float t = abs(scale * (1.0 - F_spec_dielectric) * D * G_over_cos * eta_path * eta_path *
                          dot_wo_h * dot_wi_h / denom);
            value += sqrt(p.base_color) * (p.bsdf * t);
        }
    }

    // Secondary isotropic specular reflection (clearcoat), Schlick F with R0 = 0.04, GTR1 D,
    // separable GGX G with alpha 0.25
    if (clearcoat_active) {
        float Fcc = schlick_fresnel(0.04, dot_wo_h, p.eta);
        float Dcc = gtr1_D(wh, principled_cc_alpha(p));
        float Gcc = principled_smith_ggx1(wo, wh, 0.25) * principled_smith_ggx1(wi, wh, 0.25);
        value += vec3((p.clearcoat * 0.25) * Fcc * Dcc * Gcc * abs(cos_theta_i));
    }

    // Diffuse, retro-reflection, fake subsurface and sheen
    if (diffuse_active) {
        float Fi = schlick_weight(abs(cos_theta_i));
        float Fo = schlick_weight(abs(cos_theta_o));
        // Diffuse
        float f_diff = (1.0 - 0.5 * Fo) * (1.0 - 0.5 * Fi);
        // Retro-reflection
        float cos_theta_d = dot_wi_h;
        float Rr = 2.0 * p.roughness * cos_theta_d * cos_theta_d;
        float f_retro = Rr * (Fi + Fo + Fi * Fo * (Rr - 1.0));
        // Fake subsurface (Hanrahan-Krueger based): Fss90 flattens the retro-reflection
        float Fss90 = 0.5 * Rr;
        float Fss = mix(1.0, Fss90, Fi) * mix(1.0, Fss90, Fo);
        float f_ss = 1.25 * (Fss * (1.0 / (abs(cos_theta_i) + abs(cos_theta_o)) - 0.5) + 0.5);
        value += p.base_color * (p.brdf * abs(cos_theta_i) * INV_PI * mix(f_diff + f_retro, f_ss, p.flatness));

        // Sheen, tinted towards the luminance-normalised base colour
        if (sheen_active) {
            float Fd = schlick_weight(abs(cos_theta_d));
            vec3 c_tint = lum > 0.0 ? p.base_color / lum : vec3(1.0);
            vec3 c_sheen = mix(vec3(1.0), c_tint, p.sheen_tint);
            value += c_sheen * (p.sheen * (1.0 - p.metallic) * Fd * abs(cos_theta_i));
        }
    }
    return value;
}

float principled_pdf(in SurfaceParams m, vec3 wo, vec3 wi) {
    float cos_theta_o = wo.z, cos_theta_i = wi.z;
    if (cos_theta_o == 0.0) return 0.0;
    PrincipledParams p = principled_unpack(m);

    bool front_side = cos_theta_o > 0.0;
    float eta_path = front_side ? p.eta : 1.0 / p.eta;
    bool is_reflect = cos_theta_o * cos_theta_i > 0.0;
    bool is_refract = cos_theta_o * cos_theta_i < 0.0;
    if (!is_reflect && !is_refract) return 0.0;

    vec3 wh;
    if (!mf_half_vector(wo, wi, is_reflect ? 1.0 : eta_path, wh)) return 0.0;
    float dot_wo_h = dot(wo, wh), dot_wi_h = dot(wi, wh);

    float F_spec_dielectric = fresnel_dielectric(dot_wo_h, p.eta);
    vec4 probs;
    if (!principled_lobe_probs(p, F_spec_dielectric, front_side, probs)) return 0.0;

    // |dwh/dwi| for reflection and refraction
    float dwh_dwi;
    if (is_reflect) {
        dwh_dwi = abs(dot_wi_h) > 0.0 ? 1.0 / (4.0 * abs(dot_wi_h)) : 0.0;
    } else {
        float denom = sqr(dot_wo_h + eta_path * dot_wi_h);
        dwh_dwi = denom > 1e-20 ? eta_path * eta_path * abs(dot_wi_h) / denom : 0.0;
    }

    vec3 wo_up = front_side ? wo : -wo;
    float pdf = 0.0;
    bool reflect_macmic = is_reflect && principled_mac_mic(wh, wo, wi, cos_theta_o, true);
    // Main specular reflection
    if (reflect_macmic) {
        // VNDF pdf · 1/(4 |wi·h|) with |wi·h| = |wo·h|: written without the division
        pdf += probs.w * ggx_D(wh, p.alpha) * ggx_G1_over_cos(wo_up, wh, p.alpha) * 0.25;
    }
    // Cosine hemisphere reflection (prob_diffuse is 0 unless front_side)
    if (is_reflect) pdf += probs.x * pdf_cosine_hemisphere(wi);
    // Main specular transmission
    if (p.spec_trans > 0.0 && is_refract && principled_mac_mic(wh, wo, wi, cos_theta_o, false)) {
        pdf += probs.z * ggx_pdf_vndf(wo_up, wh, p.alpha) * dwh_dwi;
    }
    // Clearcoat
    if (p.clearcoat > 0.0 && reflect_macmic) {
        pdf += probs.y * gtr1_pdf(wh, principled_cc_alpha(p)) * dwh_dwi;
    }
    return pdf;
}

bool principled_sample(in SurfaceParams m, vec3 wo, vec3 u, uint mode, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
    float cos_theta_o = wo.z;
    // Ignoring perfectly grazing incoming rays
    if (cos_theta_o == 0.0) return false;
    PrincipledParams p = principled_unpack(m);
    bool front_side = cos_theta_o > 0.0;
    // Without the transmissive lobe the inside is not sampled
    if (!front_side && !(p.bsdf > 0.0)) return false;

    // Main specular microfacet normal, visible from wo's side
    vec3 wo_up = front_side ? wo : -wo;
    vec3 m_spec = ggx_sample_vndf(wo_up, p.alpha, u.yz);
    float cos_theta_t, eta_it, eta_ti;
    float F_spec_dielectric = fresnel_dielectric(dot(wo, m_spec), p.eta, cos_theta_t, eta_it, eta_ti);

    vec4 probs;
    if (!principled_lobe_probs(p, F_spec_dielectric, front_side, probs)) return false;

    vec3 wi;
    uint flags = 0u;
    float eta = 1.0;
    float sample1 = u.x;
    if (sample1 < probs.x) {
        // Cosine hemisphere reflection
        wi = sample_cosine_hemisphere(u.yz);
        if (!(cos_theta_o * wi.z > 0.0)) return false;
    } else if (sample1 < probs.x + probs.y) {
        // Clearcoat: GTR1 normal, mirror reflection
        vec3 m_cc = gtr1_sample(u.yz, principled_cc_alpha(p));
        wi = mf_reflect(wo, m_cc);
        if (!(principled_mac_mic(m_cc, wo, wi, cos_theta_o, true) && cos_theta_o * wi.z > 0.0)) return false;
    } else if (sample1 < probs.x + probs.y + probs.z) {
        // Main specular transmission
        wi = mf_refract(wo, m_spec, cos_theta_t, eta_ti);
        if (!(principled_mac_mic(m_spec, wo, wi, cos_theta_o, false) && cos_theta_o * wi.z < 0.0)) return false;
        float len2 = dot(wi, wi);
        if (!(len2 > 0.0)) return false;
        wi *= inversesqrt(len2);
        flags = BSDF_TRANSMISSION;
        eta = eta_it;
    } else {
        // Main specular reflection
        wi = mf_reflect(wo, m_spec);
        if (!(principled_mac_mic(m_spec, wo, wi, cos_theta_o, true) && cos_theta_o * wi.z > 0.0)) return false;
    }

    float pdf = principled_pdf(m, wo, wi);
    if (!(pdf > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = principled_eval(m, wo, wi, mode) / pdf;
    s.flags = flags;
    s.eta = eta;
    return true;
}

#endif // COMMON_BSDF_PRINCIPLED_GLSL
