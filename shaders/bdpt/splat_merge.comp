// bdpt with float splats (splat.glsl): the end of a pass. The odd-indexed samples' splats of
// the pass, gathered in B_BDPT_SPLAT_NEW, are added to the splats (B_SPLAT) and to their odd
// share (B_SPLAT_ODD), and B_BDPT_SPLAT_NEW is cleared for the next pass. A grid-stride loop
// over the film's pixels (any dispatch size covers it).
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_scalar_block_layout : require
#include "common/constants.glsl"

layout(local_size_x = 256, local_size_y = 1, local_size_z = 1) in;

layout(set = 0, binding = B_SPLAT, scalar) buffer Splat { vec4 splat[]; };
layout(set = 0, binding = B_SPLAT_ODD, scalar) buffer SplatOdd { vec4 splat_odd[]; };
layout(set = 0, binding = B_BDPT_SPLAT_NEW, scalar) buffer SplatNew { vec4 splat_new[]; };

void main() {
    uint n = uint(splat_new.length());
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += stride) {
        vec4 v = splat_new[i];
        if (v != vec4(0.0)) {
            splat[i] += v;
            splat_odd[i] += v;
            splat_new[i] = vec4(0.0);
        }
    }
}
