// The camera as a sensor that light paths can reach (light tracing, bidirectional methods): the
// inverse of camera.glsl's camera_ray. After pbrt-v3's PerspectiveCamera::We / Pdf_We / Sample_Wi,
// with the pixel filter made explicit.
//
// camera_ray draws a film position x (in pixels) from pixel j's normalised filter p_f(x − c_j)
// (common/filter.glsl's filter_eval: cut at the film's edge, so x always lies on the film)
// and a lens point uniformly, and traces towards the focus point of x. A direction ω leaving lens
// point pl at angle θ to the view axis therefore carries the importance, per unit lens area and
// solid angle,
//     W_j(pl, ω) = p_f(x(ω) − c_j) / (s² cos³θ) · 1/(π r_lens²),
// s = 2 tan(fov_y/2) / height the pixel size at unit distance (dω = s² cos³θ dx for both the
// pinhole and the thin lens). Connecting a light-path vertex y to a lens point sampled uniformly
// (pdf 1/(π r_lens²), which cancels) gives the splat for pixel j
//     β f(y → pl) |cos_y| · p_f(x − c_j) / (s² cos³θ d²),
// and the image is Σ splats / (number of light paths) — one per pixel and sample.
// For MIS, the camera's directional density is pbrt's: uniform over the whole film,
// 1 / (A cos³θ) with A = width · height · s², independent of the filter; it is nonzero on the
// film.
#ifndef COMMON_CAMERA_WE_GLSL
#define COMMON_CAMERA_WE_GLSL
#include "common/bindings.glsl"
#include "common/math.glsl"
#include "common/sampling.glsl"
#include "common/filter.glsl"

// Pixel size at unit distance from the pinhole (square pixels: aspect = width / height).
float camera_pixel_size() { return 2.0 * g.lens.x / float(g.film.y); }

// Film position (pixels, row 0 at the top) that the ray from lens point pl in direction w
// (unit) comes from, and cos θ to the view axis. False behind the camera or off the film (no
// filter sample lands off it: common/filter.glsl).
bool camera_film_position(vec3 pl, vec3 w, out vec2 film, out float cos_theta) {
    film = vec2(-1.0);
    cos_theta = dot(w, g.cam_forward.xyz);
    if (!(cos_theta > 0.0)) return false;
    // The point where the ray meets the focus plane (unit distance for the pinhole), projected
    // through the lens centre as camera_ray's screen coordinates.
    float dist = CAMERA_THIN_LENS ? g.lens.w : 1.0;
    vec3 pf = pl + w * (dist / cos_theta);
    float sx = dot(pf, g.cam_right.xyz) / dist, sy = dot(pf, g.cam_up.xyz) / dist;
    vec2 res = vec2(g.film.xy);
    float tan_half = g.lens.x, aspect = g.lens.y;
    film = vec2((sx / (tan_half * aspect) + 1.0) * 0.5 * res.x, (1.0 - sy / tan_half) * 0.5 * res.y);
    return film.x >= 0.0 && film.x <= res.x && film.y >= 0.0 && film.y <= res.y;
}

// pbrt's Pdf_We directional density for a direction at cos θ to the view axis: 1 / (A cos³θ).
float camera_pdf_dir(float cos_theta) {
    float s = camera_pixel_size();
    float area = float(g.film.x) * float(g.film.y) * s * s;
    return cos_theta > 0.0 ? 1.0 / (area * cos_theta * cos_theta * cos_theta) : 0.0;
}

// A lens point for a connection (t = 1), uniform on the aperture (the origin for a pinhole).
vec3 camera_sample_lens(vec2 u) {
    if (!CAMERA_THIN_LENS) return vec3(0.0);
    float aperture = g.lens.z;
    vec2 lens = aperture * sample_uniform_disk_concentric(u);
    return lens.x * g.cam_right.xyz + lens.y * g.cam_up.xyz;
}

// Importance factor of a connection from a point at distance² d2 seen at cos θ: the splat of
// pixel j is this · p_f(x − c_j) · β f |cos_y| (see the top).
float camera_connection_we(float cos_theta, float d2) {
    float s = camera_pixel_size();
    return 1.0 / (s * s * cos_theta * cos_theta * cos_theta * d2);
}

#endif
