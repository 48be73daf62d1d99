// `deferred`, stage 1: the G-buffer. One thread per pixel and sample of the batch (z: the slice,
// i.e. sample pc.sample_base + z) casts the jittered camera ray of that sample through the BVH
// (closest hit) and stores the packed surface in the sample's slice (common.glsl: 16 bytes per
// pixel). The jitter differs per sample, so passes accumulate anti-aliasing like the path
// tracers do. (Its ray is counted by the shade stage.)
#version 460
#extension GL_GOOGLE_include_directive : require
#include "deferred/common.glsl"
#include "common/traverse.glsl"
#include "common/surface.glsl"

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uint slice = gl_GlobalInvocationID.z;
    if (px.x >= g.film.x || px.y >= g.film.y || slice >= pc.spp) return;
    uint pixel = gbuf_index(slice, px.y * g.film.x + px.x);
    // Step 1: the camera ray of this sample, as every later stage regenerates it.
    Rng rng;
    Ray ray = sample_camera_ray(px, pc.sample_base + slice, rng);
    // Step 2: primary visibility.
    Hit hit;
    if (!trace_closest(ray, hit)) {
        gbuf[pixel] = uvec4(0u, 0u, NONE, 0u);
    } else {
        // Step 3: the surface, packed: normal, depth, material and side, uv.
        Surface s = surface_at(hit, ray);
        bool front = dot(-ray.d, s.ng) > 0.0;
        gbuf[pixel] = gbuffer_pack(s.ns, hit.t, s.material, front, s.uv);
    }
}
