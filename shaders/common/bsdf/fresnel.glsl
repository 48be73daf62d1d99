//! Fresnel equations: unpolarised dielectric (exact, with η flipped when the incident cosine is
//! negative, and 1 on total internal reflection), unpolarised conductor with a complex index
//! η + ik per RGB channel, and the Schlick helpers the principled BSDF uses.
//! Follows Mitsuba 3 `include/mitsuba/render/fresnel.h` (`fresnel`, `fresnel_conductor`) and
//! `src/bsdfs/principledhelpers.h` (`schlick_weight`, `calc_schlick`, `schlick_R0_eta`).
//! The exact Fresnel terms use `precise` locals so every call site rounds the same way (they
//! cancel catastrophically near index-matched interfaces); see microfacet.glsl.
#ifndef COMMON_BSDF_FRESNEL_GLSL
#define COMMON_BSDF_FRESNEL_GLSL

#include "common/math.glsl"

/// Dielectric Fresnel reflectance at an interface with relative IOR `eta` = η_inside / η_outside
/// (the normal points outside). `cos_theta_i` is the signed cosine of the incident direction
/// (negative: arriving from inside, η flipped). Outputs (as Mitsuba's tuple):
///   cos_theta_t: signed cosine of the refracted direction (opposite sign to cos_theta_i, 0 on TIR)
///   eta_it: relative IOR in the direction of travel; eta_ti = 1 / eta_it.
float fresnel_dielectric(float cos_theta_i, float eta, out float cos_theta_t, out float eta_it,
                         out float eta_ti) {
    cos_theta_i = clamp(cos_theta_i, -1.0, 1.0);
    bool outside = cos_theta_i >= 0.0;
    precise float rcp_eta = 1.0 / eta;
    eta_it = outside ? eta : rcp_eta;
    eta_ti = outside ? rcp_eta : eta;

    // Snell's law: squared cosine of the transmitted direction
    precise float cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    precise float cos_i = abs(cos_theta_i);
    precise float cos_t = safe_sqrt(cos_theta_t_sqr);
    // Transmitted direction is on the other side of the interface
    cos_theta_t = outside ? -cos_t : cos_t;

    // Index-matched: no reflection. Grazing or total internal reflection: everything reflects.
    if (eta == 1.0) return 0.0;
    if (cos_i == 0.0 || cos_theta_t_sqr <= 0.0) {
        cos_theta_t = 0.0;
        return 1.0;
    }
    // Amplitudes of the reflected s- and p-polarised waves
    precise float a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
    precise float a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
    return clamp(0.5 * (a_s * a_s + a_p * a_p), 0.0, 1.0);
}

/// Dielectric Fresnel reflectance only (see the full overload).
float fresnel_dielectric(float cos_theta_i, float eta) {
    float cos_theta_t, eta_it, eta_ti;
    return fresnel_dielectric(cos_theta_i, eta, cos_theta_t, eta_it, eta_ti);
}

/// Conductor Fresnel reflectance per channel for the complex relative IOR eta + i·k
/// (Mitsuba `fresnel_conductor`, after K.D. Moeller, "Optics", 1988). The incident cosine is
/// clamped to [0, 1]: light arrives from outside the conductor.
vec3 fresnel_conductor(float cos_theta_i, vec3 eta, vec3 k) {
    precise float c = clamp(cos_theta_i, 0.0, 1.0);
    precise float cos_theta_i_2 = c * c;
    precise float sin_theta_i_2 = 1.0 - cos_theta_i_2;
    precise float sin_theta_i_4 = sin_theta_i_2 * sin_theta_i_2;

    precise vec3 temp_1 = eta * eta - k * k - sin_theta_i_2;
    precise vec3 a_2_pb_2 = safe_sqrt(temp_1 * temp_1 + 4.0 * k * k * eta * eta);
    precise vec3 a = safe_sqrt(0.5 * (a_2_pb_2 + temp_1));

    precise vec3 term_1 = a_2_pb_2 + cos_theta_i_2;
    precise vec3 term_2 = 2.0 * c * a;
    precise vec3 d_s = term_1 + term_2;
    // 0/0 only for the degenerate index 1 + 0i at grazing incidence (or 0 + 0i): reflect fully
    precise vec3 r_s = mix(vec3(1.0), (term_1 - term_2) / max(d_s, vec3(1e-30)), greaterThan(d_s, vec3(0.0)));

    precise vec3 term_3 = a_2_pb_2 * cos_theta_i_2 + sin_theta_i_4;
    precise vec3 term_4 = term_2 * sin_theta_i_2;
    precise vec3 d_p = term_3 + term_4;
    precise vec3 r_p = r_s * mix(vec3(1.0), (term_3 - term_4) / max(d_p, vec3(1e-30)), greaterThan(d_p, vec3(0.0)));

    return clamp(0.5 * (r_s + r_p), vec3(0.0), vec3(1.0));
}

/// Schlick weight (1 − cos)^5 with the argument clamped (principledhelpers.h `schlick_weight`).
float schlick_weight(float cos_i) {
    float m = clamp(1.0 - cos_i, 0.0, 1.0);
    float m2 = m * m;
    return m2 * m2 * m;
}

/// Normal-incidence reflectance of a dielectric with relative IOR eta: ((η − 1) / (η + 1))².
float schlick_R0_eta(float eta) { return sqr((eta - 1.0) / (eta + 1.0)); }

/// Schlick's approximation R0 + (1 − R0)(1 − cos)^5 as Mitsuba's principled BSDF evaluates it
/// (`calc_schlick`): uses the transmitted angle when the ray travels into the optically thinner
/// medium (eta_it <= 1). `cos_theta_i` is signed, as in `fresnel_dielectric`.
vec3 schlick_fresnel(vec3 R0, float cos_theta_i, float eta) {
    bool outside = cos_theta_i >= 0.0;
    float rcp_eta = 1.0 / eta;
    float eta_it = outside ? eta : rcp_eta;
    float eta_ti = outside ? rcp_eta : eta;
    float cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    float cos_theta_t = safe_sqrt(cos_theta_t_sqr);
    float w = eta_it > 1.0 ? schlick_weight(abs(cos_theta_i)) : schlick_weight(cos_theta_t);
    return mix(vec3(w), vec3(1.0), R0);
}
float schlick_fresnel(float R0, float cos_theta_i, float eta) {
    return schlick_fresnel(vec3(R0), cos_theta_i, eta).x;
}

#endif // COMMON_BSDF_FRESNEL_GLSL
