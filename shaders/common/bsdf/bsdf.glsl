//! BSDF interface for all integrators: material types, the SurfaceParams / BsdfSample structs and
//! bsdf_eval / bsdf_pdf / bsdf_sample dispatching on the material type. Every material means
//! exactly what the same-named Mitsuba 3 plugin means (see SCENE_FORMAT.md); each lives in its
//! own file next to this one. The `twosided` handling is Mitsuba 3 `src/bsdfs/twosided.cpp`:
//! a back-side query mirrors wo and wi (z → −z) and evaluates the front side.
//!
//! Conventions: wo, wi are unit vectors in the local shading frame (z = shading normal,
//! x = tangent, along which anisotropy stretches), both pointing away from the surface; wo is
//! the direction the path arrived from (Mitsuba's si.wi), wi the sampled/evaluated one (Mitsuba's
//! wo). Functions never return NaN/Inf: invalid configurations give 0 / false.
#ifndef COMMON_BSDF_GLSL
#define COMMON_BSDF_GLSL

#include "common/math.glsl"
#include "common/sampling.glsl"

// MAT_* (material types) and MATF_* (MATF_TWO_SIDED: reflection is two-sided, Mitsuba's
// twosided wrapper; MATF_HAS_ETA_K: conductor c1 = eta, c2 = k given, else Fresnel = 1) come
// from the Rust side (renderer/src/layout.rs, `mat`).
#include "common/constants.glsl"

// The material models this kernel compiles: every one, unless the kernel is specialised to the
// scene (MATERIALS_SPECIALISED, renderer/src/compile/features.rs), which defines HAS_MAT_* for
// the models its primitives use; the dispatch below then holds no code for the others.
#ifndef MATERIALS_SPECIALISED
#define HAS_MAT_DIFFUSE 1
#define HAS_MAT_CONDUCTOR 1
#define HAS_MAT_DIELECTRIC 1
#define HAS_MAT_PRINCIPLED 1
#define HAS_MAT_PHONG 1
#endif

// A kernel that compiles one model knows every material's type (MAT_SOLE): the dispatch and the
// integrators' tests of the type (`material_type`) then fold away.
#if (defined(HAS_MAT_DIFFUSE) + defined(HAS_MAT_CONDUCTOR) + defined(HAS_MAT_DIELECTRIC) + \
     defined(HAS_MAT_PRINCIPLED) + defined(HAS_MAT_PHONG)) == 1
#if defined(HAS_MAT_DIFFUSE)
#define MAT_SOLE MAT_DIFFUSE
#elif defined(HAS_MAT_CONDUCTOR)
#define MAT_SOLE MAT_CONDUCTOR
#elif defined(HAS_MAT_DIELECTRIC)
#define MAT_SOLE MAT_DIELECTRIC
#elif defined(HAS_MAT_PRINCIPLED)
#define MAT_SOLE MAT_PRINCIPLED
#else
#define MAT_SOLE MAT_PHONG
#endif
#define material_type(m) MAT_SOLE
#else
#define material_type(m) ((m).type)
#endif

#define TRANSPORT_RADIANCE 0u
#define TRANSPORT_IMPORTANCE 1u
#define BSDF_DELTA 1u          // sampled lobe is perfectly specular (pdf is a discrete probability)
#define BSDF_TRANSMISSION 2u   // wi is on the other side of the surface

/// A material with its textures already looked up at the shading point.
struct SurfaceParams {
    uint type;
    uint flags;
    vec3 c0;  // diffuse: reflectance | conductor: specular reflectance | dielectric: specular reflectance | principled: base_color | phong: diffuse
    vec3 c1;  // conductor: eta | dielectric: specular transmittance | phong: specular
    vec3 c2;  // conductor: k
    float s[12]; // conductor: s[0] roughness, s[1] anisotropy | dielectric: s[0] roughness, s[1] ior
                 // principled: s[0] metallic, s[1] roughness, s[2] specular, s[3] spec_tint, s[4] anisotropic,
                 //   s[5] sheen, s[6] sheen_tint, s[7] spec_trans, s[8] ior, s[9] subsurface, s[10] clearcoat, s[11] clearcoat_gloss
                 //   (s[8] > 0: Mitsuba `eta` = s[8]; s[8] <= 0: eta derived from `specular` s[2])
                 // phong: s[0] exponent
};

