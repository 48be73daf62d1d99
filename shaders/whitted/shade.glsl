// `whitted`: every material mapped to its classic Whitted equivalent (see
// renderer/src/integrators/whitted.rs): "local" lobes lit by shadow rays and the ambient term,
// evaluated with the exact BSDFs of common/bsdf, and perfect mirror reflection / refraction
// branches that the kernel follows with their weights.
#ifndef WHITTED_SHADE_GLSL
#define WHITTED_SHADE_GLSL
#include "common/material.glsl"

#ifndef WHITTED_MIRROR_ROUGHNESS
#define WHITTED_MIRROR_ROUGHNESS 0.2
#endif

struct Classic {
    bool has_local;        // local lobes present: direct light and ambient
    SurfaceParams local;   // the BSDF of the local lobes (wo/wi in the shading frame)
    vec3 ambient;          // albedo of the local lobes, times the environment along the normal
    vec3 kr;               // weight of the mirror-reflected branch (0: none)
    vec3 kt;               // weight of the refracted branch (0: none)
    vec3 wt;               // refracted direction, local frame (valid when kt > 0)
};

// Refraction through a smooth interface of relative IOR eta (inside / outside, normal = +z):
// returns F and the refracted direction wt (F = 1 on total internal reflection), and eta_ti, the
// factor whose square scales transmitted radiance (Mitsuba's radiance-mode 1/η²).
float whitted_refract(vec3 wo, float eta, out vec3 wt, out float eta_ti) {
    float cos_theta_t, eta_it;
    float F = fresnel_dielectric(wo.z, eta, cos_theta_t, eta_it, eta_ti);
    wt = vec3(0.0, 0.0, 1.0);
    if (F < 1.0) {
        vec3 w = vec3(-eta_ti * wo.x, -eta_ti * wo.y, cos_theta_t);
        if (w.z * wo.z < 0.0) wt = normalize(w); else F = 1.0;
    }
    return F;
}

// The classic decomposition of material m seen from wo (local frame, either side).
Classic classic_material(in SurfaceParams m, vec3 wo) {
    Classic c;
    c.has_local = false;
    c.local = m;
    c.ambient = vec3(0.0);
    c.kr = vec3(0.0);
    c.kt = vec3(0.0);
    c.wt = vec3(0.0, 0.0, 1.0);
    // Reflection-only materials: the back of a one-sided one is black (bsdf.glsl's rule).
    if (bsdf_reflection_only(m) && wo.z < 0.0 && (m.flags & MATF_TWO_SIDED) == 0u) return c;
    float cos_o = abs(wo.z);

    // (Each model compiles only where the kernel has it: common/bsdf/bsdf.glsl's HAS_MAT_*.)
    if (false) {
#ifdef HAS_MAT_DIFFUSE
    } else if (material_type(m) == MAT_DIFFUSE) {
        // Step 1: Lambert, lit locally.
        c.has_local = true;
        c.ambient = m.c0;
#endif
#ifdef HAS_MAT_PHONG
    } else if (material_type(m) == MAT_PHONG) {
        // Step 1: diffuse + specular highlight, lit locally.
        c.has_local = true;
        c.ambient = m.c0 + m.c1;
#endif
#ifdef HAS_MAT_CONDUCTOR
    } else if (material_type(m) == MAT_CONDUCTOR) {
        if (m.s[0] < WHITTED_MIRROR_ROUGHNESS) {
            // Step 1: a mirror tinted by reflectance × Fresnel at this angle.
            c.kr = m.c0 * conductor_fresnel(m, cos_o);
        } else {
            // Step 1: rough: the exact rough conductor, lit locally.
            c.has_local = true;
            c.ambient = m.c0 * conductor_fresnel(m, 1.0);
        }
#endif
#ifdef HAS_MAT_DIELECTRIC
    } else if (material_type(m) == MAT_DIELECTRIC) {
        // Step 1: smooth interface whatever the roughness: F-weighted reflection and refraction.
        float eta_ti;
        float F = whitted_refract(wo, dielectric_eta(m, false), c.wt, eta_ti);
        c.kr = m.c0 * F;
        c.kt = m.c1 * ((1.0 - F) * eta_ti * eta_ti);
#endif
#ifdef HAS_MAT_PRINCIPLED
    } else if (material_type(m) == MAT_PRINCIPLED) {
        PrincipledParams p = principled_unpack(m);
        if (p.roughness >= WHITTED_MIRROR_ROUGHNESS) {
            // Step 1: rough: the full principled BSDF, lit locally.
            c.has_local = true;
            c.ambient = bsdf_albedo_hint(m);
        } else {
            // Step 1: Lambertian diffuse part, lit locally.
            vec3 kd = p.base_color * p.brdf;
            c.local.type = MAT_DIFFUSE;
            c.local.c0 = kd;
            c.has_local = any(greaterThan(kd, vec3(0.0))) && (wo.z > 0.0 || p.spec_trans == 0.0);
            c.ambient = kd;
            // Step 2: specular mirror: dielectric Fresnel, blended to Schlick(base_color) by metallic.
            float eta_ti;
            vec3 wt;
            // (a two-sided reflector seen from the back is mirrored to the front, as bsdf.glsl)
            vec3 wo_f = p.spec_trans > 0.0 ? wo : vec3(wo.xy, cos_o);
            float F = whitted_refract(wo_f, p.eta, wt, eta_ti);
            vec3 F_metal = schlick_fresnel(p.base_color, wo_f.z, p.eta);
            c.kr = vec3((1.0 - p.metallic) * F) + p.metallic * F_metal;
            // Step 3: specular transmission, tinted by sqrt(base_color) as Mitsuba's principled.
            if (p.spec_trans > 0.0 && F < 1.0) {
                // (wt is in wo's frame: spec_trans > 0 means wo_f == wo)
                c.wt = wt;
                c.kt = sqrt(p.base_color) * (p.bsdf * (1.0 - F) * eta_ti * eta_ti);
            }
        }
#endif
    }
    return c;
}

// Whether any material this kernel compiles can branch (mirror reflection or refraction):
// conductors, dielectrics and principled surfaces can; diffuse and phong are local only. Without
// them every ray tree is the camera ray alone and the kernel needs no ray stack.
#if defined(HAS_MAT_CONDUCTOR) || defined(HAS_MAT_DIELECTRIC) || defined(HAS_MAT_PRINCIPLED)
#define WHITTED_BRANCHES 1
#else
#define WHITTED_BRANCHES 0
#endif

#endif
