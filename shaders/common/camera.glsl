// Primary rays: perspective (pinhole) and thin-lens cameras with Mitsuba 3's conventions
// (vertical field of view, focus plane at focus_distance along the view axis), and the pixel
// filter by importance sampling (box: uniform over the pixel; gaussian: a normal distribution
// truncated at 4σ, so every sample has weight 1 and pixels need no splatting). The camera sits
// at the origin: geometry is uploaded camera-relative.
#ifndef COMMON_CAMERA_GLSL
#define COMMON_CAMERA_GLSL
#include "common/bindings.glsl"
#include "common/intersect.glsl"
#include "common/rng.glsl"
#include "common/sampling.glsl"

// Offset from the pixel centre drawn from the film's filter.
vec2 sample_filter(vec2 u) {
    if (g.film.z == 1u) {
        // Box-Muller, truncated to the filter radius by clamping the radial sample.
        float sigma = g.filter_params.x, radius = g.filter_params.y;
        float rmax2 = radius * radius / (sigma * sigma);
        // Radius of a 2D normal with its CDF truncated at rmax: r² = −2 ln(1 − u·(1 − e^{−rmax²/2})).
        float r = sigma * sqrt(-2.0 * log(1.0 - u.x * (1.0 - exp(-0.5 * rmax2))));
        float phi = 2.0 * PI * u.y;
        return vec2(cos(phi), sin(phi)) * r;
    }
    return u - 0.5;
}

Ray camera_ray(uvec2 px, inout Rng rng) {
    vec4 u = rng_next4(rng);
    vec2 film = vec2(px) + 0.5 + sample_filter(u.xy);
    vec2 res = vec2(g.film.xy);
    float tan_half = g.lens.x, aspect = g.lens.y;
    // Screen position: +x right, +y up, row 0 at the top.
    float sx = (2.0 * film.x / res.x - 1.0) * tan_half * aspect;
    float sy = (1.0 - 2.0 * film.y / res.y) * tan_half;
    vec3 d = g.cam_forward.xyz + sx * g.cam_right.xyz + sy * g.cam_up.xyz;
    Ray r;
    r.o = vec3(0.0);
    r.tmin = 0.0;
    r.tmax = FLT_MAX_C;
    float aperture = g.lens.z;
    if (aperture > 0.0) {
        // Thin lens: the focus point lies on the plane at focus_distance along the view axis.
        vec3 focus = d * g.lens.w; // d has unit component along cam_forward
        vec2 lens = aperture * sample_uniform_disk_concentric(u.zw);
        r.o = lens.x * g.cam_right.xyz + lens.y * g.cam_up.xyz;
        r.d = normalize(focus - r.o);
    } else {
        r.d = normalize(d);
    }
    return r;
}

#endif