/// Result of bsdf_sample. weight = f·|cos θi| / pdf (for a delta lobe: the lobe's weight, i.e.
/// its value divided by the discrete probability `pdf` of choosing it). eta: relative IOR of the
/// crossing in the direction of travel (η_inside/η_outside entering, its inverse leaving; 1 for
/// reflection), for Russian roulette's η² bookkeeping as in Mitsuba.
struct BsdfSample { vec3 wi; vec3 weight; float pdf; uint flags; float eta; };

#include "common/bsdf/microfacet.glsl"
#include "common/bsdf/fresnel.glsl"
#include "common/bsdf/diffuse.glsl"
#include "common/bsdf/conductor.glsl"
#include "common/bsdf/dielectric.glsl"
#include "common/bsdf/principled.glsl"
#include "common/bsdf/phong.glsl"

/// True for materials that only reflect and therefore go through the twosided logic:
/// diffuse, conductor, phong, and principled without specular transmission.
bool bsdf_reflection_only(in SurfaceParams m) {
    uint t = material_type(m);
    return t == MAT_DIFFUSE || t == MAT_CONDUCTOR || t == MAT_PHONG ||
           (t == MAT_PRINCIPLED && !(m.s[7] > 0.0));
}

/// Mirrors a back-side query of a two-sided reflector to the front (Mitsuba `twosided`).
/// Returns false when the query is black: grazing wo, or the back of a one-sided material.
bool bsdf_resolve_side(in SurfaceParams m, inout vec3 wo, out bool flipped) {
    flipped = false;
    if (!bsdf_reflection_only(m)) return true;
    if (wo.z == 0.0) return false;
    if (wo.z < 0.0) {
        if ((m.flags & MATF_TWO_SIDED) == 0u) return false;
        wo.z = -wo.z;
        flipped = true;
    }
    return true;
}

bool bsdf_finite(vec3 v) { return !(any(isnan(v)) || any(isinf(v))); }
bool bsdf_finite(float x) { return !(isnan(x) || isinf(x)); }

/// f(wo, wi) · |cos θi|; 0 for delta lobes.
vec3 bsdf_eval(in SurfaceParams m, vec3 wo, vec3 wi, uint mode) {
    bool flipped;
    if (!bsdf_resolve_side(m, wo, flipped)) return vec3(0.0);
    if (flipped) wi.z = -wi.z;
    vec3 f;
    switch (material_type(m)) {
#ifdef HAS_MAT_DIFFUSE
        case MAT_DIFFUSE: f = diffuse_eval(m, wo, wi); break;
#endif
#ifdef HAS_MAT_CONDUCTOR
        case MAT_CONDUCTOR: f = conductor_eval(m, wo, wi); break;
#endif
#ifdef HAS_MAT_DIELECTRIC
        case MAT_DIELECTRIC: f = dielectric_eval(m, wo, wi, mode); break;
#endif
#ifdef HAS_MAT_PRINCIPLED
        case MAT_PRINCIPLED: f = principled_eval(m, wo, wi, mode); break;
#endif
#ifdef HAS_MAT_PHONG
        case MAT_PHONG: f = phong_eval(m, wo, wi); break;
#endif
        default: f = vec3(0.0); break;
    }
    return bsdf_finite(f) ? max(f, vec3(0.0)) : vec3(0.0);
}

/// Solid-angle density with which bsdf_sample produces wi through its non-delta lobes.
float bsdf_pdf(in SurfaceParams m, vec3 wo, vec3 wi) {
    bool flipped;
    if (!bsdf_resolve_side(m, wo, flipped)) return 0.0;
    if (flipped) wi.z = -wi.z;
    float pdf;
    switch (material_type(m)) {
#ifdef HAS_MAT_DIFFUSE
        case MAT_DIFFUSE: pdf = diffuse_pdf(m, wo, wi); break;
#endif
#ifdef HAS_MAT_CONDUCTOR
        case MAT_CONDUCTOR: pdf = conductor_pdf(m, wo, wi); break;
#endif
#ifdef HAS_MAT_DIELECTRIC
        case MAT_DIELECTRIC: pdf = dielectric_pdf(m, wo, wi); break;
#endif
#ifdef HAS_MAT_PRINCIPLED
        case MAT_PRINCIPLED: pdf = principled_pdf(m, wo, wi); break;
#endif
#ifdef HAS_MAT_PHONG
        case MAT_PHONG: pdf = phong_pdf(m, wo, wi); break;
#endif
        default: pdf = 0.0; break;
    }
    return (bsdf_finite(pdf) && pdf > 0.0) ? pdf : 0.0;
}

