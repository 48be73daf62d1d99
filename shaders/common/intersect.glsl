// Ray/primitive tests. Triangles: the watertight test of Woop, Benthin & Wald 2013 (JCGT 2(1)),
// so rays never slip between triangles sharing an edge. Spheres: the numerically careful
// quadratic of Haines et al., "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing
// Gems ch. 7). Boxes: slab test with a direction whose tiny components are clamped before the
// reciprocal, so no NaN can arise (SPIR-V FMin/FMax are undefined on NaN), and a far distance
// enlarged by 1 + 2γ3 (Ize 2013) so a box is never missed by rounding.
#ifndef COMMON_INTERSECT_GLSL
#define COMMON_INTERSECT_GLSL
#include "common/math.glsl"

struct Ray {
    vec3 o;
    vec3 d;     // unit length
    float tmin;
    float tmax;
};

// Per-ray constants of the watertight triangle test and the slab test.
struct RayPre {
    ivec3 k;    // kx, ky, kz: kz the dominant axis of d
    vec3 s;     // shear constants Sx, Sy, Sz
    vec3 inv_d; // clamped reciprocal direction
};

// pbrt's γn = nε / (1 − nε), ε = 2^-24: bounds on the relative error of n rounded operations.
const float GAMMA2 = (2.0 * 5.96046448e-8) / (1.0 - 2.0 * 5.96046448e-8);
const float GAMMA3 = (3.0 * 5.96046448e-8) / (1.0 - 3.0 * 5.96046448e-8);
const float GAMMA5 = (5.0 * 5.96046448e-8) / (1.0 - 5.0 * 5.96046448e-8);
const float GAMMA3_BOX = 1.0 + 2.0 * GAMMA3;

