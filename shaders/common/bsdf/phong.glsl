//! Energy-normalised modified Phong (Lafortune & Willems 1994, "Using the modified Phong
//! reflectance model for physically based rendering"): no Mitsuba 3 equivalent.
//!   f = c0/π + c1 · (n + 2)/(2π) · max(0, cos α)^n,  α = angle between wi and the mirror of wo.
//! Sampling picks the diffuse or the specular lobe with probabilities proportional to the
//! luminances of c0 and c1 (renormalised); cosine sampling for the diffuse lobe, a cos^n lobe
//! around the mirror direction for the specular one; the pdf is the mixture.
//! Included by bsdf.glsl; back-side queries of two-sided materials are already mirrored.
#ifndef COMMON_BSDF_PHONG_GLSL
#define COMMON_BSDF_PHONG_GLSL

#include "common/sampling.glsl"

float phong_exponent(in SurfaceParams m) { return max(m.s[0], 0.0); }

/// Probability of sampling the specular lobe.
float phong_spec_prob(in SurfaceParams m) {
    float ld = max(luminance(m.c0), 0.0);
    float ls = max(luminance(m.c1), 0.0);
    float total = ld + ls;
    return total > 0.0 ? ls / total : 0.0;
}

/// max(0, cos α)^n without pow(0, 0).
float phong_lobe(float cos_alpha, float n) {
    return cos_alpha > 0.0 ? pow(min(cos_alpha, 1.0), n) : 0.0;
}

vec3 phong_eval(in SurfaceParams m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    float n = phong_exponent(m);
    vec3 r = vec3(-wo.x, -wo.y, wo.z);
    float spec = (n + 2.0) * INV_2PI * phong_lobe(dot(wi, r), n);
    return (m.c0 * INV_PI + m.c1 * spec) * wi.z;
}

float phong_pdf(in SurfaceParams m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    float n = phong_exponent(m);
    float p_spec = phong_spec_prob(m);
    vec3 r = vec3(-wo.x, -wo.y, wo.z);
    float pdf_spec = (n + 1.0) * INV_2PI * phong_lobe(dot(wi, r), n);
    return (1.0 - p_spec) * pdf_cosine_hemisphere(wi) + p_spec * pdf_spec;
}

bool phong_sample(in SurfaceParams m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
    if (wo.z <= 0.0) return false;
    float n = phong_exponent(m);
    float p_spec = phong_spec_prob(m);
    vec3 wi;
    if (u.x < p_spec) {
        // cos^n lobe around the mirror direction: cos α = u^(1/(n+1))
        vec3 r = vec3(-wo.x, -wo.y, wo.z);
        float cos_alpha = pow(max(u.y, 1e-30), 1.0 / (n + 1.0));
        float sin_alpha = safe_sqrt(1.0 - cos_alpha * cos_alpha);
        float phi = 2.0 * PI * u.z;
        vec3 t, b;
        make_frame(r, t, b);
        wi = from_local(vec3(sin_alpha * cos(phi), sin_alpha * sin(phi), cos_alpha), t, b, r);
    } else {
        wi = sample_cosine_hemisphere(u.yz);
    }
    if (!(wi.z > 0.0)) return false;
    float pdf = phong_pdf(m, wo, wi);
    if (!(pdf > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = phong_eval(m, wo, wi) / pdf;
    return true;
}

#endif // COMMON_BSDF_PHONG_GLSL
