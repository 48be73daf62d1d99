// Primary rays: perspective (pinhole) and thin-lens cameras with Mitsuba 3's conventions
// (vertical field of view, focus plane at focus_distance along the view axis), and the pixel
// filter by importance sampling (common/filter.glsl: every sample has weight 1 and lands on the
// film, so pixels need no splatting). The camera sits at the origin: geometry is uploaded
// camera-relative.
#ifndef COMMON_CAMERA_GLSL
#define COMMON_CAMERA_GLSL
#include "common/bindings.glsl"
#include "common/intersect.glsl"
#include "common/rng.glsl"
#include "common/sampling.glsl"
#include "common/filter.glsl"

Ray camera_ray(uvec2 px, inout Rng rng) {
    vec4 u = rng_next4(rng);
    vec2 film = vec2(px) + 0.5 + filter_sample(u.xy, px);
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
    if (CAMERA_THIN_LENS) {
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