RayPre ray_precompute(vec3 d) {
    RayPre pre;
    vec3 ad = abs(d);
    int kz = (ad.x > ad.y) ? ((ad.x > ad.z) ? 0 : 2) : ((ad.y > ad.z) ? 1 : 2);
    int kx = (kz + 1) % 3;
    int ky = (kx + 1) % 3;
    // Swap kx and ky to preserve the winding when the dominant component is negative.
    if (d[kz] < 0.0) { int t = kx; kx = ky; ky = t; }
    pre.k = ivec3(kx, ky, kz);
    pre.s = vec3(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    const float tiny = 1e-30;
    vec3 dc = mix(d, mix(vec3(tiny), vec3(-tiny), lessThan(d, vec3(0.0))), lessThan(ad, vec3(tiny)));
    pre.inv_d = 1.0 / dc;
    return pre;
}

// Returns the entry distance or +inf when the box [bmin, bmax] is missed within (tmin, tmax).
float intersect_box(vec3 o, RayPre pre, vec3 bmin, vec3 bmax, float tmin, float tmax) {
    vec3 t0 = (bmin - o) * pre.inv_d;
    vec3 t1 = (bmax - o) * pre.inv_d;
    vec3 tn = min(t0, t1);
    vec3 tf = max(t0, t1) * GAMMA3_BOX;
    float enter = max(max(tn.x, tn.y), max(tn.z, tmin));
    float leave = min(min(tf.x, tf.y), min(tf.z, tmax));
    return enter <= leave ? enter : uintBitsToFloat(0x7f800000u);
}

// Watertight ray/triangle test. On a hit within (tmin, tmax) returns true with t and the
// barycentrics (b1, b2) of v1 and v2.
bool intersect_triangle(Ray r, RayPre pre, vec3 p0, vec3 p1, vec3 p2, out float t, out vec2 b12) {
    t = 0.0; b12 = vec2(0.0);
    // Step 1: translate to the ray origin, permute so z is dominant, shear.
    vec3 a = p0 - r.o, b = p1 - r.o, c = p2 - r.o;
    float ax = a[pre.k.x] - pre.s.x * a[pre.k.z];
    float ay = a[pre.k.y] - pre.s.y * a[pre.k.z];
    float bx = b[pre.k.x] - pre.s.x * b[pre.k.z];
    float by = b[pre.k.y] - pre.s.y * b[pre.k.z];
    float cx = c[pre.k.x] - pre.s.x * c[pre.k.z];
    float cy = c[pre.k.y] - pre.s.y * c[pre.k.z];
    // Step 2: scaled barycentrics (edge functions).
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    float det = u + v + w;
    if (det == 0.0) return false;
    // Step 3: scaled distance, compared without dividing.
    float az = pre.s.z * a[pre.k.z];
    float bz = pre.s.z * b[pre.k.z];
    float cz = pre.s.z * c[pre.k.z];
    float ts = u * az + v * bz + w * cz;
    float inv_det = 1.0 / det;
    t = ts * inv_det;
    if (!(t > r.tmin && t < r.tmax)) return false;
    // Step 4: t conservatively positive (pbrt-v3 §3.9.6, its bound on t's rounding error from
    // the sheared coordinates and edge functions). A ray leaves a surface from an origin pushed
    // off it by the hit point's error bound (surface.glsl's offset_origin); where that bound is
    // small next to the vertices' coordinates (the surface's plane passes near the camera, the
    // origin of the render's coordinates) a ray leaving at a grazing angle could find the surface
    // it left again at a t that is rounding noise, and lose the light beyond it.
    float max_xt = max(max(abs(ax), abs(bx)), abs(cx));
    float max_yt = max(max(abs(ay), abs(by)), abs(cy));
    float max_zt = max(max(abs(az), abs(bz)), abs(cz));
    float delta_z = GAMMA3 * max_zt;
    float delta_x = GAMMA5 * (max_xt + max_zt);
    float delta_y = GAMMA5 * (max_yt + max_zt);
    float delta_e = 2.0 * (GAMMA2 * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    float max_e = max(max(abs(u), abs(v)), abs(w));
    float delta_t = 3.0 * (GAMMA3 * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * abs(inv_det);
    if (!(t > delta_t)) return false;
    b12 = vec2(v, w) * inv_det;
    return true;
}

// The two roots (near, far) of the ray's line and the sphere; false when the line misses it.
bool sphere_roots(Ray r, vec3 center, float radius, out float tn, out float tf) {
    tn = 0.0; tf = 0.0;
    vec3 f = r.o - center;
    float bq = -dot(f, r.d);
    vec3 l = f + bq * r.d;             // f minus its projection on d: accurate perpendicular
    float disc = radius * radius - dot(l, l);
    if (disc < 0.0) return false;
    float cq = dot(f, f) - radius * radius;
    float q = bq + (bq >= 0.0 ? 1.0 : -1.0) * sqrt(disc);
    float t0 = (q != 0.0) ? cq / q : 0.0;
    float t1 = q;
    tn = min(t0, t1); tf = max(t0, t1);
    return true;
}

// Ray/sphere test; returns the nearest root within (tmin, tmax).
bool intersect_sphere(Ray r, vec3 center, float radius, out float t) {
    float tn, tf;
    t = 0.0;
    if (!sphere_roots(r, center, radius, tn, tf)) return false;
    if (tn > r.tmin && tn < r.tmax) { t = tn; return true; }
    if (tf > r.tmin && tf < r.tmax) { t = tf; return true; }
    return false;
}

// The uv of a triangle's point of barycentrics b12 (of v1, v2) when its mesh has no texture
// coordinates: Mitsuba's (b1, b2), whose v = 0 is a texture's top row; candela reads v = 1
// there, so v is returned flipped (as sphere_uv's). renderer/src/compile/prims.rs's shading
// records hold the same corners.
vec2 barycentric_uv(vec2 b12) { return vec2(b12.x, 1.0 - b12.y); }

// Mitsuba's sphere parameterisation at `local` (a point of the sphere of `radius` minus its
// centre): u = longitude around +z / 2π, v = colatitude / π, with v = 0 on a texture's top row;
// candela reads v = 1 there, so v is returned flipped.
vec2 sphere_uv(vec3 local, float radius) {
    float phi = atan(local.y, local.x);
    if (phi < 0.0) phi += 2.0 * PI;
    float theta = safe_acos(local.z / radius);
    return vec2(phi * INV_2PI, 1.0 - theta * INV_PI);
}

#endif
