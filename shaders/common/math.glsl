//! Shared math constants and helpers: safe sqrt/acos, luminance, orthonormal frames.
//! The frame construction is Duff et al. 2017, "Building an Orthonormal Basis, Revisited"
//! (JCGT 6(1)), the same branchless basis Mitsuba 3 uses in `coordinate_system()`.
//! Include with `#include "common/math.glsl"` (GL_GOOGLE_include_directive).
#ifndef COMMON_MATH_GLSL
#define COMMON_MATH_GLSL

#define PI 3.14159265358979323846
#define INV_PI 0.31830988618379067154
#define INV_2PI 0.15915494309189533577
#define INV_4PI 0.07957747154594766788
/// Largest finite float (FLT_MAX rounded down in its last decimal so it still parses as finite).
#define FLT_MAX_C 3.402823466e38

/// x².
float sqr(float x) { return x * x; }

/// sqrt(max(x, 0)): never NaN for slightly negative round-off.
float safe_sqrt(float x) { return sqrt(max(x, 0.0)); }
vec3 safe_sqrt(vec3 x) { return sqrt(max(x, vec3(0.0))); }

/// acos with its argument clamped to [-1, 1].
float safe_acos(float x) { return acos(clamp(x, -1.0, 1.0)); }

/// Rec.709 / sRGB-primaries luminance of a linear RGB colour (Mitsuba's `luminance()`).
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

/// Largest of the three components.
float max_comp(vec3 v) { return max(v.x, max(v.y, v.z)); }

/// Orthonormal basis (t, b, n) around the unit vector n, right-handed: cross(t, b) == n.
/// Duff et al. 2017, Listing 3 (branchless, no singularity at n.z = -1).
void make_frame(vec3 n, out vec3 t, out vec3 b) {
    float sgn = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + n.z);
    float bxy = n.x * n.y * a;
    t = vec3(1.0 + sgn * n.x * n.x * a, sgn * bxy, -sgn * n.x);
    b = vec3(bxy, sgn + n.y * n.y * a, -n.y);
}

/// World → local: components of v along (t, b, n).
vec3 to_local(vec3 v, vec3 t, vec3 b, vec3 n) { return vec3(dot(v, t), dot(v, b), dot(v, n)); }

/// Local → world: v.x·t + v.y·b + v.z·n.
vec3 from_local(vec3 v, vec3 t, vec3 b, vec3 n) { return v.x * t + v.y * b + v.z * n; }

#endif // COMMON_MATH_GLSL