/// Samples wi given wo and three uniforms u in [0,1) (u.x picks the lobe, u.yz the direction).
/// Returns false when no direction was produced (s is then zeroed); a produced sample may still
/// carry a zero weight (e.g. a black reflectance), as in Mitsuba.
bool bsdf_sample(in SurfaceParams m, vec3 wo, vec3 u, uint mode, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
    bool flipped;
    if (!bsdf_resolve_side(m, wo, flipped)) return false;
    bool ok;
    switch (material_type(m)) {
#ifdef HAS_MAT_DIFFUSE
        case MAT_DIFFUSE: ok = diffuse_sample(m, wo, u, s); break;
#endif
#ifdef HAS_MAT_CONDUCTOR
        case MAT_CONDUCTOR: ok = conductor_sample(m, wo, u, s); break;
#endif
#ifdef HAS_MAT_DIELECTRIC
        case MAT_DIELECTRIC: ok = dielectric_sample(m, wo, u, mode, s); break;
#endif
#ifdef HAS_MAT_PRINCIPLED
        case MAT_PRINCIPLED: ok = principled_sample(m, wo, u, mode, s); break;
#endif
#ifdef HAS_MAT_PHONG
        case MAT_PHONG: ok = phong_sample(m, wo, u, s); break;
#endif
        default: ok = false; break;
    }
    if (flipped) s.wi.z = -s.wi.z;
    ok = ok && s.pdf > 0.0 && bsdf_finite(s.pdf) && bsdf_finite(s.weight) && bsdf_finite(s.wi) &&
         bsdf_finite(s.eta) && s.eta > 0.0;
    if (!ok) {
        s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 0u, 1.0);
        return false;
    }
    s.weight = max(s.weight, vec3(0.0));
    return true;
}

/// True when every lobe is perfectly specular (next-event estimation cannot help).
bool bsdf_is_delta(in SurfaceParams m) {
#ifdef HAS_MAT_CONDUCTOR
    if (material_type(m) == MAT_CONDUCTOR) return conductor_is_delta(m);
#endif
#ifdef HAS_MAT_DIELECTRIC
    if (material_type(m) == MAT_DIELECTRIC) return dielectric_is_delta(m);
#endif
    return false;
}

/// Cheap reflectance estimate in [0, 1] (Russian roulette, debugging); not an exact albedo.
vec3 bsdf_albedo_hint(in SurfaceParams m) {
    vec3 a;
    switch (material_type(m)) {
#ifdef HAS_MAT_DIFFUSE
        case MAT_DIFFUSE: a = m.c0; break;
#endif
#ifdef HAS_MAT_CONDUCTOR
        case MAT_CONDUCTOR: a = m.c0 * conductor_fresnel(m, 1.0); break;
#endif
#ifdef HAS_MAT_DIELECTRIC
        case MAT_DIELECTRIC: {
            float F0 = fresnel_dielectric(1.0, max(m.s[1], 1e-3));
            a = m.c0 * F0 + m.c1 * (1.0 - F0);
            break;
        }
#endif
#ifdef HAS_MAT_PRINCIPLED
        case MAT_PRINCIPLED: {
            float metallic = clamp(m.s[0], 0.0, 1.0);
            float spec_trans = clamp(m.s[7], 0.0, 1.0);
            vec3 base = max(m.c0, vec3(0.0));
            a = base * ((1.0 - metallic) * (1.0 - spec_trans) + metallic) +
                sqrt(base) * ((1.0 - metallic) * spec_trans) + vec3(0.04 * (1.0 - metallic));
            break;
        }
#endif
#ifdef HAS_MAT_PHONG
        case MAT_PHONG: a = m.c0 + m.c1; break;
#endif
        default: a = vec3(0.0); break;
    }
    return bsdf_finite(a) ? clamp(a, vec3(0.0), vec3(1.0)) : vec3(0.0);
}

#endif // COMMON_BSDF_GLSL
